"""The FMU toolkit: a pythonfmu ``Fmi2Slave`` base that declares ports from the signal catalogue.

An FMU wrapper binds the slave class of its entry in the FMU catalogue
(:mod:`sideslip.fmi.catalogue`)::

    VehiclePlant = fmu_class("VehiclePlant", __name__)

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
  the last valid value and values outside the catalogue range are clamped; the start of every
  bad episode of an input is logged at warning status in category ``logStatusWarning`` (at
  most once per :data:`EPISODE_LOG_INTERVAL` of simulated time per input, the suppressed ones
  counted in the next message), ``doStep`` still returns ``fmi2OK`` (hosts such as
  OMSimulator and fmusim stop on fmi2Warning), the output ``inputs_held`` counts the inputs
  held or clamped in the step and an estimator's ``valid`` is false; the model never sees NaN;
* outputs: never NaN, and always within their declared ``min``/``max`` (a value outside is
  clamped, logged like an input and, for an estimator, makes ``valid`` false);
* lifecycle: the FMI 2.0 co-simulation states are enforced (a call in the wrong state, e.g.
  ``doStep`` after ``fmi2Terminate``, is refused with fmi2Error), and a ``doStep`` whose
  communication point is not the FMU's current time (a skipped or repeated interval) is refused
  with fmi2Error and changes nothing; a step size that differs from the previous one by rounding
  only (:data:`STEP_ROUNDING`) is the previous one;
* state: get/set/serialise FMU state writes every variable value and the library object
  (filter state, buffers, RNG) in the typed, checksummed format of :mod:`sideslip.fmi.state`
  (never pickle); restoring rebuilds the model from the state's parameters and then its data,
  and a state that is not valid is refused with fmi2Error naming why;
* no Python exception ever reaches pythonfmu (it would turn it into fmi2Fatal and free
  the instance) and no traceback reaches the host's log: every entry point catches and logs
  the message.
"""
from __future__ import annotations

import base64
import ctypes
import functools
import math
import sys
from operator import le
from typing import Any
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Initial, Fmi2Status

from .. import __version__
from ..params import ChoiceIndices, ParameterError, build, declared_fields, describe_range
from ..signals import signal
from ..units import QUANTITIES, UNITS
from . import state as fmu_state
from .catalogue import HELD_OUTPUT, fmu_spec

__all__ = ["SideslipSlave", "fmu_class", "keep_module_dict_alive", "import_bundle", "EPISODE_LOG_INTERVAL", "HELD_OUTPUT"]

_ROOT = __name__.split(".")[0]

_ERROR, _WARNING, _OK = Fmi2Status.error, Fmi2Status.warning, Fmi2Status.ok

EPISODE_LOG_INTERVAL = 1.0
"""[s] of simulated time: a port's bad episodes are logged at most once per interval."""

MAX_COMMUNICATION_STEP = 10.0
"""[s] The longest communication step a ``doStep`` takes: the models integrate at their own sample period
inside it, so a step's cost grows with its length (a 1e5 s step would block the host for minutes); a
longer one is refused with a message, nothing changed.  A closed loop of these FMUs steps at 1-10 ms."""

STEP_ROUNDING = 1e-9
"""Relative difference below which a communication step is the previous one: a host that computes each
step as the difference of two communication points (OMSimulator) passes 0.001 as 0.0009999999999998899 or
0.0010000000000000009; the model takes the same step every time, so its results do not depend on the
host's rounding."""

_INSTANTIATED, _INITIALIZING, _STEPPING, _TERMINATED = "instantiated", "initialization mode", "step mode", "terminated"


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


_CLASSES: dict[str, type] = {}


def fmu_class(name: str, module: str) -> type:
    """The slave class of the catalogue entry ``name``, made once per process (for a wrapper module).

    pythonfmu 0.7 runs the wrapper file again at every ``fmi2Instantiate`` and keeps a reference to
    the class it finds: a class statement there would leave a new class behind per instance
    (about 3 KB).  The wrapper binds this one class instead.
    """
    cls = _CLASSES.get(name)
    if cls is None:
        cls = _CLASSES[name] = type(name, (SideslipSlave,), {
            "__module__": module, "__qualname__": name,
            "__doc__": "Model, configuration, role and description come from the catalogue entry of this name."})
    return cls


def import_bundle() -> None:
    """Keep every module of this package importable for the life of the process.

    Inside an FMU the package is the build's own copy, renamed per build (``sideslip_<hash>``,
    :mod:`sideslip.fmi.build`), so FMUs of different builds in one process each run their own code.
    Hosts such as OMSimulator delete an FMU's unpacked folder once it is loaded: the package's sources
    are held in memory (:func:`sideslip.fmi.resident.keep_resident`) so that a module imported later still
    loads, and the FMU's model imports only what it uses.
    """
    from .resident import keep_resident

    keep_resident(sys.modules[_ROOT])


def _leave_sys_path(resources) -> None:
    """Move the FMU's ``resources/`` folder from the front of ``sys.path`` to its end.

    pythonfmu puts it first to import the wrapper module; left there, it would shadow the host's
    own packages (a host process that imports :mod:`sideslip` later, or the workers it spawns,
    would get the FMU's partial copy).  The FMU's modules load through their packages' ``__path__``, not
    ``sys.path``, or from memory (:func:`import_bundle`).
    """
    folder = str(resources) if resources else None
    if folder and folder in sys.path:               # pythonfmu inserts it at every instantiation: keep one
        sys.path[:] = [p for p in sys.path if p != folder] + [folder]


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
        if real.get("start") is not None:              # exactly (pythonfmu writes 16 digits): hosts set it back
            real.set("start", repr(float(self.start)))
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


PORT_BUFFER_MAGIC = "sideslip-ports-v2"
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
        self._out_lo: list[float] = []   # declared range of each model output (Booleans unbounded)
        self._out_hi: list[float] = []
        self._param_vr: dict[str, int] = {}
        self._warned: set = set()
        self.model = None
        self._failed: str | None = None
        self._phase = _INSTANTIATED
        self._t0 = 0.0
        self._t = 0.0                    # the FMU's time: the communication point the next doStep starts at
        self._h = 0.0                    # the step the model takes: the host's, unless it differs by rounding only
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
        self._n_out = len(self._port_kind) - self._n_in
        self._declare_port(HELD_OUTPUT, Fmi2Causality.output)
        self._n_ports = len(self._port_kind)
        self._ports = (ctypes.c_double * self._n_ports)(*self._port_start)
        self._last_in = list(self._port_start[:self._n_in])
        n_watch = self._n_in + self._n_out           # inputs, then model outputs: their bad episodes
        self._bad = [False] * n_watch                # in a bad episode now
        self._episodes = [0] * n_watch
        self._reported = [-math.inf] * n_watch       # time of the last report
        self._suppressed = [0] * n_watch             # episodes not reported since
        self._n_bad = 0
        self._valid_port = (self._n_in + self.model_class.output_names.index("valid")
                            if "valid" in self.model_class.output_names else None)
        for f, info in declared_fields(self.config_class):
            if info.fmu:
                self._param_vr[f.name] = self._declare_param(f.name, f.default, info)
        self._group_vr: dict[str, int] = {}          # numeric stand-ins of String configuration
        self._choices = ChoiceIndices(self.config_class)
        for group in (self._choices, *getattr(self.config_class, "parameter_groups", tuple)()):
            for name, start, info in group.parameters():
                self._group_vr[name] = self._declare_param(name, start, info)
        renew = String("_renew", causality=Fmi2Causality.local, variability=Fmi2Variability.discrete,
                       initial=Fmi2Initial.exact, start="",
                       description="Internal: set by the FMU's native binary to make this instance new again "
                                   "(fmi2Reset, reuse after fmi2FreeInstance; not for users)")
        self._renew_vr = self._register(renew, "", "String")
        self._init_kwargs = kwargs

    def _renew(self) -> None:
        """Make this object a new instance in place (what fmi2Reset asks for).  pythonfmu 0.7's own reset
        leaves the old Python object behind (about 60 KB); the native binary asks for this instead, and
        uses it to keep freed instances for the next fmi2Instantiate.  The log queue pythonfmu reads
        stays the same list."""
        queue = self.log_queue
        self.__init__(**self._init_kwargs)
        queue.clear()
        self.log_queue = queue

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
        lo, hi = (sig.min, sig.max) if sig.kind == "Real" else (-math.inf, math.inf)
        if not is_out:
            self._in_lo.append(lo)
            self._in_hi.append(hi)
        elif name != HELD_OUTPUT:
            self._out_lo.append(lo)
            self._out_hi.append(hi)

    def _declare_param(self, name: str, default, info) -> int:
        """Declare a parameter (its start value ``default``); returns its value reference."""
        variability = Fmi2Variability.tunable if info.tunable else Fmi2Variability.fixed
        desc = info.description if isinstance(default, str) and info.choices is None else \
            f"{info.description} (allowed: {describe_range(info)})"
        common = dict(causality=Fmi2Causality.parameter, variability=variability, initial=Fmi2Initial.exact,
                      description=desc)
        if isinstance(default, bool):
            return self._register(Boolean(name, **common), default, "Boolean")
        if isinstance(default, int):
            return self._register(_BoundedInteger(name, info.min, info.max, **common), default, "Integer")
        if isinstance(default, str):
            return self._register(String(name, **common), default, "String")
        return self._register(_TypedReal(name, info.quantity, info.min, info.max, None, **common), float(default),
                              "Real")

    def _port_layout(self) -> str:
        """``_port_buffer`` value: magic, address (hex), first port vr, n_in, n_ports, the ``_renew``
        variable's vr, kinds."""
        return (f"{PORT_BUFFER_MAGIC}:{ctypes.addressof(self._ports):x}:1:{self._n_in}:{self._n_ports}:"
                f"{self._renew_vr}:" + "".join(self._port_kind))

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
        self.log(msg.replace(" %", "%").replace("%", " percent"), status)

    def _log_once(self, key, msg: str, status=_WARNING) -> None:
        if key not in self._warned:
            self._warned.add(key)
            self._log(msg, status)

    def _fail(self, msg: str) -> None:
        self._failed = msg
        self._log(msg, _ERROR)

    def _refuse(self, call: str, allowed: str) -> bool:
        """Log a call made in the wrong state (fmi2Error); returns False."""
        self._log(f"{self.modelName}: {call} is not allowed in {self._phase} "
                  f"(allowed in {allowed})", _ERROR)
        return False

    # ------------------------------------------------------------------ lifecycle
    def setup_experiment(self, start_time: float = 0.0, stop_time=None, tolerance=None):
        if self._phase != _INSTANTIATED:
            self._refuse("fmi2SetupExperiment", _INSTANTIATED)
            return
        self._t0 = self._t = float(start_time)

    def enter_initialization_mode(self):
        if self._phase != _INSTANTIATED:
            self._refuse("fmi2EnterInitializationMode", _INSTANTIATED)
            return
        self._phase = _INITIALIZING

    def exit_initialization_mode(self):
        if self._phase != _INITIALIZING:
            self._refuse("fmi2ExitInitializationMode", _INITIALIZING)
            return
        self._phase = _STEPPING
        try:
            self.model = self._build_model()
            self._write_outputs(self.model.outputs(), self._t)
            self._failed = None
        except ParameterError as exc:
            self.model = None
            self._fail(f"{self.modelName}: {exc}")
        except Exception as exc:  # noqa: BLE001 - any failure must become a logged error, not a raise
            self.model = None
            self._fail(f"{self.modelName}: initialisation failed: "
                       f"{type(exc).__name__}: {exc}")

    def _build_model(self):
        """The library model of the current parameter values (validated; raises ParameterError)."""
        values = {name: self._vals[vr] for name, vr in self._param_vr.items()}
        stand_ins = {name: self._vals[vr] for name, vr in self._group_vr.items()}
        config = self._choices.apply(build(self.config_class, values), stand_ins)
        if hasattr(config, "with_parameter_groups"):
            config = config.with_parameter_groups(stand_ins)
        return self.make_model(config)

    def do_step(self, current_time: float, step_size: float) -> bool:
        model = self.model
        if self._phase != _STEPPING:
            return self._refuse("fmi2DoStep", _STEPPING)
        if model is None:
            self._log(self._failed or f"{self.modelName}: doStep called before initialisation", _ERROR)
            return False
        if not (step_size > 0.0 and math.isfinite(step_size)):
            self._log(f"{self.modelName}: communication step size {step_size!r} is not "
                      "a positive finite number; step refused", _ERROR)
            return False
        if step_size > MAX_COMMUNICATION_STEP:
            self._log(f"{self.modelName}: communication step size {step_size:g} s is longer than "
                      f"{MAX_COMMUNICATION_STEP:g} s; step refused, nothing changed (step in shorter intervals)", _ERROR)
            return False
        t = self._t
        if not math.isfinite(current_time):
            self._log(f"{self.modelName}: communication point {current_time!r} is not finite; step refused, "
                      "nothing changed", _ERROR)
            return False
        if abs(current_time - t) > 1e-9 * max(step_size, abs(t)):
            self._log(f"{self.modelName}: doStep from t={current_time:.9g} s, but the FMU is "
                      f"at t={t:.9g} s (a skipped or repeated interval); step refused, nothing changed (restore an "
                      "FMU state or reset to go back)", _ERROR)
            return False
        try:
            end = current_time + step_size
            u = self._ports[:self._n_in]
            # in range and finite (NaN compares false); the rare failure goes to _sanitize
            if not (all(map(le, self._in_lo, u)) and all(map(le, u, self._in_hi))):
                u, held = self._sanitize(u, end)
            else:
                held = 0
                if self._n_bad:
                    self._end_episodes(0, self._n_in)
            self._last_in = u
            model.held_inputs = held
            h = self._h
            if abs(step_size - h) > STEP_ROUNDING * h:
                self._h = h = step_size
            model.step(h, *u)
            self._t = end
            self._ports[self._n_ports - 1] = held
            return self._write_outputs(model.outputs(), end)
        except Exception as exc:  # noqa: BLE001
            self._log(f"{self.modelName}: step at t={current_time:.6g} failed: "
                      f"{type(exc).__name__}: {exc}", _ERROR)
            return False

    def _episode(self, i: int, t: float, msg: str) -> None:
        """Port ``i`` is bad in this step: log the start of a new episode (rate-limited)."""
        if self._bad[i]:
            return
        self._bad[i] = True
        self._n_bad += 1
        self._episodes[i] += 1
        if t - self._reported[i] >= EPISODE_LOG_INTERVAL:
            more = self._suppressed[i]
            self._log(f"{self.modelName}: t={t:.6g} s: {msg}"
                      + (f" ({more} more episode{'s' if more > 1 else ''} since the last report)" if more else ""),
                      _WARNING)
            self._reported[i], self._suppressed[i] = t, 0
        else:
            self._suppressed[i] += 1

    def _end_episodes(self, first: int, stop: int) -> None:
        for i in range(first, stop):
            if self._bad[i]:
                self._bad[i] = False
                self._n_bad -= 1

    def _sanitize(self, u: list, t: float) -> tuple[list, int]:
        """Inputs made safe (hold the last valid value on NaN/inf, clamp to the catalogue range) and how
        many were changed."""
        out, held = list(u), 0
        for i, x in enumerate(u):
            lo, hi = self._in_lo[i], self._in_hi[i]
            name = self.vars[i + 1].name
            if x - x != 0.0:
                out[i] = self._last_in[i]
                self._episode(i, t, f"input '{name}' = {x!r}; holding the last valid value {out[i]:g}")
            elif not lo <= x <= hi:
                out[i] = lo if x < lo else hi
                self._episode(i, t, f"input '{name}' = {x:g} outside [{lo:g}, {hi:g}] "
                              f"{QUANTITIES[self.vars[i + 1].quantity]}; clamped")
            else:
                if self._bad[i]:
                    self._bad[i] = False
                    self._n_bad -= 1
                continue
            held += 1
        return out, held

    def _write_outputs(self, values, t: float) -> bool:
        """Store model outputs (floats, Booleans as 0.0/1.0): never NaN or inf (the last value is held, an
        error), never outside the declared range (clamped; an estimator's ``valid`` goes false)."""
        n_in = self._n_in
        if all(map(le, self._out_lo, values)) and all(map(le, values, self._out_hi)):
            self._ports[n_in:n_in + self._n_out] = values
            if self._n_bad:
                self._end_episodes(n_in, n_in + self._n_out)
            return True
        ports, ok, clamped = self._ports, True, False
        for k, y in enumerate(values):
            p, lo, hi = n_in + k, self._out_lo[k], self._out_hi[k]
            if y - y != 0.0:                       # hold the last value, never emit NaN/inf
                ok = False
                self._log_once(("nonfinite", p), f"{self.modelName}: output '{self.vars[p + 1].name}' became "
                               f"{y!r}; holding its last value", _ERROR)
            elif not lo <= y <= hi:
                ports[p] = lo if y < lo else hi
                clamped = True
                self._episode(p, t, f"output '{self.vars[p + 1].name}' = {y:g} outside its declared "
                              f"[{lo:g}, {hi:g}]; clamped")
            else:
                ports[p] = float(y)
                if self._bad[p]:
                    self._bad[p] = False
                    self._n_bad -= 1
        if clamped and self._valid_port is not None:
            ports[self._valid_port] = 0.0
        return ok

    def terminate(self):
        if self._phase not in (_STEPPING,):
            self._refuse("fmi2Terminate", _STEPPING)
            return
        self._phase = _TERMINATED

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
        if self._phase == _TERMINATED:
            return self._refuse(f"setting '{var.name}'", f"{_INSTANTIATED}, {_INITIALIZING} or {_STEPPING}")
        if var.causality in (Fmi2Causality.output, Fmi2Causality.local):
            self._log(f"{self.modelName}: '{var.name}' is an {var.causality.name} and cannot be set", _ERROR)
            return False
        if (self._phase == _STEPPING and var.causality == Fmi2Causality.parameter
                and var.variability == Fmi2Variability.fixed):
            self._log(f"{self.modelName}: fixed parameter '{var.name}' cannot change after initialisation; "
                      "ignored", _ERROR)
            return False
        return True

    @_host_call("fmi2SetReal")
    def set_real(self, vrs, values):
        n_in = self._n_in
        for vr, x in zip(vrs, values):
            if 1 <= vr <= n_in and self._port_kind[vr - 1] == "R":
                if self._phase == _TERMINATED:
                    self._refuse(f"setting '{self.vars[vr].name}'", f"{_INSTANTIATED}, {_INITIALIZING} or {_STEPPING}")
                    continue
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
                if self._phase == _TERMINATED:
                    self._refuse(f"setting '{self.vars[vr].name}'", f"{_INSTANTIATED}, {_INITIALIZING} or {_STEPPING}")
                    continue
                self._ports[vr - 1] = 1.0 if x else 0.0
            elif self._check_settable(vr, "Boolean"):
                self._vals[vr] = bool(x)

    @_host_call("fmi2SetString")
    def set_string(self, vrs, values):
        for vr, x in zip(vrs, values):
            if vr == self._renew_vr:
                self._renew()
                return
            if self._check_settable(vr, "String"):
                self._vals[vr] = str(x)

    # ------------------------------------------------------------------ FMU state
    _STATE_FIELDS = ("_last_in", "_bad", "_episodes", "_reported", "_suppressed", "_n_bad", "_warned", "_failed",
                     "_phase", "_t0", "_t", "_h")

    def _get_fmu_state(self):
        """The state as bytes (:mod:`sideslip.fmi.state`); b"" and an error logged if it cannot be written."""
        try:
            model = None if self.model is None else base64.b64encode(fmu_state.dumps(self.model)).decode("ascii")
            return fmu_state.dumps({"fmu": self.modelName, "vals": list(self._vals), "ports": list(self._ports),
                                    "fields": {k: getattr(self, k) for k in self._STATE_FIELDS}, "model": model})
        except Exception as exc:  # noqa: BLE001
            self._log(f"{self.modelName}: fmi2GetFMUstate failed: {type(exc).__name__}: {exc}", _ERROR)
            return b""

    def _set_fmu_state(self, state):
        """Restore a state of :meth:`_get_fmu_state`; anything else is refused (error logged, nothing changed)."""
        try:
            if not isinstance(state, (bytes, bytearray)) or not state:
                raise fmu_state.StateError("empty FMU state")
            outer = fmu_state.loads(state)
            if not isinstance(outer, dict) or outer.get("fmu") != self.modelName:
                raise fmu_state.StateError(f"not a state of {self.modelName}")
            vals, ports, fields = outer.get("vals"), outer.get("ports"), outer.get("fields")
            if not (isinstance(vals, list) and len(vals) == len(self._vals) and isinstance(ports, list)
                    and len(ports) == self._n_ports and isinstance(fields, dict)
                    and set(fields) == set(self._STATE_FIELDS)):
                raise fmu_state.StateError("the state's variables do not match this FMU")
            kinds = {"Real": float, "Integer": int, "Boolean": bool, "String": str}
            for vr, (kind, value) in enumerate(zip(self._kind, vals)):
                if (value is None) != (vr == 0 or self._vals[vr] is None) or (
                        value is not None and type(value) is not kinds[kind]):
                    raise fmu_state.StateError(f"variable {vr} ({self.vars[vr].name}) has a value of the wrong type")
            if not all(isinstance(x, float) for x in ports) or fields["_phase"] not in (
                    _INSTANTIATED, _INITIALIZING, _STEPPING, _TERMINATED):
                raise fmu_state.StateError("the state's ports or phase are not valid")
            model = None
            if outer.get("model") is not None:
                saved_vals, self._vals = self._vals, vals
                try:
                    template = self._build_model()         # what is not data comes from a model built anew
                finally:
                    self._vals = saved_vals
                model = fmu_state.loads(base64.b64decode(outer["model"], validate=True), template)
                if type(model) is not type(template):
                    raise fmu_state.StateError("the state's model is not this FMU's model")
        except Exception as exc:  # noqa: BLE001 - a bad state is the host's error, never a crash
            self._log(f"{self.modelName}: fmi2SetFMUstate refused: "
                      f"{type(exc).__name__}: {exc}", _ERROR)
            return
        self._vals = vals
        self._ports[:] = ports                       # same buffer: the shim's address stays valid
        for k, v in fields.items():
            setattr(self, k, v)
        self.model = model

    @staticmethod
    def _fmu_state_to_bytes(state) -> bytes:
        return bytes(state) if isinstance(state, (bytes, bytearray)) else b""

    @staticmethod
    def _fmu_state_from_bytes(data: bytes):
        return bytes(data)                           # checked when set: a refusal then is an fmi2Error


if _ROOT != "sideslip":          # inside an FMU (the per-build package): keep it while its folder exists
    import_bundle()
