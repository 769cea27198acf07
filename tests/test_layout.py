"""The layers of docs/design.md, checked mechanically: the repository's top level, which package may import
which, no import circles, the FMU catalogue against the wrappers, and a non-editable install that lists and
builds every FMU."""
import re
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

from sideslip.estimators import ESTIMATORS
from sideslip.fmi.bundle import PACKAGE_DIR, bundled_files, module_imports, module_name, wrapper_script
from sideslip.fmi.catalogue import CATALOGUE, PLANT_PACKAGE, PLANT_SIDE, fmu_names
from sideslip.fmi.slave import SideslipSlave

ROOT = Path(__file__).resolve().parents[1]

LAYERS = {"core": 0, "fmi": 1, "cosim": 2, "studies": 3, "cli": 4}
"""A module may import modules of its own layer and of the layers before it."""

_CORE = {"numpy", "scipy", "control", "vehiclemodels", "tqdm", "pyarrow", "asammdf"}
THIRD_PARTY = {"core": _CORE,
               "fmi": _CORE | {"pythonfmu", "fmpy"},
               "cosim": _CORE | {"pythonfmu", "fmpy", "libcosimpy", "OMSimulator", "pandas"},
               "studies": _CORE | {"fmpy", "matplotlib", "distributed", "optuna"},
               "cli": {"numpy"}}
"""Third-party packages each layer may import (the core never imports pythonfmu or fmpy; tqdm for progress bars,
pyarrow and asammdf for the logs' formats, each imported where it is used)."""


def _layer(name: str) -> str:
    parts = name.split(".")
    if len(parts) > 1 and parts[1] in ("fmi", "cosim", "studies"):
        return parts[1]
    if len(parts) > 1 and parts[1] in ("cli", "__main__"):
        return "cli"
    return "core"


def _graph() -> dict[str, set[str]]:
    """Module -> the project modules it imports (anywhere in the file, functions included)."""
    files = {module_name(p): p for p in PACKAGE_DIR.rglob("*.py")}
    graph = {}
    for name, path in files.items():
        targets = set()
        for imported in module_imports(path):
            while imported and imported not in files:          # "pkg.mod.attr" -> "pkg.mod"
                imported = imported.rpartition(".")[0]
            if imported and imported != name:
                targets.add(imported)
        graph[name] = targets
    return graph


def test_no_module_imports_a_later_layer():
    offenders = [(m, t) for m, targets in _graph().items() for t in targets
                 if LAYERS[_layer(t)] > LAYERS[_layer(m)]]
    assert offenders == []


def test_each_layer_imports_only_its_third_party_packages():
    offenders = []
    for path in PACKAGE_DIR.rglob("*.py"):
        name = module_name(path)
        tops = {i.split(".")[0] for i in module_imports(path)} - {"sideslip", "__future__"}
        bad = {t for t in tops if t not in sys.stdlib_module_names} - THIRD_PARTY[_layer(name)]
        if bad:
            offenders.append((name, sorted(bad)))
    assert offenders == []


def test_the_import_graph_has_no_circle():
    """Tarjan's strongly connected components on the module graph: every component is one module.
    Imports of a package's ``__init__`` by its own submodules would be circles too."""
    graph = _graph()
    index, low, stack, on_stack, circles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            visit(v)
    assert circles == []


def test_importing_the_library_core_pulls_in_neither_pythonfmu_nor_fmpy():
    core = sorted(m for m in _graph() if _layer(m) == "core" and not m.endswith("__main__"))
    code = (f"import sys, importlib; [importlib.import_module(m) for m in {core!r}]; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pythonfmu', 'fmpy')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_top_level_is_the_projects_layout():
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    top = {path.split("/")[0] for path in tracked}
    assert top == {"pyproject.toml", "setup.py", "fmu_src", "build_fmu.py", "plant_fmus", "examples", "tests",
                   "README.md", "docs", "mkdocs.yml", ".ci", ".gitignore"}


def test_no_estimator_function_is_longer_than_a_reader_can_hold():
    """The estimators' functions stay under 80 lines; a paper's sample is its stages and its hardened profile's
    departures are _hardened_* hooks (sideslip.estimators.profiles)."""
    import ast

    long = []
    for path in (PACKAGE_DIR / "estimators").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and node.end_lineno - node.lineno + 1 > 80:
                long.append(f"{path.relative_to(PACKAGE_DIR)}:{node.name}")
    assert long == []


# ---------------------------------------------------------------- the FMU catalogue
def test_every_catalogue_entry_has_its_wrapper_and_no_wrapper_is_outside_the_catalogue():
    """Estimator and controller wrappers in fmu_src/, the plant side's in plant_fmus/."""
    for folder, plant_side in (("fmu_src", False), ("plant_fmus", True)):
        wrappers = {p.stem for p in (ROOT / folder).glob("*_fmu.py")}
        assert wrappers == {s.module for s in CATALOGUE.values() if (s.role in PLANT_SIDE) == plant_side}
    for spec in CATALOGUE.values():
        assert wrapper_script(spec) == ROOT / spec.source_folder / f"{spec.module}.py"


@pytest.mark.parametrize("name", sorted(CATALOGUE))
def test_a_wrapper_binds_its_class_and_takes_everything_from_the_catalogue(name):
    import importlib
    import inspect

    spec = CATALOGUE[name]
    module = importlib.import_module(spec.import_name)
    classes = [c for _, c in inspect.getmembers(module, inspect.isclass)
               if issubclass(c, SideslipSlave) and c.__module__ == spec.import_name]
    assert [c.__name__ for c in classes] == [name]
    cls = classes[0]
    assert (cls.model_class, cls.config_class, cls.role, cls.description) == (
        spec.model_class, spec.config_class, spec.role, spec.description)
    assert list(cls.model_class.input_names) == list(spec.inputs)
    assert len(wrapper_script(spec).read_text().splitlines()) <= 10


def test_the_catalogue_estimators_are_the_library_estimators():
    assert fmu_names("estimator") == sorted(ESTIMATORS)
    for name in fmu_names("estimator"):
        assert CATALOGUE[name].model_class is ESTIMATORS[name]


def test_pyproject_installs_every_wrapper_and_package():
    setup = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert sorted(setup["py-modules"]) == sorted(s.module for s in CATALOGUE.values() if s.role not in PLANT_SIDE)
    assert setup["package-dir"] == {"": "fmu_src", PLANT_PACKAGE: "plant_fmus"}
    packages = {".".join(p.parent.relative_to(ROOT / "fmu_src").parts)
                for p in PACKAGE_DIR.rglob("__init__.py")}
    assert sorted(setup["packages"]) == sorted(packages | {PLANT_PACKAGE})


@pytest.mark.parametrize("name", ["VehiclePlant", "Park2018Observer", "StabilityController"])
def test_an_fmu_bundles_only_what_runs_inside_it(name):
    files = {str(p.relative_to(PACKAGE_DIR)) for p in bundled_files(CATALOGUE[name])}
    assert not any(f.startswith(("cosim", "studies", "cli", "__main__")) for f in files)
    assert not {"fmi/build.py", "fmi/bundle.py", "fmi/docs.py"} & files
    assert {"fmi/slave.py", "fmi/catalogue.py", "signals.py", "vehicles/pi2011_suv.toml", "plant/vehicle.py",
            "estimators/park2018.py", "control/dyc.py"} <= files


def test_a_non_editable_install_lists_and_builds_every_fmu(tmp_path):
    """``pip install .`` into a folder, then list and build the FMUs from there, with nothing of the
    source tree on the path (``python -S``: no site-packages .pth, so no editable finder)."""
    import shutil

    source = tmp_path / "source"                     # a clean copy: setuptools builds in the source tree
    for folder in ("fmu_src", "plant_fmus"):
        shutil.copytree(ROOT / folder, source / folder, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, source / name)
    target = tmp_path / "site"
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--quiet",
                           "--target", str(target), str(source)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    site = sysconfig.get_paths()["purelib"]
    env = {"PYTHONPATH": f"{target}:{site}", "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    code = ("import sideslip, sys; from sideslip.fmi.catalogue import fmu_names; "
            "from sideslip.fmi.build import build_fmus; print(sideslip.__file__); print(' '.join(fmu_names())); "
            "build_fmus(None, sys.argv[1], log=lambda m: None)")
    out = subprocess.run([sys.executable, "-S", "-c", code, str(tmp_path / "fmus")], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=900)
    assert out.returncode == 0, out.stderr
    installed, names = out.stdout.splitlines()[:2]
    assert installed.startswith(str(target)) and names.split() == fmu_names()
    for name in fmu_names():
        with zipfile.ZipFile(tmp_path / "fmus" / f"{name}.fmu") as z:
            assert z.testzip() is None
            assert any(re.fullmatch(rf"resources/{CATALOGUE[name].module}_[0-9a-f]{{12}}\.py", n) for n in z.namelist())
            assert re.search(r'modelIdentifier="%s"' % name, z.read("modelDescription.xml").decode())
