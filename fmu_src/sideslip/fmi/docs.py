"""Markdown I/O tables of the FMUs, generated from the same declarations the FMUs are built from.

``python -m sideslip fmu-tables`` prints them; the README embeds the output between the
markers ``<!-- fmu-tables:begin -->`` / ``<!-- fmu-tables:end -->`` and a test keeps it current.
"""
from __future__ import annotations

from ..params import declared_fields, describe_range
from ..signals import SIGNALS
from .registry import fmu_entries

__all__ = ["fmu_tables_markdown", "BEGIN", "END"]

BEGIN, END = "<!-- fmu-tables:begin -->", "<!-- fmu-tables:end -->"


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return repr(v) if isinstance(v, str) else str(v)


def _ports(names) -> list[str]:
    rows = ["| name | type | unit | range | description |", "|---|---|---|---|---|"]
    for n in names:
        s = SIGNALS[n]
        rng = "" if s.kind == "Boolean" else f"[{s.min:g}, {s.max:g}]"
        rows.append(f"| `{n}` | {s.kind} | {'' if s.kind == 'Boolean' else s.unit} | {rng} | {s.description} |")
    return rows


def fmu_tables_markdown() -> str:
    """One section per FMU: inputs, outputs and parameters with units, ranges and defaults."""
    out = []
    order = {"driver": 0, "plant": 1, "sensors": 2, "estimator": 3, "controller": 4}
    for name, e in sorted(fmu_entries().items(), key=lambda kv: (order[kv[1].role], kv[0])):
        cls = e.slave_class
        out += [f"### {name} ({e.role})", "", cls.description, "", "Inputs:", ""] + _ports(e.inputs)
        out += ["", "Outputs:", ""] + _ports(e.outputs)
        out += ["", "Parameters:", "", "| name | default | unit | allowed | description |", "|---|---|---|---|---|"]
        for f, info in declared_fields(cls.config_class):
            if not info.fmu:
                continue
            unit = "" if isinstance(f.default, str) or info.unit == "1" else info.unit
            allowed = "" if isinstance(f.default, str) and info.choices is None else describe_range(info)
            out.append(f"| `{f.name}` | {_fmt(f.default)} | {unit} | {allowed} | {info.description} |")
        out.append("")
    return "\n".join(out).rstrip() + "\n"
