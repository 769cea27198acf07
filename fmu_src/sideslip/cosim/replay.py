"""Estimator FMUs on a recorded drive: the recording's signals drive the FMUs' inputs through fmpy.

:func:`replay_fmus` loads each estimator FMU once, sets its parameters, and steps every one of
them at the communication step through the recording (resampled onto that step by zero-order
hold, :meth:`sideslip.recording.Recording.on_grid`): the step from ``t_k-1`` to ``t_k`` gets the
recording's values at ``t_k``, as the fmpy master's Gauss-Seidel loop gives an estimator the
sensors' outputs of the same step (and as :func:`sideslip.recording.replay` steps a library model),
so a log of a closed loop replays to the loop's own estimates.  An input the recording lacks keeps its
start value (``Mz_cmd`` 0: no controller, ``mu`` 1; the GNSS of an estimator configured without it, its
``unused_inputs``) and is listed in ``meta["unconnected_inputs"]``;
an input the estimator needs that the recording cannot give is an error naming the column.
"""
from __future__ import annotations

import ctypes
import time
from pathlib import Path

import numpy as np

from ..fmi.build import DEFAULT_OUT
from ..fmi.catalogue import fmu_spec
from ..progress import progress_bar
from ..recording import LogError, OPTIONAL_INPUTS, Recording, missing_columns
from .assembly import MasterError, fmu_paths
from .master import _Instance
from .results import Results

__all__ = ["replay_fmus"]


def replay_fmus(recording: Recording, components, step: float = 1e-3, fmu_dir: str | Path = DEFAULT_OUT,
                progress: bool = False) -> Results:
    """Run estimator FMUs on a recording.

    Parameters
    ----------
    recording : Recording
        The drive (contract signal names, SI).
    components : list of Component
        Estimator FMUs with their parameters (instance names unique).
    step : float
        Communication step [s]; the recording is resampled onto it.
    fmu_dir : path
        Folder of the built FMUs (built on first use).
    progress : bool
        A progress bar on stderr when it is a terminal.

    Returns
    -------
    Results
        ``time`` and ``<instance>.<output>`` for every output, one row per step (the first row is the
        state after initialisation); ``meta`` as the fmpy master's.

    Raises
    ------
    LogError
        When an estimator needs an input the recording does not have.
    """
    components = list(components)
    names = [c.name for c in components]
    if len(set(names)) != len(names):
        raise MasterError(f"instance names must be unique: {names}")
    rec = recording.on_grid(step)
    n = len(rec.time)
    paths = fmu_paths(components, fmu_dir)
    messages: list = []
    instances, plans, unconnected = [], [], []
    try:
        for comp in components:
            unused = getattr(fmu_spec(comp.fmu).model_class, "unused_inputs", lambda p: ())(comp.parameters)
            inst = _Instance(comp, paths[comp.name], messages)
            inst.instantiate()
            instances.append(inst)
            inst.set_parameters(comp.parameters)
            real_in, bool_in = [], []
            for name, var in inst.inputs.items():
                if name in rec.signals:
                    (real_in if var.type == "Real" else bool_in).append(name)
                elif name in OPTIONAL_INPUTS or name in unused:
                    unconnected.append(f"{comp.name}.{name}")
                else:
                    raise LogError(missing_columns(rec.source, [n for n in inst.inputs if n not in rec.signals
                                                                and n not in OPTIONAL_INPUTS and n not in unused],
                                                   comp.fmu))
            vr = lambda ns: (ctypes.c_uint * len(ns))(*[inst.vars[v].valueReference for v in ns])  # noqa: E731,B023
            u_real = np.ascontiguousarray(np.column_stack([rec.signals[v] for v in real_in]) if real_in
                                          else np.zeros((n, 0)))
            u_bool = np.ascontiguousarray((np.column_stack([rec.signals[v] for v in bool_in]) > 0.5).astype(np.int32)
                                          if bool_in else np.zeros((n, 0), dtype=np.int32))
            outs = inst.outputs_real + inst.outputs_bool
            plans.append((inst, vr(real_in), u_real, vr(bool_in), u_bool, vr(inst.outputs_real),
                          vr(inst.outputs_bool), outs))
            inst.slave.setupExperiment(startTime=float(rec.time[0]))
            inst.slave.enterInitializationMode()
            inst.slave.exitInitializationMode()
        columns = [f"{inst.name}.{o}" for inst, *_r, outs in plans for o in outs]
        out = np.empty((n, len(columns)))
        wall0 = time.perf_counter()
        c_h, one = ctypes.c_double(step), ctypes.c_int(1)
        col = 0
        bar = progress_bar(len(plans) * rec.duration, "replay", "sim s", enabled=None if progress else False)
        for inst, vr_r, u_r, vr_b, u_b, vr_or, vr_ob, outs in plans:
            f, comp = inst._fn, inst.component
            n_r, n_b, n_or, n_ob = u_r.shape[1], u_b.shape[1], len(inst.outputs_real), len(inst.outputs_bool)
            y = np.zeros(n_or)
            yb = np.zeros(n_ob, dtype=np.int32)
            p_y, p_yb = ctypes.c_void_p(y.ctypes.data), ctypes.c_void_p(yb.ctypes.data)
            for k in range(n):
                if k:
                    t = float(rec.time[k - 1])
                    if n_r and f["fmi2SetReal"](comp, vr_r, n_r, ctypes.c_void_p(u_r[k].ctypes.data)) > 1:
                        inst.check(2, "fmi2SetReal", t)
                    if n_b and f["fmi2SetBoolean"](comp, vr_b, n_b, ctypes.c_void_p(u_b[k].ctypes.data)) > 1:
                        inst.check(2, "fmi2SetBoolean", t)
                    status = f["fmi2DoStep"](comp, ctypes.c_double(t), c_h, one)
                    if status > 1:
                        inst.check(status, "fmi2DoStep", t)
                if n_or and f["fmi2GetReal"](comp, vr_or, n_or, p_y) > 1:
                    inst.check(2, "fmi2GetReal")
                if n_ob and f["fmi2GetBoolean"](comp, vr_ob, n_ob, p_yb) > 1:
                    inst.check(2, "fmi2GetBoolean")
                out[k, col:col + n_or] = y
                out[k, col + n_or:col + n_or + n_ob] = yb
                if k % 5000 == 4999:
                    bar.update(5000 * step)
            col += len(outs)
        bar.close()
        wall = time.perf_counter() - wall0
    finally:
        for inst in reversed(instances):
            try:
                inst.slave.terminate()
                inst.slave.fmi2FreeInstance(inst.slave.component)
            except Exception:  # noqa: BLE001 - best effort during teardown
                pass
    dtype = [("time", float)] + [(c, float) for c in columns]
    data = np.empty(n, dtype=dtype)
    data["time"] = rec.time
    for i, c in enumerate(columns):
        data[c] = out[:, i]
    duration = float(rec.time[-1] - rec.time[0])
    meta = {"step": step, "duration": duration, "steps": n - 1, "wall_time": wall, "master": "replay",
            "source": rec.source, "real_time_factor": duration / wall if wall > 0 else float("inf"),
            "components": [{"name": c.name, "fmu": c.fmu, "parameters": dict(c.parameters)} for c in components],
            "unconnected_inputs": unconnected,
            "messages": [f"[{lvl}] {inst}: {msg}" for inst, lvl, msg in messages]}
    return Results(data, meta)
