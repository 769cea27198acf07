"""A second master: the same closed loop run by DNV's libcosim (``pip install libcosimpy``).

libcosim's fixed-step algorithm is a Jacobi scheme: every slave steps from the inputs
transferred at the previous communication point, in parallel worker threads, then outputs
are transferred to the connected inputs.  With ``scheme="jacobi"`` the project's fmpy master
(:class:`~sideslip.cosim.master.CoSimulation`) does exactly that, so the two must give the
same trajectories; the test suite checks it to 1e-9.

The wiring is the fmpy master's (:func:`~sideslip.cosim.assembly.resolve_connections`):
components, parameters (start values set before initialisation) and connections by name.
Recording uses libcosim's last-value observer after every step, so the results have the
layout of :class:`~sideslip.cosim.results.Results` (``time`` and ``<instance>.<variable>``).
libcosim initialises inside its first step, so the outputs right after initialisation
cannot be observed: the rows start at ``t = step`` (the fmpy master's start at 0).

libcosim loads the FMUs into this process, so they share this interpreter like in fmpy.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from fmpy import read_model_description

from ..fmi.build import DEFAULT_OUT
from ..fmi.variables import fmi_value
from .assembly import MasterError, fmu_paths, interface_of, resolve_connections
from .results import Results
from .ssp import read_experiment

__all__ = ["run_libcosim", "run_libcosim_ssp", "libcosim_available"]

NANO = 1_000_000_000


def libcosim_available() -> bool:
    """Whether ``libcosimpy`` can be imported."""
    try:
        import libcosimpy.CosimExecution  # noqa: F401
    except (ImportError, OSError):
        return False
    return True


def _last_error() -> str:
    from libcosimpy._internal import get_last_error_message

    return get_last_error_message()


def _require():
    try:
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
        from libcosimpy.CosimSlave import CosimLocalSlave
    except (ImportError, OSError) as exc:
        raise MasterError("the libcosim master needs libcosimpy: pip install libcosimpy "
                          f"(or pip install -e '.[cosim]'); import failed: {exc}") from exc
    log_output_level(CosimLogLevel.WARNING)      # its default (debug) prints every FMI Library step
    return CosimExecution, CosimLocalSlave, CosimObserver


def _set_start(execution, index: int, var, key: str, value) -> None:
    """Parameter ``key = value`` as a libcosim initial value of the right type."""
    setter = getattr(execution, f"{var.type.lower()}_initial_value")
    if not setter(index, var.valueReference, fmi_value(var.type, value, key)):
        raise MasterError(f"libcosim refused the initial value {key} = {value!r}: {_last_error()}")


def run_libcosim(components, connections=(), duration: float = 1.0, step: float = 1e-3,
                 fmu_dir: str | Path = DEFAULT_OUT) -> Results:
    """Run components in closed loop with libcosim.

    Parameters
    ----------
    components : list of Component
        As for :class:`~sideslip.cosim.master.CoSimulation` (order = slave order).
    connections : iterable of (str, str)
        Explicit ``("src.output", "dst.input")`` pairs; the rest connect by name.
    duration : float
        Simulated time [s].
    step : float
        Communication step [s]; a whole number of nanoseconds (libcosim's time unit).
    fmu_dir : path
        Folder of the built FMUs.

    Returns
    -------
    Results
        Every output of every component after every step (rows from ``t = step``);
        ``meta["master"] = "libcosim"``.
    """
    CosimExecution, CosimLocalSlave, CosimObserver = _require()
    components = list(components)
    step_ns = int(round(step * NANO))
    if step_ns <= 0 or abs(step_ns / NANO - step) > 1e-15:
        raise MasterError(f"step {step} s is not a whole number of nanoseconds")
    paths = fmu_paths(components, fmu_dir)
    mds = {c.name: read_model_description(str(paths[c.name])) for c in components}
    links, unconnected = resolve_connections([interface_of(c.name, mds[c.name]) for c in components], connections)

    execution = CosimExecution.from_step_size(step_ns)
    slaves, index = [], {}
    for c in components:
        slave = CosimLocalSlave(fmu_path=str(paths[c.name]), instance_name=c.name)
        slaves.append(slave)                          # keep alive while the execution runs
        i = execution.add_local_slave(local_slave=slave)
        if i < 0:
            raise MasterError(f"libcosim could not load {paths[c.name]} as {c.name!r}: {_last_error()}")
        index[c.name] = i
        by_name = {v.name: v for v in mds[c.name].modelVariables}
        for key, value in c.parameters.items():
            var = by_name.get(key)
            if var is None or var.causality != "parameter":
                raise MasterError(f"{c.name}: no parameter {key!r}")
            _set_start(execution, i, var, key, value)
    vr = {(c.name, v.name): v.valueReference for c in components for v in mds[c.name].modelVariables}
    for (dst, name), (src, out, kind) in links.items():
        connect = execution.connect_real_variables if kind == "Real" else execution.connect_boolean_variables
        if connect(index[src], vr[src, out], index[dst], vr[dst, name]) != 0:       # returns the C status
            raise MasterError(f"libcosim refused the connection {src}.{out} -> {dst}.{name}: {_last_error()}")

    real_out = [(c.name, v.name, v.valueReference) for c in components for v in mds[c.name].modelVariables
                if v.causality == "output" and v.type == "Real"]
    bool_out = [(c.name, v.name, v.valueReference) for c in components for v in mds[c.name].modelVariables
                if v.causality == "output" and v.type == "Boolean"]
    res = _observe(execution, CosimObserver, index, real_out, bool_out, duration, step)
    res.meta.update({"components": [{"name": c.name, "fmu": c.fmu, "parameters": dict(c.parameters)}
                                    for c in components],
                     "connections": [f"{s[0]}.{s[1]} -> {d[0]}.{d[1]}" for d, s in links.items()],
                     "unconnected_inputs": list(unconnected)})
    return res


def run_libcosim_ssp(ssp: str | Path, duration: float | None = None, step: float | None = None) -> Results:
    """Run an SSP package (e.g. from ``python -m sideslip export-ssp``) with libcosim.

    Parameters
    ----------
    ssp : path
        ``.ssp`` file or folder holding ``SystemStructure.ssd``.
    duration : float, optional
        Simulated time [s] (default: the ``DefaultExperiment`` stop time).
    step : float, optional
        Communication step [s] (default: the package's OSP ``FixedStepAlgorithm``).

    Returns
    -------
    Results
        Every output of every component after every step (rows from ``t = step``).
    """
    import tempfile
    import zipfile

    CosimExecution, _, CosimObserver = _require()
    ssp = Path(ssp)
    with tempfile.TemporaryDirectory(prefix="sideslip_ssp_") as tmp:
        folder = ssp
        if ssp.is_file():
            folder = Path(tmp)
            with zipfile.ZipFile(ssp) as z:
                z.extractall(folder)
        start, stop, base_step = read_experiment(folder / "SystemStructure.ssd")
        if step is None:
            if base_step is None:
                raise MasterError(f"{ssp}: no fixed step in the package; give step")
            step = base_step
        if duration is None:
            if stop is None:
                raise MasterError(f"{ssp}: no DefaultExperiment stopTime; give duration")
            duration = stop - start
        try:
            execution = CosimExecution.from_ssp_file(str(folder), step_size=int(round(step * NANO)))
        except AssertionError as exc:                 # libcosimpy reports a failed load this way
            raise MasterError(f"libcosim could not load {ssp}: {exc}") from exc
        index, real_out, bool_out = {}, [], []
        for info in execution.slave_infos():
            name = info.name.decode()
            index[name] = info.index
            for v in execution.slave_variables(info.index):
                if v.causality == 2 and v.type in (0, 3):                 # output; Real / Boolean
                    (real_out if v.type == 0 else bool_out).append((name, v.name.decode(), v.reference))
        return _observe(execution, CosimObserver, index, real_out, bool_out, duration, step)


def _observe(execution, CosimObserver, index, real_out, bool_out, duration, step) -> Results:
    """Step ``execution`` for ``duration`` and record the given outputs after every step."""
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer=observer)
    order = sorted(index, key=index.get)                  # slave order; columns grouped by slave
    real_out = sorted(real_out, key=lambda r: index[r[0]])
    bool_out = sorted(bool_out, key=lambda r: index[r[0]])
    groups_r = [(index[inst], [vr for i, _, vr in real_out if i == inst]) for inst in order]
    groups_b = [(index[inst], [vr for i, _, vr in bool_out if i == inst]) for inst in order]
    n = int(round(duration / step))
    rec_r = np.empty((n, len(real_out)))
    rec_b = np.empty((n, len(bool_out)), dtype=bool)
    wall0 = time.perf_counter()
    for k in range(n):                     # the first call initialises, then steps
        if not execution.step():
            raise MasterError(f"libcosim: the step from t = {k * step:g} s failed: {_last_error()}")
        col = 0
        for i, vrs in groups_r:
            if vrs:
                rec_r[k, col:col + len(vrs)] = observer.last_real_values(slave_index=i, variable_references=vrs)
                col += len(vrs)
        col = 0
        for i, vrs in groups_b:
            if vrs:
                rec_b[k, col:col + len(vrs)] = observer.last_boolean_values(slave_index=i, variable_references=vrs)
                col += len(vrs)
    wall = time.perf_counter() - wall0
    columns = {"time": np.arange(1, n + 1) * step}
    columns.update({f"{inst}.{name}": rec_r[:, j] for j, (inst, name, _) in enumerate(real_out)})
    columns.update({f"{inst}.{name}": rec_b[:, j] for j, (inst, name, _) in enumerate(bool_out)})
    meta = {"master": "libcosim", "scheme": "jacobi", "step": step, "duration": n * step, "steps": n,
            "wall_time": wall, "real_time_factor": n * step / wall if wall > 0 else float("inf"),
            "us_per_step": wall / max(n, 1) * 1e6, "components": [], "connections": [],
            "unconnected_inputs": [], "messages": []}
    return Results.from_columns(columns, meta)
