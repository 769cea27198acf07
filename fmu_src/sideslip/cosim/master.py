"""The fmpy master: several FMUs in closed loop through fmpy, fixed communication step.

* Components and connections as :mod:`sideslip.cosim.assembly` resolves them (by contract
  name, explicit connections override); unconnected inputs keep their start values and are
  listed in the run metadata.
* Gauss-Seidel in component order (default): each component gets the latest outputs of
  all others before its ``doStep``; with the order driver, plant, sensors, estimators,
  controller the sensors see the plant at the end of the step, the controller acts on the
  next one.  ``scheme="jacobi"``: every component gets the outputs of the previous
  communication point, then all step (the scheme of libcosim's fixed-step algorithm, see
  :mod:`sideslip.cosim.libcosim_master`).
* Lean loop: value references resolved once, one preallocated buffer for all outputs,
  batched ``fmi2GetReal``/``fmi2SetReal`` per component, raw ctypes calls (GIL held, so
  pythonfmu's GIL round trip is a no-op), no per-step allocation.  Boolean inputs are set at the
  first step and whenever they change (an FMI 2.0 input keeps its value until it is set again):
  event flags and validity change a few times a second.
* Every output of every component is recorded (optionally every n-th step) into a
  structured array with fields ``time`` and ``<instance>.<variable>``.
* Extracted FMUs are cached per process, so hundreds of runs (tuning studies) load each
  FMU's library once.
"""
from __future__ import annotations

import atexit
import ctypes
import math
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

from ..fmi.build import DEFAULT_OUT
from ..fmi.variables import fmi_value
from .assembly import Component, MasterError, fmu_paths, interface_of, resolve_connections
from .results import Results

__all__ = ["CoSimulation", "SCHEMES"]

_STATUS = ("ok", "warning", "discard", "error", "fatal", "pending")
SCHEMES = ("gauss-seidel", "jacobi")


# ---------------------------------------------------------------------------------------- extraction
_EXTRACTED: dict[tuple, Path] = {}
_EXTRACT_ROOT: Path | None = None
_EXTRACT_LOCK = threading.Lock()   # loops in several threads of one process share the cache


def _extract_cached(path: Path) -> Path:
    """Extract ``path`` once per process (keyed by path, size and mtime)."""
    global _EXTRACT_ROOT
    stat = path.stat()
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    with _EXTRACT_LOCK:
        if key not in _EXTRACTED:
            if _EXTRACT_ROOT is None:
                _EXTRACT_ROOT = Path(tempfile.mkdtemp(prefix="sideslip_fmus_"))
                atexit.register(shutil.rmtree, _EXTRACT_ROOT, True)
            target = _EXTRACT_ROOT / f"{path.stem}_{len(_EXTRACTED)}"
            _EXTRACTED[key] = Path(extract(str(path), unzipdir=str(target)))
        return _EXTRACTED[key]


# ---------------------------------------------------------------------------------------- one instance
class _Instance:
    """A loaded, instantiated FMU with its value references and raw function handles."""

    def __init__(self, comp: Component, path: Path, messages: list):
        self.comp, self.name = comp, comp.name
        self.md = read_model_description(str(path))
        self.unzip = _extract_cached(path)
        mid = self.md.coSimulation.modelIdentifier
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.outputs_real = [v.name for v in self.md.modelVariables if v.causality == "output" and v.type == "Real"]
        self.outputs_bool = [v.name for v in self.md.modelVariables
                             if v.causality == "output" and v.type == "Boolean"]
        self.inputs = {v.name: v for v in self.md.modelVariables if v.causality == "input"}
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=str(self.unzip), modelIdentifier=mid,
                               instanceName=comp.name)
        self.messages = messages

        def logger(env, instance, status, category, message):
            self.messages.append((comp.name, _STATUS[status] if 0 <= status < 6 else str(status),
                                  message.decode("utf-8", "replace") if message else ""))

        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        # raw handles: PyDLL keeps the GIL during the call (pythonfmu re-acquires it anyway)
        so = Path(self.unzip) / "binaries" / "linux64" / f"{mid}.so"
        lib = ctypes.PyDLL(str(so)) if so.is_file() else None
        self._fn = {}
        for fname in ("fmi2SetReal", "fmi2GetReal", "fmi2SetBoolean", "fmi2GetBoolean", "fmi2DoStep"):
            f = getattr(lib, fname) if lib is not None else self.slave._functions[fname]
            f.restype = ctypes.c_int
            f.argtypes = None
            self._fn[fname] = f

    def check(self, status: int, what: str, t: float | None = None) -> None:
        if status > 1:
            where = "" if t is None else f" at t={t:.6g} s"
            log = "\n".join(f"  [{lvl}] {inst}: {msg}" for inst, lvl, msg in self.messages if inst == self.name)
            raise MasterError(f"{self.name}: {what} returned {_STATUS[status] if status < 6 else status}{where}"
                              + (f"\n{log}" if log else ""))

    def instantiate(self):
        self.slave.instantiate(callbacks=self._callbacks, loggingOn=False)
        self.component = ctypes.c_void_p(self.slave.component)

    def set_parameters(self, params: dict):
        for key, value in params.items():
            var = self.vars.get(key)
            if var is None or var.causality != "parameter":
                known = sorted(v.name for v in self.md.modelVariables if v.causality == "parameter")
                raise MasterError(f"{self.name}: no parameter {key!r}; parameters are: {', '.join(known)}")
            try:
                getattr(self.slave, f"set{var.type}")([var.valueReference], [fmi_value(var.type, value, key)])
            except Exception as exc:
                raise MasterError(f"{self.name}: setting parameter {key!r} = {value!r} failed: {exc}") from exc


# ---------------------------------------------------------------------------------------- master
class CoSimulation:
    """Closed loop of FMUs at a fixed communication step (see module docstring).

    Parameters
    ----------
    components : list of Component
        In execution order (driver, plant, sensors, estimators, controller).
    connections : iterable of (str, str)
        Explicit ``("src_instance.output", "dst_instance.input")`` pairs; they override the
        connection by name for that input.
    step : float
        Communication step [s].
    record_every : int
        Record every n-th step (1 = every step).
    fmu_dir : path
        Folder of the built FMUs (built/rebuilt on first use when names are given).
    scheme : {"gauss-seidel", "jacobi"}
        Coupling scheme (module docstring).
    """

    def __init__(self, components, connections=(), step: float = 1e-3, record_every: int = 1,
                 fmu_dir: str | Path = DEFAULT_OUT, scheme: str = "gauss-seidel"):
        if not step > 0:
            raise MasterError(f"step must be > 0, got {step}")
        if scheme not in SCHEMES:
            raise MasterError(f"scheme must be one of {', '.join(SCHEMES)}, got {scheme!r}")
        self.scheme = scheme
        if record_every < 1:
            raise MasterError(f"record_every must be >= 1, got {record_every}")
        self.components = list(components)
        names = [c.name for c in self.components]
        if len(set(names)) != len(names):
            raise MasterError(f"instance names must be unique: {names}")
        self.step, self.record_every = float(step), int(record_every)
        self.fmu_dir = Path(fmu_dir)
        self.explicit = [tuple(c) for c in connections]
        self.messages: list = []
        self._instances: list[_Instance] = []
        self._open = False

    # ---------------------------------------------------------------- setup
    def _connect(self):
        return resolve_connections([interface_of(i.name, i.md) for i in self._instances], self.explicit)

    def setup(self) -> None:
        """Build (if needed), load, instantiate, parameterise and initialise every FMU."""
        paths = fmu_paths(self.components, self.fmu_dir)
        try:
            for comp in self.components:
                inst = _Instance(comp, paths[comp.name], self.messages)
                inst.instantiate()
                self._instances.append(inst)
            self._open = True
            for inst, comp in zip(self._instances, self.components):
                inst.set_parameters(comp.parameters)
            self.links, self.unconnected = self._connect()
            self._layout()
            for inst in self._instances:
                try:
                    inst.slave.setupExperiment(startTime=0.0)
                    inst.slave.enterInitializationMode()
                except Exception as exc:
                    raise self._failure(inst.name, exc) from exc
            self._push_inputs_all()
            for inst in self._instances:
                try:
                    inst.slave.exitInitializationMode()
                except Exception as exc:
                    raise self._failure(inst.name, exc) from exc
            self._pull_outputs_all()
        except Exception:
            self.close()
            raise

    def _failure(self, name: str, exc: Exception) -> MasterError:
        """The error of an FMU that refused to initialise: its own messages first (they name the parameter and the
        allowed range), the failed FMI call after them."""
        errors = [msg for inst, lvl, msg in self.messages if inst == name and lvl in ("error", "fatal")]
        others = [f"  [{lvl}] {msg}" for inst, lvl, msg in self.messages
                  if inst == name and lvl not in ("error", "fatal")]
        lead = "\n".join(m if m.startswith(name) else f"{name}: {m}" for m in errors) or f"{name}: {exc}"
        return MasterError("\n".join([lead, *others] + ([f"  ({exc})"] if errors else [])))

    def _layout(self):
        """Buffers: all Real outputs in one float64 vector, all Boolean outputs in one int32 vector."""
        self.real_names, self.bool_names = [], []
        for inst in self._instances:
            inst.r0 = len(self.real_names)
            self.real_names += [f"{inst.name}.{n}" for n in inst.outputs_real]
            inst.b0 = len(self.bool_names)
            self.bool_names += [f"{inst.name}.{n}" for n in inst.outputs_bool]
        self.Y = np.zeros(len(self.real_names))
        self.B = np.zeros(len(self.bool_names), dtype=np.int32)
        ridx = {n: i for i, n in enumerate(self.real_names)}
        bidx = {n: i for i, n in enumerate(self.bool_names)}
        y_addr, b_addr = self.Y.ctypes.data, self.B.ctypes.data
        for inst in self._instances:
            vr = lambda names: (ctypes.c_uint * len(names))(*[inst.vars[n].valueReference for n in names])  # noqa: E731
            inst.out_r_vr, inst.n_out_r = vr(inst.outputs_real), len(inst.outputs_real)
            inst.out_r_ptr = ctypes.c_void_p(y_addr + 8 * inst.r0)
            inst.out_b_vr, inst.n_out_b = vr(inst.outputs_bool), len(inst.outputs_bool)
            inst.out_b_ptr = ctypes.c_void_p(b_addr + 4 * inst.b0)
            real_in = [(n, s) for (i, n), s in self.links.items() if i == inst.name and s[2] == "Real"]
            bool_in = [(n, s) for (i, n), s in self.links.items() if i == inst.name and s[2] == "Boolean"]
            inst.in_r_vr, inst.n_in_r = vr([n for n, _ in real_in]), len(real_in)
            inst.in_r_src = np.array([ridx[f"{s[0]}.{s[1]}"] for _, s in real_in], dtype=np.intp)
            inst.U = np.zeros(len(real_in))
            inst.in_r_ptr = ctypes.c_void_p(inst.U.ctypes.data)
            inst.in_b_vr, inst.n_in_b = vr([n for n, _ in bool_in]), len(bool_in)
            inst.in_b_src = np.array([bidx[f"{s[0]}.{s[1]}"] for _, s in bool_in], dtype=np.intp)
            inst.UB = np.zeros(len(bool_in), dtype=np.int32)
            inst.in_b_ptr = ctypes.c_void_p(inst.UB.ctypes.data)

    def _push_inputs(self, inst, t=None):
        if inst.n_in_r:
            self.Y.take(inst.in_r_src, out=inst.U)
            inst.check(inst._fn["fmi2SetReal"](inst.component, inst.in_r_vr, inst.n_in_r, inst.in_r_ptr),
                       "fmi2SetReal", t)
        if inst.n_in_b:
            self.B.take(inst.in_b_src, out=inst.UB)
            inst.check(inst._fn["fmi2SetBoolean"](inst.component, inst.in_b_vr, inst.n_in_b, inst.in_b_ptr),
                       "fmi2SetBoolean", t)

    def _pull_outputs(self, inst, t=None):
        if inst.n_out_r:
            inst.check(inst._fn["fmi2GetReal"](inst.component, inst.out_r_vr, inst.n_out_r, inst.out_r_ptr),
                       "fmi2GetReal", t)
        if inst.n_out_b:
            inst.check(inst._fn["fmi2GetBoolean"](inst.component, inst.out_b_vr, inst.n_out_b, inst.out_b_ptr),
                       "fmi2GetBoolean", t)

    def _push_inputs_all(self):
        for inst in self._instances:
            self._push_inputs(inst)

    def _pull_outputs_all(self):
        for inst in self._instances:
            self._pull_outputs(inst)

    # ---------------------------------------------------------------- run
    def run(self, duration: float, progress=None, profile: bool = False) -> Results:
        """Simulate ``duration`` [s] from t = 0 and return the recorded results.

        Parameters
        ----------
        duration : float
            Simulated time [s].
        progress : callable, optional
            Called as ``progress(fraction)`` about 100 times during the run.
        profile : bool
            Also time each component (set inputs + doStep + get outputs) and put the mean
            time per step of every 100-step block into ``meta["profile"][name]`` [us], and the
            whole step's (every component and the master's bookkeeping) into ``meta["profile_step"]``.
        """
        if not self._open:
            self.setup()
        h = self.step
        n = int(round(duration / h))
        every = self.record_every
        n_rec = n // every + 1
        nr, nb = len(self.real_names), len(self.bool_names)
        rec_r = np.empty((n_rec, nr))
        rec_b = np.empty((n_rec, nb), dtype=np.int32)
        rec_r[0], rec_b[0] = self.Y, self.B
        # one tuple per component, everything resolved: the loop below only calls C
        plan = []
        for inst in self._instances:
            f = inst._fn
            plan.append((inst, inst.component, f["fmi2DoStep"],
                         inst.n_in_r, f["fmi2SetReal"], inst.in_r_vr, inst.in_r_ptr, inst.in_r_src, inst.U,
                         inst.n_in_b, f["fmi2SetBoolean"], inst.in_b_vr, inst.in_b_ptr, inst.in_b_src, inst.UB,
                         inst.n_out_r, f["fmi2GetReal"], inst.out_r_vr, inst.out_r_ptr,
                         inst.n_out_b, f["fmi2GetBoolean"], inst.out_b_vr, inst.out_b_ptr))
        # a Boolean input keeps its value until it is set again (FMI 2.0): set only when it changed (event flags and
        # validity change a few times a second, the call into a Python FMU costs microseconds)
        sent_b: dict[str, bytes | None] = {inst.name: None for inst in self._instances}
        # the arrays' own take: np.take's Python wrapper costs a microsecond per call, seven calls per step
        Y, B, take_r, take_b = self.Y, self.B, self.Y.take, self.B.take
        c_h = ctypes.c_double(h)
        one = ctypes.c_int(1)
        c_double = ctypes.c_double
        tick = max(1, n // 100)
        block = 100
        clock = time.perf_counter if profile else None
        spent = np.zeros((n // block + 1, len(plan) + 1))      # per component, and the whole step last
        # the current block's sums in a list: `x[i] += clock() - t` reads x[i] before the clock, inside the timed
        # window, and a list item is a fraction of a NumPy item's cost (less of the profiler in what it measures)
        acc = [0.0] * (len(plan) + 1)
        wall0 = time.perf_counter()
        k_rec = 1
        jacobi = self.scheme == "jacobi"
        for k in range(n):
            if clock:
                t_step = clock()
            t = k * h
            c_t = c_double(t)
            if jacobi:                 # everyone reads the outputs of t_k before anyone steps
                for (inst, comp, do_step, n_ir, set_r, vr_ir, p_ir, src_ir, u_r, n_ib, set_b, vr_ib, p_ib, src_ib,
                     u_b, *_outs) in plan:
                    if n_ir:
                        take_r(src_ir, out=u_r)
                        if set_r(comp, vr_ir, n_ir, p_ir) > 1:
                            inst.check(2, "fmi2SetReal", t)
                    if n_ib:
                        take_b(src_ib, out=u_b)
                        if (sent := u_b.tobytes()) != sent_b[inst.name]:
                            sent_b[inst.name] = sent
                            if set_b(comp, vr_ib, n_ib, p_ib) > 1:
                                inst.check(2, "fmi2SetBoolean", t)
            for j, (inst, comp, do_step, n_ir, set_r, vr_ir, p_ir, src_ir, u_r, n_ib, set_b, vr_ib, p_ib, src_ib, u_b,
                    n_or, get_r, vr_or, p_or, n_ob, get_b, vr_ob, p_ob) in enumerate(plan):
                if clock:
                    t_a = clock()
                if n_ir and not jacobi:
                    take_r(src_ir, out=u_r)
                    if set_r(comp, vr_ir, n_ir, p_ir) > 1:
                        inst.check(2, "fmi2SetReal", t)
                if n_ib and not jacobi:
                    take_b(src_ib, out=u_b)
                    if (sent := u_b.tobytes()) != sent_b[inst.name]:
                        sent_b[inst.name] = sent
                        if set_b(comp, vr_ib, n_ib, p_ib) > 1:
                            inst.check(2, "fmi2SetBoolean", t)
                status = do_step(comp, c_t, c_h, one)
                if status > 1:
                    inst.check(status, "fmi2DoStep", t)
                if n_or and get_r(comp, vr_or, n_or, p_or) > 1:
                    inst.check(2, "fmi2GetReal", t)
                if n_ob and get_b(comp, vr_ob, n_ob, p_ob) > 1:
                    inst.check(2, "fmi2GetBoolean", t)
                if clock:
                    acc[j] += clock() - t_a
            if (k + 1) % every == 0:
                rec_r[k_rec] = Y
                rec_b[k_rec] = B
                k_rec += 1
            if progress is not None and k % tick == 0:
                progress(k / n)
            if clock:
                acc[-1] += clock() - t_step
                if (k + 1) % block == 0:
                    spent[k // block] = acc
                    acc = [0.0] * len(acc)
        wall = time.perf_counter() - wall0
        dtype = [("time", float)] + [(nm, float) for nm in self.real_names] + [(nm, bool) for nm in self.bool_names]
        data = np.empty(k_rec, dtype=dtype)
        data["time"] = np.arange(k_rec) * h * every
        for i, nm in enumerate(self.real_names):
            data[nm] = rec_r[:k_rec, i]
        for i, nm in enumerate(self.bool_names):
            data[nm] = rec_b[:k_rec, i] != 0
        meta = {"step": h, "duration": n * h, "steps": n, "wall_time": wall, "master": "fmpy", "scheme": self.scheme,
                "real_time_factor": (n * h / wall) if wall > 0 else math.inf,
                "us_per_step": wall / max(n, 1) * 1e6,
                "components": [{"name": c.name, "fmu": c.fmu, "parameters": dict(c.parameters)}
                               for c in self.components],
                "connections": [f"{s[0]}.{s[1]} -> {d[0]}.{d[1]}" for d, s in self.links.items()],
                "unconnected_inputs": list(self.unconnected),
                "messages": [f"[{lvl}] {inst}: {msg}" for inst, lvl, msg in self.messages]}
        if profile:
            full = n // block
            meta["profile"] = {inst.name: (spent[:full, j] / block * 1e6).tolist()
                               for j, (inst, *_rest) in enumerate(plan)}
            meta["profile_step"] = (spent[:full, -1] / block * 1e6).tolist()
        return Results(data, meta)

    # ---------------------------------------------------------------- teardown
    def close(self) -> None:
        """Terminate and free every instance (idempotent)."""
        for inst in reversed(self._instances):
            try:
                inst.slave.terminate()
            except Exception:  # noqa: BLE001 - best effort during teardown
                pass
            try:
                inst.slave.fmi2FreeInstance(inst.slave.component)
            except Exception:  # noqa: BLE001
                pass
        self._instances = []
        self._open = False

    def __enter__(self):
        self.setup()
        return self

    def __exit__(self, *exc):
        self.close()
