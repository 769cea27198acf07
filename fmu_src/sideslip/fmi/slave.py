"""The FMU toolkit: a pythonfmu ``Fmi2Slave`` base that declares ports from the signal catalogue.

An FMU wrapper is a class statement named like its entry in the FMU catalogue
(:mod:`sideslip.fmi.catalogue`)::

    class VehiclePlant(SideslipSlave):
        pass

The entry gives the library model class (``input_names``, ``output_names``, ``step(h, *u)``,
``outputs()``), its configuration dataclass of declared parameters, the role and the
description, and this base does the rest:

* ports: every input/output from :mod:`sideslip.signals` (unit, declaredType, min/max,
  description, start); parameters from the config's declared fields;
* modelDescription: UnitDefinitions/TypeDefinitions, outputs ``initial="exact"`` with
  ``dependencies=""`` (outputs change only in doStep), explicit parameter variability,
  DefaultExperiment;
* initialisation: the config is built and validated in ``exit_initialization_mode``; a
  bad value is logged at error status naming the parameter and its range (the status shim
  turns that into ``fmi2Error``), and the instance refuses to step;
* ports in shared memory: port values live in a ctypes ``double`` array whose address and
  layout are published in the local variable ``_port_buffer`` (value reference 0); the
  status shim serves ``fmi2Get/SetReal/Boolean`` on ports straight from it, so the hot
  path never enters Python (parameters and everything else still go through pythonfmu);
* inputs are checked at the start of every ``doStep``: non-finite values are replaced by
  the last valid value and values outside the catalogue range are clamped, each reported
  once at warning status; the model never sees NaN and no output is ever NaN;
* state: get/set/serialise FMU state copies the whole library object (filter state,
  buffers, RNG) and every variable value;
* no Python exception ever reaches pythonfmu (it would turn it into fmi2Fatal and free
  the instance): every entry point catches and logs.
"""
from __future__ import annotations

import copy
import ctypes
import functools
import math
import pickle
import sys
import traceback
from operator import le
from typing import Any
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Initial, Fmi2Status

from .. import __version__
from ..params import ParameterError, build, declared_fields, describe_range
from ..signals import signal
from ..units import QUANTITIES, UNITS
from .catalogue import fmu_spec

__all__ = ["SideslipSlave", "keep_module_dict_alive"]

_ERROR, _WARNING, _OK = Fmi2Status.error, Fmi2Status.warning, Fmi2Status.ok


def keep_module_dict_alive(namespace: dict) -> None:
    """Compensate pythonfmu 0.7's extra ``Py_DECREF`` of the wrapper module's globals.

    pythonfmu's ``findClass`` (called once per ``fmi2Instantiate``) re-executes the wrapper
    module source and then ``Py_DECREF``s the dict it *borrowed* from ``PyModule_GetDict``.
    A wrapper without functions of its own has nothing else holding that dict, so after the
    first instance the module's globals are freed and the next instantiation fails or
    crashes the host.  Every wrapper calls this at top level with ``globals()``: the source
    runs once per ``findClass``, so each stray decrement is matched by one increment (the
    normal import adds one extra reference, which only keeps an immortal module alive).
    """
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(namespace))


def _leave_sys_path(resources) -> None:
    """Move the FMU's ``resources/`` folder from the front of ``sys.path`` to its end.

    pythonfmu puts it first to import the wrapper module; left there, it would shadow the host's
    own packages (a host process that imports :mod:`sideslip` later, or the workers it spawns,
    would get the FMU's partial copy).  The FMU's modules are imported by then, and its
    subpackages load through their packages' ``__path__``, not ``sys.path``.
    """
    folder = str(resources) if resources else None
    if folder and folder in sys.path:
        sys.path.remove(folder)
        sys.path.append(folder)


def _host_call(function: str, default=None):
    """Decorate an fmi2Get/Set handler: an exception is logged at error status (never raised
    into pythonfmu, which would return fmi2Fatal and free the instance); getters then return
    ``default(len(vrs))``."""
    def wrap(method):
        @functools.wraps(method)
        def guarded(self, vrs, *args):
            try:
                return method(self, vrs, *args)
            except Exception as exc:  # noqa: BLE001 - wrong value reference or type from the host
                self._log(f"{self.modelName}: {function} failed: {exc!r}", _ERROR)
                return default(len(vrs)) if default else None
        return guarded
    return wrap


def _fmt(value: float) -> str:
    return f"{value:.16g}"


class _TypedReal(Real):
    """pythonfmu ``Real`` that also writes ``declaredType``, ``unit``, ``min``/``max``."""

    def __init__(self, name, quantity, lo, hi, display=None, **kwargs):
        super().__init__(name, **kwargs)
        self.quantity, self.lo, self.hi, self.display = quantity, lo, hi, display

    def to_xml(self) -> Element:
        node = super().to_xml()
        real = node.find("Real")
        real.set("declaredType", self.quantity)
        real.set("unit", QUANTITIES[self.quantity])
        if self.display:
            real.set("displayUnit", self.display)
        if math.isfinite(self.lo):
            real.set("min", _fmt(self.lo))
        if math.isfinite(self.hi):
            real.set("max", _fmt(self.hi))
        return node


class _BoundedInteger(Integer):
    def __init__(self, name, lo, hi, **kwargs):
        super().__init__(name, **kwargs)
        self.lo, self.hi = lo, hi

    def to_xml(self) -> Element:
        node = super().to_xml()
        integer = node.find("Integer")
        if math.isfinite(self.lo):
            integer.set("min", str(int(self.lo)))
        if math.isfinite(self.hi):
            integer.set("max", str(int(self.hi)))
        return node


def _display_unit(quantity: str) -> str | None:
    display = UNITS[QUANTITIES[quantity]].display
    return display[0][0] if display else None


PORT_BUFFER_MAGIC = "sideslip-ports-v1"
"""Prefix of the ``_port_buffer`` string read by the status shim (keep in sync with the C file)."""


class SideslipSlave(Fmi2Slave):
    """Base class of every sideslip-fmu FMU (see module docstring).

    A subclass is named like its catalogue entry, which sets ``spec``, ``role``,
    ``model_class`` (a library class with ``input_names``, ``output_names``,
    ``step(h, *inputs)`` and ``outputs()`` returning floats, Booleans as 0.0/1.0),
    ``config_class`` (a frozen dataclass of :func:`~sideslip.params.param` fields) and
    ``description``; a subclass may override :meth:`make_model`.

    Value references: 0 is ``_port_buffer``; inputs are ``1..n_in`` and outputs follow, in
    the model's order; parameters come last.
    """

    spec: Any = None
    role: str = ""
    model_class: Any = None
    config_class: Any = None
    description = "sideslip-fmu model"
    author = "sideslip-fmu developers"
    license = "MIT"
    version = __version__
    copyright = "sideslip-fmu developers"
    default_step = 1e-3
    default_stop = 20.0

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        spec = fmu_spec(cls.__name__)
        cls.spec, cls.role, cls.description = spec, spec.role, spec.description
        cls.model_class, cls.config_class = spec.model_class, spec.config_class

    # ------------------------------------------------------------------ declaration
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        _leave_sys_path(kwargs.get("resources"))
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=self.default_stop,
                                                    step_size=self.default_step)
        self._vals: list = []            # parameter values by value reference (None for ports)
        self._kind: list = []            # "Real" / "Integer" / "Boolean" / "String" per value reference
        self._port_kind: list = []       # "R" / "B" per port
        self._port_start: list = []      # start value per port
        self._in_lo: list[float] = []    # catalogue range of each input
        self._in_hi: list[float] = []
        self._param_vr: dict[str, int] = {}
        self._warned: set = set()
        self.model = None
        self._failed: str | None = None
        self._initialized = False
        self._t0 = 0.0
        buffer_var = String("_port_buffer", causality=Fmi2Causality.local, variability=Fmi2Variability.fixed,
                            initial=Fmi2Initial.calculated,
                            description="Internal: address and layout of the port buffer shared with the "
                                        "FMU's native binary (not for users)")
        self._register(buffer_var, None, "String", getter=self._port_layout)
        for name in self.model_class.input_names:
            self._declare_port(name, Fmi2Causality.input)
        self._n_in = len(self._port_kind)
        for name in self.model_class.output_names:
            self._declare_port(name, Fmi2Causality.output)
        self._n_ports = len(self._port_kind)
        self._ports = (ctypes.c_double * self._n_ports)(*self._port_start)
        self._last_in = list(self._port_start[:self._n_in])
        for f, info in declared_fields(self.config_class):
            if info.fmu:
                self._declare_param(f.name, f.default, info)

    def _register(self, var, value, kind: str, getter=None, setter=None) -> int:
        vr = len(self._vals)
        self._vals.append(value)
        self._kind.append(kind)
        var.getter = getter or (lambda vr=vr: self._vals[vr])
        var.setter = setter or (lambda v, vr=vr: self._vals.__setitem__(vr, v))
        self.register_variable(var, nested=False)
        assert var.value_reference == vr
        return vr

    def _declare_port(self, name: str, causality) -> None:
        sig = signal(name)
        is_out = causality == Fmi2Causality.output
        p = len(self._port_kind)
        common = dict(causality=causality, description=sig.description,
                      initial=Fmi2Initial.exact if is_out else None)
        if sig.kind == "Boolean":
            var = Boolean(name, variability=Fmi2Variability.discrete, **common)
            self._register(var, None, "Boolean", getter=lambda p=p: self._ports[p] != 0.0)
            self._port_kind.append("B")
            self._port_start.append(1.0 if sig.start else 0.0)
        else:
            var = _TypedReal(name, sig.quantity, sig.min, sig.max, _display_unit(sig.quantity),
                             variability=Fmi2Variability.continuous, **common)
            self._register(var, None, "Real", getter=lambda p=p: self._ports[p])
            self._port_kind.append("R")
            self._port_start.append(float(sig.start))
        if not is_out:
            self._in_lo.append(sig.min if sig.kind == "Real" else -math.inf)
            self._in_hi.append(sig.max if sig.kind == "Real" else math.inf)

    def _declare_param(self, name: str, default, info) -> None:
        variability = Fmi2Variability.tunable if info.tunable else Fmi2Variability.fixed
        desc = info.description if isinstance(default, str) and info.choices is None else \
            f"{info.description} (allowed: {describe_range(info)})"
        common = dict(causality=Fmi2Causality.parameter, variability=variability, initial=Fmi2Initial.exact,
                      description=desc)
        if isinstance(default, bool):
            vr = self._register(Boolean(name, **common), default, "Boolean")
        elif isinstance(default, int):
            vr = self._register(_BoundedInteger(name, info.min, info.max, **common), default, "Integer")
        elif isinstance(default, str):
            vr = self._register(String(name, **common), default, "String")
        else:
            vr = self._register(_TypedReal(name, info.quantity, info.min, info.max, None, **common),
                                float(default), "Real")
        self._param_vr[name] = vr

    def _port_layout(self) -> str:
        """``_port_buffer`` value: magic, address (hex), first port vr, n_in, n_ports, kinds."""
        return (f"{PORT_BUFFER_MAGIC}:{ctypes.addressof(self._ports):x}:1:{self._n_in}:{self._n_ports}:"
                + "".join(self._port_kind))

    def to_xml(self, model_options=None):
        """modelDescription with unit/type definitions and output dependencies added."""
        root = super().to_xml(model_options or {})
        used = sorted({v.quantity for v in self.vars.values() if isinstance(v, _TypedReal)})
        units = sorted({QUANTITIES[q] for q in used})
        unit_defs = Element("UnitDefinitions")
        for name in units:
            unit = UNITS[name]
            node = SubElement(unit_defs, "Unit", name=name)
            if unit.base:
                SubElement(node, "BaseUnit", {k: str(e) for k, e in unit.base.items()})
            for dname, factor in unit.display:
                SubElement(node, "DisplayUnit", name=dname, factor=_fmt(factor))
        type_defs = Element("TypeDefinitions")
        for q in used:
            simple = SubElement(type_defs, "SimpleType", name=q)
            attrs = {"quantity": q, "unit": QUANTITIES[q]}
            display = _display_unit(q)
            if display:
                attrs["displayUnit"] = display
            SubElement(simple, "Real", attrs)
        pos = list(root).index(root.find("CoSimulation")) + 1
        root.insert(pos, type_defs)
        root.insert(pos, unit_defs)
        outputs = root.find("ModelStructure/Outputs")
        if outputs is not None:
            for unknown in outputs:
                unknown.set("dependencies", "")
        return root

    # ------------------------------------------------------------------ subclass hooks
    def make_model(self, config):
        """Library object for a validated config (override when the constructor differs)."""
        return self.model_class(config)

    # ------------------------------------------------------------------ logging
    def _log(self, msg: str, status=_OK) -> None:
        # pythonfmu passes the text as a printf format: never let a '%' through
        self.log(msg.replace("%", " percent"), status)

    def _log_once(self, key, msg: str, status=_WARNING) -> None:
        if key not in self._warned:
            self._warned.add(key)
            self._log(msg, status)

    def _fail(self, msg: str) -> None:
        self._failed = msg
        self._log(msg, _ERROR)

    # ------------------------------------------------------------------ lifecycle
    def setup_experiment(self, start_time: float = 0.0, stop_time=None, tolerance=None):
        self._t0 = float(start_time)

    def exit_initialization_mode(self):
        try:
            values = {name: self._vals[vr] for name, vr in self._param_vr.items()}
            config = build(self.config_class, values)
            self.model = self.make_model(config)
            self._write_outputs(self.model.outputs())
            self._initialized = True
            self._failed = None
        except ParameterError as exc:
            self._fail(f"{self.modelName} '{self.instance_name}': {exc}")
        except Exception as exc:  # noqa: BLE001 - any failure must become a logged error, not a raise
            self._fail(f"{self.modelName} '{self.instance_name}': initialisation failed: {exc!r}\n"
                       + traceback.format_exc(limit=4))

    def do_step(self, current_time: float, step_size: float) -> bool:
        model = self.model
        if model is None:
            self._log(self._failed or f"{self.modelName}: doStep called before initialisation", _ERROR)
            return False
        try:
            u = self._ports[:self._n_in]
            # in range and finite (NaN compares false); the rare failure goes to _sanitize
            if not (all(map(le, self._in_lo, u)) and all(map(le, u, self._in_hi))):
                u = self._sanitize(u)
            self._last_in = u
            model.step(step_size, *u)
            return self._write_outputs(model.outputs())
        except Exception as exc:  # noqa: BLE001
            self._log(f"{self.modelName} '{self.instance_name}': step at t={current_time:.6g} failed: {exc!r}\n"
                      + traceback.format_exc(limit=4), _ERROR)
            return False

    def _sanitize(self, u: list) -> list:
        """Inputs made safe: hold the last valid value on NaN/inf, clamp to the catalogue range."""
        out = list(u)
        for i, x in enumerate(u):
            lo, hi = self._in_lo[i], self._in_hi[i]
            name = self.vars[i + 1].name
            if x - x != 0.0:
                out[i] = self._last_in[i]
                self._log_once(("nan", i), f"{self.modelName}: input '{name}' = {x!r}; holding the last valid "
                               f"value {out[i]:g}")
            elif not lo <= x <= hi:
                out[i] = lo if x < lo else hi
                self._log_once(("range", i), f"{self.modelName}: input '{name}' = {x:g} outside [{lo:g}, {hi:g}] "
                               f"{QUANTITIES[self.vars[i + 1].quantity]}; clamped")
        return out

    def _write_outputs(self, values) -> bool:
        """Store model outputs (floats, Booleans as 0.0/1.0); never store NaN or inf."""
        total = sum(values)
        if total - total == 0.0:                   # all finite (NaN/inf propagate through the sum)
            self._ports[self._n_in:self._n_ports] = values
            return True
        ports, ok = self._ports, True
        for p, y in zip(range(self._n_in, self._n_ports), values):
            if y - y == 0.0:
                ports[p] = float(y)
            else:                                  # hold the last value, never emit NaN/inf
                ok = False
                self._log_once(("nonfinite", p), f"{self.modelName}: output '{self.vars[p + 1].name}' became "
                               f"{y!r}; holding its last value", _ERROR)
        return ok

    def terminate(self):
        pass

    # ------------------------------------------------------------------ variable access (Python path)
    @_host_call("fmi2GetReal", lambda n: [0.0] * n)
    def get_real(self, vrs):
        ports, vals, n = self._ports, self._vals, self._n_ports
        return [ports[vr - 1] if 1 <= vr <= n else float(vals[vr]) for vr in vrs]

    @_host_call("fmi2GetInteger", lambda n: [0] * n)
    def get_integer(self, vrs):
        return [int(self._vals[vr]) for vr in vrs]

    @_host_call("fmi2GetBoolean", lambda n: [False] * n)
    def get_boolean(self, vrs):
        ports, vals, n = self._ports, self._vals, self._n_ports
        return [ports[vr - 1] != 0.0 if 1 <= vr <= n else bool(vals[vr]) for vr in vrs]

    @_host_call("fmi2GetString", lambda n: [""] * n)
    def get_string(self, vrs):
        return [self._port_layout() if vr == 0 else str(self._vals[vr]) for vr in vrs]

    def _check_settable(self, vr: int, kind: str) -> bool:
        if not 0 <= vr < len(self._vals) or self._kind[vr] != kind:
            self._log(f"{self.modelName}: value reference {vr} is not a {kind} variable", _ERROR)
            return False
        var = self.vars[vr]
        if var.causality in (Fmi2Causality.output, Fmi2Causality.local):
            self._log_once(("set-output", vr), f"{self.modelName}: '{var.name}' is an {var.causality.name} and "
                           "cannot be set", _WARNING)
            return False
        if (self._initialized and var.causality == Fmi2Causality.parameter
                and var.variability == Fmi2Variability.fixed):
            self._log_once(("set-fixed", vr), f"{self.modelName}: fixed parameter '{var.name}' cannot change "
                           "after initialisation; ignored", _WARNING)
            return False
        return True

    @_host_call("fmi2SetReal")
    def set_real(self, vrs, values):
        n_in = self._n_in
        for vr, x in zip(vrs, values):
            if 1 <= vr <= n_in and self._port_kind[vr - 1] == "R":
                self._ports[vr - 1] = x            # checked at the next doStep
            elif self._check_settable(vr, "Real"):
                self._vals[vr] = float(x)

    @_host_call("fmi2SetInteger")
    def set_integer(self, vrs, values):
        for vr, x in zip(vrs, values):
            if self._check_settable(vr, "Integer"):
                self._vals[vr] = int(x)

    @_host_call("fmi2SetBoolean")
    def set_boolean(self, vrs, values):
        n_in = self._n_in
        for vr, x in zip(vrs, values):
            if 1 <= vr <= n_in and self._port_kind[vr - 1] == "B":
                self._ports[vr - 1] = 1.0 if x else 0.0
            elif self._check_settable(vr, "Boolean"):
                self._vals[vr] = bool(x)

    @_host_call("fmi2SetString")
    def set_string(self, vrs, values):
        for vr, x in zip(vrs, values):
            if self._check_settable(vr, "String"):
                self._vals[vr] = str(x)

    # ------------------------------------------------------------------ FMU state
    _STATE_FIELDS = ("_vals", "_last_in", "_warned", "model", "_failed", "_initialized", "_t0")

    def _get_fmu_state(self):
        try:
            state = copy.deepcopy({k: getattr(self, k) for k in self._STATE_FIELDS})
            state["_ports"] = list(self._ports)
            return state
        except Exception as exc:  # noqa: BLE001
            self._log(f"{self.modelName}: fmi2GetFMUstate failed: {exc!r}", _ERROR)
            return {}

    def _set_fmu_state(self, state):
        try:
            if not state:
                raise ValueError("empty FMU state")
            state = copy.deepcopy(state)
            self._ports[:] = state.pop("_ports")     # same buffer: the shim's address stays valid
            for k, v in state.items():
                setattr(self, k, v)
        except Exception as exc:  # noqa: BLE001
            self._log(f"{self.modelName}: fmi2SetFMUstate failed: {exc!r}", _ERROR)

    @staticmethod
    def _fmu_state_to_bytes(state) -> bytes:
        return pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)

    @staticmethod
    def _fmu_state_from_bytes(data: bytes):
        return pickle.loads(data)
