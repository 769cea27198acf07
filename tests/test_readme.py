"""The README's FMU tables are the ones generated from the declarations; its commands exist."""
from pathlib import Path

from sideslip.fmi.docs import BEGIN, END, fmu_tables_markdown

ROOT = Path(__file__).resolve().parents[1]


def test_readme_fmu_tables_are_current():
    text = (ROOT / "README.md").read_text()
    embedded = text[text.index(BEGIN) + len(BEGIN):text.index(END)].strip()
    assert embedded == fmu_tables_markdown().strip(), "run: python -m sideslip fmu-tables and paste into README"


def test_ci_runs_the_readme_test_command():
    readme = (ROOT / "README.md").read_text()
    command = 'python3 -m venv .venv && .venv/bin/pip install -e ".[test]" && .venv/bin/python -m pytest'
    assert command in readme
    assert command in (ROOT / ".ci" / "run").read_text()
