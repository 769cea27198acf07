"""Parameter files: values of one FMU's parameters (e.g. the chosen point of ``sideslip tune``) in a file that the
command line applies (``--params FILE``) and any FMI host can: JSON for scripts (fmpy's ``start_values``), or an
SSP parameter-value file (``.ssv``, SSP 1.0 ``ssv:ParameterSet``), the standard form that SSP tools load.

Every name and value is checked against the FMU's declared parameters when the file is read, with the same
messages as an FMU's initialisation (the name and the allowed range).
"""
from __future__ import annotations

import json
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement, fromstring, register_namespace, tostring

from ..params import build, declared_fields, one_of
from .catalogue import fmu_names, fmu_spec

__all__ = ["SSV_NS", "write_param_file", "read_param_file"]

SSV_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
"""The namespace of SSP 1.0 parameter-value files."""
register_namespace("ssv", SSV_NS)

_SSV_TYPES = {bool: "Boolean", int: "Integer", float: "Real", str: "String"}


def _declared(fmu: str) -> dict:
    """``{name: (default, info)}`` of the FMU's numeric parameters."""
    return {f.name: (f.default, info) for f, info in declared_fields(fmu_spec(fmu).config_class)}


def _checked(fmu: str, values: dict) -> dict:
    """``values`` with every name an FMU parameter and every value in its range
    (:class:`~sideslip.params.ParameterError` if not), as the parameters' types."""
    if fmu not in fmu_names():
        raise ValueError(one_of(fmu, fmu_names(), "FMU"))
    cfg = build(fmu_spec(fmu).config_class, values)
    return {name: getattr(cfg, name) for name in values}


def write_param_file(path, fmu: str, values: dict, info: dict | None = None) -> Path:
    """Write the values of parameters of ``fmu`` to ``path``: JSON (``{"fmu", "parameters", "info"}``) or, for a
    ``.ssv`` path, an SSP parameter-value file (``info`` is not written there).

    Raises
    ------
    ValueError
        An unknown FMU; :class:`~sideslip.params.ParameterError` for an unknown parameter or a value out of its
        range.
    """
    values = _checked(fmu, dict(values))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".ssv":
        root = Element(f"{{{SSV_NS}}}ParameterSet", version="1.0", name=f"{fmu}_{path.stem}")
        plist = SubElement(root, f"{{{SSV_NS}}}Parameters")
        declared = _declared(fmu)
        for name, value in values.items():
            default, info_ = declared[name]
            kind = _SSV_TYPES[type(default)]
            el = SubElement(SubElement(plist, f"{{{SSV_NS}}}Parameter", name=name), f"{{{SSV_NS}}}{kind}",
                            value=str(value).lower() if kind == "Boolean" else repr(value))
            if kind == "Real" and info_.unit:
                el.set("unit", info_.unit)
        path.write_bytes(b'<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root))
    else:
        path.write_text(json.dumps({"fmu": fmu, "parameters": values, "info": info or {}}, indent=1) + "\n")
    return path


def read_param_file(path, fmu: str | None = None) -> tuple[str, dict]:
    """The FMU and the parameter values of a file of :func:`write_param_file` (JSON or ``.ssv``).

    Parameters
    ----------
    path : path
        The file.
    fmu : str, optional
        The FMU the values are for: needed for an ``.ssv`` file (which does not name it), checked against a JSON
        file's.

    Raises
    ------
    ValueError
        A file that cannot be read or names another FMU; :class:`~sideslip.params.ParameterError` for an unknown
        parameter or a value out of its range.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ValueError(f"parameter file {path}: {exc.strerror or exc}") from None
    if path.suffix.lower() == ".ssv":
        if fmu is None:
            raise ValueError(f"parameter file {path}: an .ssv file does not name its FMU; say which")
        try:
            root = fromstring(text)
        except Exception as exc:  # noqa: BLE001 - any XML error is the file's
            raise ValueError(f"parameter file {path}: not XML ({exc})") from None
        values = {}
        for p in root.iter(f"{{{SSV_NS}}}Parameter"):
            typed = next(iter(p), None)
            if typed is None or "value" not in typed.attrib:
                raise ValueError(f"parameter file {path}: parameter {p.get('name')!r} has no value")
            values[p.get("name")] = typed.get("value")
        return fmu, _checked(fmu, values)
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"parameter file {path}: not JSON ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("parameters"), dict):
        raise ValueError(f"parameter file {path}: expected {{\"fmu\": ..., \"parameters\": {{...}}}}")
    named = data.get("fmu")
    if fmu is not None and named is not None and named != fmu:
        raise ValueError(f"parameter file {path} holds parameters of {named}, not of {fmu}")
    fmu = fmu or named
    if fmu is None:
        raise ValueError(f"parameter file {path}: it names no FMU (\"fmu\")")
    return fmu, _checked(fmu, data["parameters"])
