"""The per-FMU reference pages of the documentation, generated from the FMU catalogue.

Each FMU gets ``docs/fmus/<name>.md``: its description, what it implements (the docstring of
its library module, where the equations and the choices are written), and its inputs, outputs
and parameters with value references, units, ranges, defaults and descriptions: the
declarations the modelDescription is written from.  ``docs/fmus/index.md`` lists them all.
``python -m sideslip docs`` writes the pages; a test keeps the committed ones current.
"""
from __future__ import annotations

import importlib
import re
from pathlib import Path

from ..params import declared_fields, describe_range
from ..signals import SIGNALS
from .catalogue import CATALOGUE, ROLES, FmuSpec

__all__ = ["fmu_pages", "write_fmu_pages", "DOCS_FMU_DIR"]

DOCS_FMU_DIR = Path("docs") / "fmus"
"""Where the pages go, relative to the repository."""


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.6g}"
    return f"`{v!r}`" if isinstance(v, str) else str(v)


def _role(match) -> str:
    """``:class:`~a.b.C``` -> ```C```, ``:mod:`a.b``` -> ```a.b```."""
    target = match.group(1)
    return f"`{target[1:].rsplit('.', 1)[-1]}`" if target.startswith("~") else f"`{target}`"


def _markdown(docstring: str) -> str:
    """A numpydoc/reST module docstring as Markdown: roles become code, the rest is kept."""
    text = re.sub(r":\w+:`([^`]+)`", _role, docstring)
    lines = text.strip("\n").splitlines()
    out = []
    for i, line in enumerate(lines):
        # reST section underlines ("Title" over "-----") become Markdown headings
        if i + 1 < len(lines) and lines[i + 1] and set(lines[i + 1].strip()) == {"-"} and line.strip():
            out.append(f"### {line.strip()}")
            continue
        if line.strip() and set(line.strip()) == {"-"} and i > 0 and lines[i - 1].strip():
            continue
        out.append(line)
    return "\n".join(out)


def _value_references(spec: FmuSpec) -> dict[str, int]:
    """Value reference of every variable, from the wrapper class itself (as the build declares them)."""
    cls = getattr(importlib.import_module(spec.module), spec.name)
    instance = cls(instance_name="docs", resources=".")
    return {v.name: vr for vr, v in instance.vars.items()}


def _ports(names, vrs) -> list[str]:
    rows = ["| name | vr | type | unit | range | start | description |", "|---|---:|---|---|---|---|---|"]
    for n in names:
        s = SIGNALS[n]
        real = s.kind == "Real"
        rows.append(f"| `{n}` | {vrs[n]} | {s.kind} | {s.unit if real else ''} | "
                    f"{f'[{s.min:g}, {s.max:g}]' if real else ''} | {s.start:g} | {s.description} |"
                    if real else
                    f"| `{n}` | {vrs[n]} | {s.kind} | | | {'true' if s.start else 'false'} | {s.description} |")
    return rows


def _page(spec: FmuSpec) -> str:
    vrs = _value_references(spec)
    model = spec.model_class
    module = importlib.import_module(model.__module__)
    lines = [f"# {spec.name}", "",
             f"*{spec.role}* · library model `{model.__module__}.{model.__name__}` · configuration "
             f"`{spec.config_class.__name__}` · wrapper `fmu_src/{spec.module}.py`", "",
             spec.description + ".", "",
             "## What it implements", "", _markdown(module.__doc__ or ""), "",
             "## Inputs", ""]
    lines += _ports(spec.inputs, vrs) if spec.inputs else ["(none)"]
    lines += ["", "## Outputs", ""] + _ports(spec.outputs, vrs)
    lines += ["", "## Parameters", "",
              "Set before `fmi2ExitInitializationMode`; a value outside its range fails initialisation "
              "with a message naming the parameter and the range.", "",
              "| name | vr | type | unit | default | allowed | description |", "|---|---:|---|---|---|---|---|"]
    for f, info in declared_fields(spec.config_class):
        if not info.fmu:
            continue
        kind = {bool: "Boolean", int: "Integer", float: "Real", str: "String"}[type(f.default)]
        unit = "" if kind != "Real" or info.unit == "1" else info.unit
        allowed = "" if kind == "Boolean" or (kind == "String" and info.choices is None) else describe_range(info)
        lines.append(f"| `{f.name}` | {vrs[f.name]} | {kind} | {unit} | {_fmt(f.default)} | {allowed} | "
                     f"{info.description} |")
    lines += ["", "Value reference 0 is `_port_buffer`, a local String the FMU's native binary reads "
              "(not for users)."]
    return "\n".join(lines).rstrip() + "\n"


def _index() -> str:
    lines = ["# FMU reference", "",
             "Every FMU of the project, generated from the FMU catalogue (`sideslip/fmi/catalogue.py`) and the "
             "declarations the modelDescriptions are written from. Units are SI, angles in radians; "
             "ports follow the I/O contract (see [the user guide](../user-guide.md)).", "",
             "| FMU | role | inputs | outputs | parameters | implements |", "|---|---|---:|---:|---:|---|"]
    for spec in sorted(CATALOGUE.values(), key=lambda s: (ROLES.index(s.role), s.name)):
        n_par = sum(1 for _, info in declared_fields(spec.config_class) if info.fmu)
        doc = importlib.import_module(spec.model_class.__module__).__doc__ or ""
        first = _markdown(doc.split("\n\n")[0]).replace("\n", " ")
        lines.append(f"| [{spec.name}]({spec.name}.md) | {spec.role} | {len(spec.inputs)} | {len(spec.outputs)} | "
                     f"{n_par} | {first} |")
    return "\n".join(lines) + "\n"


def fmu_pages() -> dict[str, str]:
    """File name -> Markdown of every generated page (``index.md`` and one per FMU)."""
    pages = {"index.md": _index()}
    pages.update({f"{name}.md": _page(spec) for name, spec in sorted(CATALOGUE.items())})
    return pages


def write_fmu_pages(folder: Path | str = DOCS_FMU_DIR) -> list[Path]:
    """Write :func:`fmu_pages` into ``folder`` (removing pages of FMUs no longer in the catalogue)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    pages = fmu_pages()
    for stale in folder.glob("*.md"):
        if stale.name not in pages:
            stale.unlink()
    written = []
    for name, text in pages.items():
        (folder / name).write_text(text)
        written.append(folder / name)
    return written
