"""The documentation: generated pages current, the site builds strictly, the README's commands and
its closed-loop example run, no link leaves the repository."""
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from sideslip.fmi.docs import fmu_pages

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_the_design_page_states_the_signal_contract():
    """Every signal of the contract's groups is named on docs/design.md, which the code cites."""
    from sideslip import signals

    design = (ROOT / "docs" / "design.md").read_text()
    groups = ("PLANT_INPUTS", "PLANT_OUTPUTS", "SENSOR_OUTPUTS", "DRIVER_INPUTS", "DRIVER_OUTPUTS",
              "ESTIMATOR_COMMON_OUTPUTS", "CONTROLLER_INPUTS", "CONTROLLER_EXTRA_INPUTS", "CONTROLLER_OUTPUTS")
    missing = [n for g in groups for n in getattr(signals, g) if f"`{n}`" not in design]
    assert missing == []
    cited = [p for p in (ROOT / "fmu_src").rglob("*.py") if "DESIGN.md" in p.read_text()]
    assert cited == []


def test_the_fmu_reference_pages_are_current():
    pages = fmu_pages()
    committed = {p.name: p.read_text() for p in (ROOT / "docs" / "fmus").glob("*.md")}
    assert committed == pages, "run: python -m sideslip docs"


def test_the_site_builds_without_warnings(tmp_path):
    mkdocs = shutil.which("mkdocs", path=str(Path(sys.executable).parent)) or shutil.which("mkdocs")
    if mkdocs is None:
        pytest.skip("mkdocs is not installed (pip install -e '.[docs]')")
    proc = subprocess.run([mkdocs, "build", "--strict", "--site-dir", str(tmp_path / "site")], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "site" / "fmus" / "Park2018Observer" / "index.html").is_file()


def test_ci_runs_the_readme_test_command():
    command = 'python3 -m venv .venv && .venv/bin/pip install -e ".[test]" && .venv/bin/python -m pytest'
    assert command in README
    assert command in (ROOT / ".ci" / "run").read_text()


def test_readme_is_short_and_links_only_into_the_repository():
    assert len(README.splitlines()) <= 200
    for target in re.findall(r"\]\(([^)#]+)", README):
        assert not target.startswith(("http", "..", "/")), target
        assert (ROOT / target).exists(), target


def test_no_page_speaks_of_how_it_was_made_or_cites_a_file_name():
    texts = {p: p.read_text() for p in [ROOT / "README.md", *(ROOT / "docs").rglob("*.md")]}
    for path, text in texts.items():
        assert not re.search(r"\bthe (issue|task)\b", text, re.IGNORECASE), path
        assert not re.search(r"\b00[0-4]_[0-9a-f]{4,}", text), path


def test_the_readme_closed_loop_example_runs(fmu_dir):
    block = README.split("```python\n", 1)[1].split("```", 1)[0]
    block = block.replace("CoSimulation(components, step=1e-3)", f"CoSimulation(components, step=1e-3, fmu_dir={str(fmu_dir)!r})")
    block = block.replace("sim.run(8.0)", "sim.run(2.0)")
    namespace = {}
    exec(compile(block, "README.md", "exec"), namespace)
    res = namespace["res"]
    assert res["time"][-1] == pytest.approx(2.0)
    assert abs(res["estimator.beta_hat"][-1] - res["plant.beta"][-1]) < 0.02
    assert res["controller.Mz_cmd"].any()
