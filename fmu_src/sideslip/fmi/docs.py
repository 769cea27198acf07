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

from ..params import ChoiceIndices, declared_fields, describe_range
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
    cls = getattr(importlib.import_module(spec.import_name), spec.name)
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
    module = importlib.import_module(spec.library_module)         # the module (or package) the catalogue names
    lines = [f"# {spec.name}", "",
             f"*{spec.role}* · library model `{spec.library_module}.{model.__name__}` · configuration "
             f"`{spec.config_class.__name__}` · wrapper `{spec.source_folder}/{spec.module}.py`", "",
             spec.description + ".", "",
             "## What it implements", "", _markdown(module.__doc__ or ""), "",
             "## Inputs", ""]
    lines += _ports(spec.inputs, vrs) if spec.inputs else ["(none)"]
    lines += ["", "## Outputs", ""] + _ports(spec.outputs, vrs)
    lines += ["", "## Parameters", "",
              "Set before `fmi2ExitInitializationMode`; a value outside its range fails initialisation "
              "with a message naming the parameter and the range.", "",
              _HEADER, _RULE]
    lines += [_param_row(f.name, f.default, info, vrs) for f, info in declared_fields(spec.config_class) if info.fmu]
    groups, choices = _groups(spec), ChoiceIndices(spec.config_class).parameters()
    if groups or choices:
        lines += ["", "## Numeric configuration", "",
                  "For hosts that cannot set String parameters (OMSimulator applies only Real, Integer and Boolean "
                  "start values): numeric parameters that stand in for the String ones. "
                  + _markdown(" ".join((_precedence(spec), " ".join(ChoiceIndices.__doc__.split("\n\n")[1].split())))),
                  ""]
    if choices:
        lines += ["", "### Choices as numbers", "", _HEADER, _RULE]
        lines += [_param_row(name, start, info, vrs) for name, start, info in choices]
    for group in groups:
        params = group.parameters()
        first, last = vrs[params[0][0]], vrs[params[-1][0]]
        if group.prefix in _SHARED_GROUPS:
            lines += ["", f"- `{group.prefix}.*` (value references {first}-{last}): every field of "
                      f"[the {group.prefix} parameters]({group.prefix}-parameters.md), start values those of the "
                      f"default `{spec.config_class.__dataclass_fields__[group.prefix].default}`."]
        else:
            lines += ["", f"### `{group.prefix}.*`", "", _HEADER, _RULE]
            lines += [_param_row(name, start, info, vrs) for name, start, info in params]
    lines += ["", "Value reference 0 is `_port_buffer`, a local String the FMU's native binary reads "
              "(not for users)."]
    return "\n".join(lines).rstrip() + "\n"


_HEADER, _RULE = "| name | vr | type | unit | default | allowed | description |", "|---|---:|---|---|---|---|---|"

_SHARED_GROUPS = ("vehicle",)
"""Groups documented once on their own page (``<prefix>-parameters.md``), not on every FMU's."""


def _param_cells(default, info) -> tuple[str, str, str, str, str]:
    """Type, unit, default, allowed range and description of a parameter."""
    kind = {bool: "Boolean", int: "Integer", float: "Real", str: "String"}[type(default)]
    unit = "" if kind != "Real" or info.unit == "1" else info.unit
    allowed = "" if kind == "Boolean" or (kind == "String" and info.choices is None) else describe_range(info)
    return kind, unit, _fmt(default), allowed, info.description


def _param_row(name: str, default, info, vrs) -> str:
    kind, unit, start, allowed, description = _param_cells(default, info)
    return f"| `{name}` | {vrs[name]} | {kind} | {unit} | {start} | {allowed} | {description} |"


def _groups(spec: FmuSpec) -> tuple:
    return tuple(getattr(spec.config_class, "parameter_groups", tuple)())


def _precedence(spec: FmuSpec) -> str:
    """The precedence rules: the docstrings of the config's ``with_parameter_groups`` (first paragraphs)."""
    texts = []
    for cls in spec.config_class.__mro__:
        method = cls.__dict__.get("with_parameter_groups")
        if method is not None and method.__doc__:
            paragraphs = [p for p in method.__doc__.split("\n\n") if p.strip()]
            texts.append(" ".join(" ".join(paragraphs[1].split()).split("\n")) if len(paragraphs) > 1 else "")
    return " ".join(t for t in reversed(texts) if t)


def _shared_group_page(prefix: str) -> str:
    from ..vehicles import load_vehicle, vehicle_names
    group = next(g for spec in CATALOGUE.values() for g in _groups(spec) if g.prefix == prefix)
    names = vehicle_names()
    vehicles = [load_vehicle(n) for n in names]
    lines = [f"# The {prefix} parameters", "",
             f"Every FMU that takes a vehicle has these numeric parameters `{prefix}.<field>` besides the String "
             "`vehicle` (a bundled name or a TOML file) and `vehicle_overrides`. Their start values are those of "
             "the FMU's default vehicle (named on its page); the values of every bundled vehicle are below.", "",
             "| name | type | unit | allowed | description | " + " | ".join(f"`{n}`" for n in names) + " |",
             "|---|---|---|---|---|" + "---:|" * len(names)]
    for name, start, info in group.parameters():
        kind, unit, _, allowed, description = _param_cells(start, info)
        values = (_fmt(getattr(v, name[len(prefix) + 1:])) for v in vehicles)
        lines.append(f"| `{name}` | {kind} | {unit} | {allowed} | {description} | " + " | ".join(values) + " |")
    return "\n".join(lines) + "\n"


def _index() -> str:
    lines = ["# FMU reference", "",
             "Every FMU of the project, generated from the FMU catalogue (`sideslip/fmi/catalogue.py`) and the "
             "declarations the modelDescriptions are written from. Units are SI, angles in radians; "
             "ports follow the I/O contract (see [the user guide](../user-guide.md)).", "",
             "| FMU | role | inputs | outputs | parameters | implements |", "|---|---|---:|---:|---:|---|"]
    for spec in sorted(CATALOGUE.values(), key=lambda s: (ROLES.index(s.role), s.name)):
        n_par = sum(1 for _, info in declared_fields(spec.config_class) if info.fmu) + sum(
            len(g.parameters()) for g in (ChoiceIndices(spec.config_class), *_groups(spec)))
        doc = importlib.import_module(spec.library_module).__doc__ or ""
        first = _markdown(doc.split("\n\n")[0]).replace("\n", " ")
        lines.append(f"| [{spec.name}]({spec.name}.md) | {spec.role} | {len(spec.inputs)} | {len(spec.outputs)} | "
                     f"{n_par} | {first} |")
    lines += ["", "Shared numeric parameters: " + ", ".join(f"[`{p}.*`]({p}-parameters.md)" for p in _SHARED_GROUPS)
              + " (every FMU that takes a vehicle)."]
    return "\n".join(lines) + "\n"


def fmu_pages() -> dict[str, str]:
    """File name -> Markdown of every generated page (``index.md`` and one per FMU)."""
    pages = {"index.md": _index()}
    pages.update({f"{prefix}-parameters.md": _shared_group_page(prefix) for prefix in _SHARED_GROUPS})
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
