"""Architecture rules of DESIGN.md that can be checked mechanically."""
import ast
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "fmu_src" / "sideslip"


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_only_the_fmu_toolkit_and_the_master_import_pythonfmu_or_fmpy():
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE).parts
        allowed = {"fmi": {"pythonfmu", "fmpy"}, "cosim": {"fmpy"}}.get(rel[0], set())
        bad = (_imports(path) & {"pythonfmu", "fmpy"}) - allowed
        if bad:
            offenders.append((str(path.relative_to(PACKAGE)), bad))
    assert offenders == []


def test_importing_the_algorithms_pulls_in_neither_pythonfmu_nor_fmpy():
    code = ("import sys, sideslip, sideslip.plant.vehicle, sideslip.plant.sensors, sideslip.plant.driver, "
            "sideslip.bicycle, sideslip.cosim.scenarios, sideslip.cosim.metrics; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pythonfmu', 'fmpy')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_wrapper_modules_have_project_unique_names():
    root = PACKAGE.parents[1]
    wrappers = list((root / "plant_fmus").glob("*.py")) + list((root / "fmu_src").glob("*_fmu.py"))
    assert wrappers and all(w.stem.startswith("sideslip_") or w.stem.endswith("_fmu") for w in wrappers)
    assert all(w.stem.endswith("_fmu") for w in wrappers)
