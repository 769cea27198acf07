"""Declared, validated parameters: one mechanism for configs, FMU parameters and error messages.

A configuration is a frozen dataclass whose fields are declared with :func:`param`
(default, quantity, description, allowed range).  :func:`check` validates every declared
field and raises :class:`ParameterError` naming the parameter, its value and the allowed
range; the FMU toolkit declares FMU parameters from the same fields, so the range in the
modelDescription and the one in the error message cannot disagree.
"""
from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

from .units import QUANTITIES

__all__ = ["ParamInfo", "ParameterError", "ParamGroup", "ChoiceIndices", "param", "redefault", "check",
           "declared_fields", "build", "parse_bool", "parse_assignment", "parse_assignments", "format_assignments",
           "describe_range", "did_you_mean", "one_of"]


class ParameterError(ValueError):
    """A parameter value outside its allowed set.

    Parameters
    ----------
    name : str
        Parameter name as the user sets it (e.g. ``"vehicle.m"`` or ``"Ts"``).
    value : object
        The offending value.
    allowed : str
        Human-readable allowed range or set, with unit.
    """

    def __init__(self, name: str, value: Any, allowed: str):
        self.name, self.value, self.allowed = name, value, allowed
        super().__init__(f"parameter '{name}' = {value!r} is invalid; allowed: {allowed}")

    def __reduce__(self):
        # rebuilt from its three fields, so it crosses a process pool or a Dask worker with its message
        return type(self), (self.name, self.value, self.allowed)


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` naming the known names closest to a misspelt ``name``, or ``""``."""
    close = difflib.get_close_matches(str(name), list(known), n=3, cutoff=0.6)
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


def one_of(name: str, known: Iterable[str], what: str) -> str:
    """The message of an unknown ``name`` among ``known`` ``what`` s: the closest ones first, then every one."""
    known = sorted(known)
    return f"unknown {what} {name!r}{did_you_mean(name, known)}; known: {', '.join(known)}"


@dataclass(frozen=True)
class ParamInfo:
    """Declaration attached to a dataclass field by :func:`param`."""

    quantity: str
    description: str
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    choices: tuple | None = None
    tunable: bool = False
    fmu: bool = True

    @property
    def unit(self) -> str:
        return QUANTITIES[self.quantity]

    @property
    def min(self) -> float:
        """Lower bound for the modelDescription (``-inf`` when unbounded; the least of numeric choices)."""
        if self.choices is not None and all(isinstance(c, (int, float)) for c in self.choices):
            return float(min(self.choices))
        lo = self.ge if self.ge is not None else self.gt
        return -math.inf if lo is None else float(lo)

    @property
    def max(self) -> float:
        """Upper bound for the modelDescription (``inf`` when unbounded; the greatest of numeric choices)."""
        if self.choices is not None and all(isinstance(c, (int, float)) for c in self.choices):
            return float(max(self.choices))
        hi = self.le if self.le is not None else self.lt
        return math.inf if hi is None else float(hi)


def param(default, quantity: str = "Dimensionless", description: str = "", *, ge=None, gt=None,
          le=None, lt=None, choices: Iterable | None = None, tunable: bool = False,
          fmu: bool = True):
    """Declare a configuration field.

    Parameters
    ----------
    default : float, int, bool or str
        Default value; its Python type is the parameter type.
    quantity : str
        Physical quantity (see :data:`sideslip.units.QUANTITIES`); gives the unit.
    description : str
        One-line description written into the modelDescription.
    ge, gt, le, lt : float, optional
        Inclusive/exclusive bounds.
    choices : iterable, optional
        Allowed values (strings).
    tunable : bool
        Whether the parameter may change during simulation (FMI variability).
    fmu : bool
        Whether the FMU toolkit exposes the field as an FMU parameter.
    """
    if quantity not in QUANTITIES:
        raise KeyError(f"unknown quantity {quantity!r}")
    info = ParamInfo(quantity, description, ge, gt, le, lt,
                     tuple(choices) if choices is not None else None, tunable, fmu)
    return dataclasses.field(default=default, metadata={"param": info})


def redefault(cls, name: str, default):
    """The field ``name`` of the config class ``cls`` with another default (a subclass's own default for a
    parameter it inherits: the declaration - quantity, description, range - stays in one place)."""
    field = next(f for f in dataclasses.fields(cls) if f.name == name)
    return dataclasses.field(default=default, metadata=field.metadata)


def declared_fields(cls_or_obj) -> list[tuple[dataclasses.Field, ParamInfo]]:
    """The ``(field, ParamInfo)`` pairs of a config class or instance, in declaration order."""
    return [(f, f.metadata["param"]) for f in dataclasses.fields(cls_or_obj) if "param" in f.metadata]


def describe_range(info: ParamInfo) -> str:
    """Allowed range of a declaration as text, e.g. ``"> 0 kg"`` or ``"[0, 1]"``."""
    unit = "" if info.unit == "1" else f" {info.unit}"
    if info.choices is not None:
        return "one of " + ", ".join(repr(c) for c in info.choices)
    lo_txt = None if info.ge is None and info.gt is None else (
        f"[{info.ge:g}" if info.ge is not None else f"({info.gt:g}")
    hi_txt = None if info.le is None and info.lt is None else (
        f"{info.le:g}]" if info.le is not None else f"{info.lt:g})")
    if lo_txt and hi_txt:
        return f"{lo_txt}, {hi_txt}{unit}"
    if lo_txt:
        return (">= " if info.ge is not None else "> ") + f"{(info.ge if info.ge is not None else info.gt):g}{unit}"
    if hi_txt:
        return ("<= " if info.le is not None else "< ") + f"{(info.le if info.le is not None else info.lt):g}{unit}"
    return f"any finite value{unit}"


def _check_value(name: str, value: Any, info: ParamInfo, typ: type) -> None:
    if typ is str:
        if not isinstance(value, str):
            raise ParameterError(name, value, "a string")
        if info.choices is not None and value not in info.choices:
            raise ParameterError(name, value, describe_range(info))
        return
    if typ is bool:
        if not isinstance(value, (bool, int)):
            raise ParameterError(name, value, "true or false")
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(name, value, f"a number, {describe_range(info)}")
    if info.choices is not None:
        if value not in info.choices:
            raise ParameterError(name, value, describe_range(info))
        return
    if not math.isfinite(value):              # a physical value is finite, whatever its bounds
        raise ParameterError(name, value, f"a finite number, {describe_range(info)}")
    if ((info.ge is not None and not value >= info.ge) or (info.gt is not None and not value > info.gt)
            or (info.le is not None and not value <= info.le)
            or (info.lt is not None and not value < info.lt)):
        raise ParameterError(name, value, describe_range(info))


def check(obj, prefix: str = "") -> None:
    """Validate every declared field of a config instance.

    Raises
    ------
    ParameterError
        For the first field outside its declared range (name prefixed with ``prefix``).
    """
    for f, info in declared_fields(obj):
        _check_value(prefix + f.name, getattr(obj, f.name), info, type(f.default))


def parse_bool(name: str, raw: Any) -> bool:
    """A Boolean from a bool, number or string (``true/false``, ``1/0``, ``yes/no``, ``on/off``).

    Raises
    ------
    ParameterError
        For any other string.
    """
    if isinstance(raw, str):
        low = raw.strip().lower()
        if low in ("1", "true", "yes", "on"):
            return True
        if low in ("0", "false", "no", "off"):
            return False
        raise ParameterError(name, raw, "true or false")
    return bool(raw)


def _coerce(name: str, raw: Any, typ: type, info: ParamInfo):
    if typ is str:
        return str(raw)
    if typ is bool:
        return parse_bool(name, raw)
    try:
        val = float(raw)
    except (TypeError, ValueError):
        raise ParameterError(name, raw, f"a number, {describe_range(info)}") from None
    if typ is int:
        if not val.is_integer():
            raise ParameterError(name, raw, f"an integer, {describe_range(info)}")
        return int(val)
    return val


def build(cls, values: Mapping[str, Any] | None = None, prefix: str = "", **kwargs):
    """Construct config ``cls`` from a mapping, converting types and validating.

    Unknown keys raise :class:`ParameterError` listing the accepted names, so a typo in a
    scenario, CLI ``--set`` or FMU string parameter is reported, not ignored.
    """
    merged = dict(values or {})
    merged.update(kwargs)
    fields = {f.name: (f, info) for f, info in declared_fields(cls)}
    other = {f.name for f in dataclasses.fields(cls)} - set(fields)
    converted = {}
    for key, raw in merged.items():
        if key in fields:
            f, info = fields[key]
            converted[key] = _coerce(prefix + key, raw, type(f.default), info)
        elif key in other:
            converted[key] = raw
        else:
            raise ParameterError(prefix + key, raw, "a known name" + did_you_mean(key, fields) + ": "
                                 + ", ".join(sorted(fields)))
    try:
        return cls(**converted)
    except ParameterError as exc:      # name the context (e.g. "maneuver sine_steer: frequency")
        if prefix and not exc.name.startswith(prefix):
            raise ParameterError(prefix + exc.name, exc.value, exc.allowed) from None
        raise


def parse_assignment(item: str, name: str = "overrides", allowed: str = "key=value") -> tuple[str, str]:
    """Split one ``"key=value"`` item into ``("key", "value")`` (both stripped); the value may hold
    further ``=`` signs.

    Raises
    ------
    ParameterError
        When the item has no ``=`` or an empty key.
    """
    key, sep, val = item.partition("=")
    if not sep or not key.strip():
        raise ParameterError(name, item, allowed)
    return key.strip(), val.strip()


def parse_assignments(text: str, name: str = "overrides") -> dict[str, str]:
    """Parse ``"a=1, b=2.5; c=x"`` into ``{"a": "1", "b": "2.5", "c": "x"}`` (items separated by
    commas or semicolons, each read by :func:`parse_assignment`).

    Raises
    ------
    ParameterError
        When an item is not of the form ``key=value``.
    """
    out: dict[str, str] = {}
    for item in text.replace(";", ",").split(","):
        if item.strip():
            key, val = parse_assignment(item.strip(), name, "comma-separated key=value items")
            out[key] = val
    return out


def format_assignments(values: Mapping[str, Any]) -> str:
    """The text ``"a=1.5, b=x"`` that :func:`parse_assignments` reads back to the same values (floats
    written with ``repr``, so exactly)."""
    return ", ".join(f"{k}={v!r}" if isinstance(v, float) else f"{k}={v}" for k, v in values.items())


def _numbered(choices) -> str:
    """``"1 a, 2 b"``: the numbers of an enumeration's choices."""
    return ", ".join(f"{i} {c}" for i, c in enumerate(choices, 1))


@dataclass(frozen=True)
class ParamGroup:
    """The declared fields of a configuration class as a group of parameters ``<prefix>.<field>``.

    What a host that cannot set String parameters uses instead of a text spec (a vehicle file, a
    maneuver spec): every numeric or Boolean field, and every text field with ``choices`` as an
    Integer enumeration ``1..n`` (text fields without choices are left out).

    Parameters
    ----------
    prefix : str
        Parameter names are ``prefix + "." + field``.
    cls : type
        Dataclass of :func:`param` fields.
    defaults : Mapping
        Start value of each field (e.g. the default vehicle's); the dataclass defaults where absent.
    """

    prefix: str
    cls: type
    defaults: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def parameters(self) -> list[tuple[str, Any, ParamInfo]]:
        """``(name, start, info)`` of every parameter of the group, in declaration order."""
        out = []
        for f, info in declared_fields(self.cls):
            if not info.fmu or (isinstance(f.default, str) and info.choices is None):
                continue
            start = self.defaults.get(f.name, f.default)
            if isinstance(f.default, str):               # an enumeration 1..n of the choices
                start = info.choices.index(start) + 1
                info = dataclasses.replace(info, description=f"{info.description} ({_numbered(info.choices)})",
                                           choices=None,
                                           ge=1, gt=None, le=len(info.choices), lt=None)
            out.append((f"{self.prefix}.{f.name}", start, info))
        return out

    def _choices(self, field: str) -> tuple:
        return dict((f.name, i.choices) for f, i in declared_fields(self.cls))[field]

    def values(self, parameters: Mapping[str, Any]) -> dict[str, Any]:
        """The field values of parameter values ``{"<prefix>.<field>": value}`` (enumerations back to
        their text), each checked against its declared range (errors name the parameter)."""
        types = {f.name: (type(f.default), info) for f, info in declared_fields(self.cls)}
        out = {}
        for name, start, info in self.parameters():
            field = name[len(self.prefix) + 1:]
            value = parameters.get(name, start)
            typ, declared = types[field]
            if typ is str:
                _check_value(name, value, info, int)
                value = declared.choices[int(value) - 1]
            else:
                _check_value(name, value, declared, typ)
            out[field] = value
        return out

    def numbers(self, obj) -> dict[str, Any]:
        """The parameter values that stand for the fields of ``obj`` (an instance of ``cls``)."""
        out = {}
        for name, _, _ in self.parameters():
            field = name[len(self.prefix) + 1:]
            value = getattr(obj, field)
            out[name] = self._choices(field).index(value) + 1 if isinstance(value, str) else value
        return out

    def changed(self, parameters: Mapping[str, Any]) -> dict[str, Any]:
        """The fields whose parameter differs from its start value (checked like :meth:`values`)."""
        starts = {name[len(self.prefix) + 1:]: start for name, start, _ in self.parameters()}
        out = {}
        for field, value in self.values(parameters).items():
            start = starts[field]
            if isinstance(value, str):
                start = self._choices(field)[start - 1]
            if value != start:
                out[field] = value
        return out


@dataclass(frozen=True)
class ChoiceIndices:
    """Integer stand-ins ``<field>_index`` of a configuration's text fields with ``choices``.

    A ``<field>_index`` of ``0`` (its start value) keeps the String ``<field>``; ``1..n`` selects the
    n-th choice and wins over the String.
    """

    cls: type

    def parameters(self) -> list[tuple[str, int, ParamInfo]]:
        """``(name, 0, info)`` of every stand-in, in declaration order."""
        out = []
        for f, info in declared_fields(self.cls):
            if info.fmu and isinstance(f.default, str) and info.choices is not None:
                out.append((f"{f.name}_index", 0, ParamInfo(
                    "Dimensionless", f"{info.description}, as a number: 0 the String '{f.name}', "
                    f"{_numbered(info.choices)}",
                    ge=0, le=len(info.choices))))
        return out

    def numbers(self, config) -> dict[str, int]:
        """The stand-ins that select what ``config``'s text fields hold."""
        return {name: self.cls.__dataclass_fields__[name[:-len("_index")]].metadata["param"].choices.index(
            getattr(config, name[:-len("_index")])) + 1 for name, _, _ in self.parameters()}

    def apply(self, config, values: Mapping[str, Any]):
        """``config`` with every stand-in of ``values`` that is not 0 applied (checked like any parameter)."""
        changes = {}
        for name, start, info in self.parameters():
            index = values.get(name, start)
            _check_value(name, index, info, int)
            if index:
                field = name[:-len("_index")]
                changes[field] = self.cls.__dataclass_fields__[field].metadata["param"].choices[index - 1]
        return dataclasses.replace(config, **changes) if changes else config
