"""Values of FMI variables by type: the one conversion every master, exporter and test harness uses.

A parameter set from a scenario, the command line or an SSP file may arrive as a number, a
Boolean or a string; :func:`fmi_value` turns it into the Python value of the variable's FMI
type (``"false"`` is False, ``"2"`` an Integer 2), naming the variable when it cannot.
"""
from __future__ import annotations

from ..params import ParameterError, parse_bool

__all__ = ["FMI_TYPES", "fmi_value", "format_value"]

FMI_TYPES = ("Real", "Integer", "Boolean", "String")


def fmi_value(fmi_type: str, value, name: str = "value"):
    """``value`` as the Python value of an FMI variable of type ``fmi_type``.

    Raises
    ------
    ParameterError
        When the value cannot be converted (names ``name``).
    ValueError
        For an unknown FMI type.
    """
    try:
        if fmi_type == "Real":
            return float(value)
        if fmi_type == "Integer":
            number = float(value)
            if not number.is_integer():
                raise ValueError
            return int(number)
    except (TypeError, ValueError):
        raise ParameterError(name, value, f"a {'number' if fmi_type == 'Real' else 'whole number'}") from None
    if fmi_type == "Boolean":
        return parse_bool(name, value)
    if fmi_type == "String":
        return str(value)
    raise ValueError(f"unknown FMI type {fmi_type!r} of {name}; one of {', '.join(FMI_TYPES)}")


def format_value(fmi_type: str, value, name: str = "value") -> str:
    """The text of a value in an XML attribute (SSP parameter values, start values)."""
    v = fmi_value(fmi_type, value, name)
    if fmi_type == "Real":
        return repr(v)
    if fmi_type == "Boolean":
        return "true" if v else "false"
    return str(v)
