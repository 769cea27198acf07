"""A third master: the same closed loop run by OpenModelica's OMSimulator (not on PyPI: see the deployment page).

OMSimulator applies only Real, Integer and Boolean start values before instantiation (String ones are
dropped without a message), so every component is configured by its numeric parameters
(:meth:`~sideslip.fmi.catalogue.FmuSpec.numeric_parameters`): the vehicle as ``vehicle.<field>``, the
maneuver as ``maneuver_kind`` and ``<maneuver>.<field>``, choices as ``<field>_index``.  Its fixed-step
master ("oms-ma") is a Jacobi scheme, so the trajectories equal the fmpy master's with
``scheme="jacobi"``; the test suite checks it to 1e-9.

Two routes:

* :func:`run_omsimulator` loads the FMUs into this process through OMSimulator's C API (its Python
  package ``OMSimulator.Capi``), steps with ``oms_stepUntil`` and reads every output after every step
  (exact doubles);
* :func:`run_omsimulator_ssp` runs an SSP package (:func:`~sideslip.cosim.ssp.export_ssp`) with the
  ``OMSimulator`` command-line program and reads its ``.mat`` result file.

Where OMSimulator is comes from the environment variable ``SIDESLIP_OMSIMULATOR``: its install folder
(with ``bin/OMSimulator`` and ``lib/OMSimulator``).
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
from fmpy import read_model_description
from scipy.io import loadmat

from ..fmi.build import DEFAULT_OUT
from ..fmi.variables import fmi_value
from .assembly import MasterError, fmu_paths, interface_of, numeric_parameters, resolve_connections
from .results import Results
from .ssp import read_experiment

__all__ = ["run_omsimulator", "run_omsimulator_ssp", "omsimulator_home", "ENV"]

ENV = "SIDESLIP_OMSIMULATOR"
"""Environment variable naming OMSimulator's install folder."""


def omsimulator_home() -> Path | None:
    """OMSimulator's install folder from :data:`ENV`, or ``None`` when it is not set or not there."""
    home = os.environ.get(ENV)
    return Path(home) if home and (Path(home) / "lib" / "OMSimulator").is_dir() else None


def _home() -> Path:
    home = omsimulator_home()
    if home is None:
        raise MasterError(f"OMSimulator not found: set {ENV} to its install folder (holding bin/OMSimulator "
                          "and lib/OMSimulator)")
    return home


def _capi():
    lib = str(_home() / "lib")
    if lib not in sys.path:
        sys.path.append(lib)
    from OMSimulator import Capi

    return Capi


def run_omsimulator(components, connections=(), duration: float = 1.0, step: float = 1e-3,
                    fmu_dir: str | Path = DEFAULT_OUT, temp_dir: str | Path | None = None) -> Results:
    """Run components in closed loop in OMSimulator (in this process, through its C API).

    Parameters
    ----------
    components : list of Component
        As for :class:`~sideslip.cosim.master.CoSimulation`; parameters are converted to numbers.
    connections : iterable of (str, str)
        Explicit ``("src.output", "dst.input")`` pairs; the rest connect by name.
    duration : float
        Simulated time [s].
    step : float
        Communication step [s].
    fmu_dir : path
        Folder of the built FMUs.
    temp_dir : path, optional
        OMSimulator's temporary folder (default: a new one, removed afterwards); OMSimulator deletes each
        FMU's unpacked folder there once it is loaded.

    Returns
    -------
    Results
        Every Real and Boolean output of every component after every step (rows from ``t = step``);
        ``meta["master"] = "omsimulator"``.
    """
    capi = _capi()
    components = list(components)
    paths = fmu_paths(components, fmu_dir)
    mds = {c.name: read_model_description(str(paths[c.name])) for c in components}
    links, unconnected = resolve_connections([interface_of(c.name, mds[c.name]) for c in components], connections)
    model = f"sideslip{os.getpid()}"
    root = f"{model}.root"

    def call(status, what: str):
        if getattr(status, "value", status) != 0:                  # OMSimulator's Status enumeration: 0 is ok
            raise MasterError(f"OMSimulator: {what} failed ({status})")

    with tempfile.TemporaryDirectory(prefix="sideslip_oms_") as tmp:
        call(capi.setTempDirectory(str(temp_dir or tmp)), "setTempDirectory")
        call(capi.newModel(model), "newModel")
        try:
            call(capi.addSystem(root, 1), "addSystem")                  # a weakly coupled (co-simulation) system
            for c in components:
                params = numeric_parameters(c)
                call(capi.addSubModel(f"{root}.{c.name}", str(paths[c.name])), f"loading {paths[c.name]}")
                by_name = {v.name: v for v in mds[c.name].modelVariables}
                for key, value in params.items():
                    var = by_name.get(key)
                    if var is None or var.causality != "parameter":
                        raise MasterError(f"{c.name}: no parameter {key!r}")
                    call(getattr(capi, f"set{var.type}")(f"{root}.{c.name}.{key}", fmi_value(var.type, value, key)),
                         f"setting {c.name}.{key}")
            for (dst, name), (src, out, _) in links.items():
                call(capi.addConnection(f"{root}.{src}.{out}", f"{root}.{dst}.{name}"),
                     f"connecting {src}.{out} -> {dst}.{name}")
            call(capi.setFixedStepSize(root, step), "setFixedStepSize")
            call(capi.setStopTime(model, duration), "setStopTime")
            result = Path(tmp) / "result.mat"
            call(capi.setResultFile(model, str(result), 1000), "setResultFile")
            call(capi.instantiate(model), "instantiate")
            call(capi.initialize(model), "initialize")
            wall0 = time.perf_counter()
            call(capi.simulate(model), "simulate")
            wall = time.perf_counter() - wall0
            n = int(round(duration / step))
            call(capi.terminate(model), "terminate")
        finally:
            capi.delete(model)
        columns = _columns(_read_mat(result), 0.0)
    outputs = {f"{c.name}.{v.name}": v.type for c in components for v in mds[c.name].modelVariables
               if v.causality == "output" and v.type in ("Real", "Boolean")}
    data = {"time": columns["time"]}
    data.update({name: columns[name].astype(bool) if kind == "Boolean" else columns[name]
                 for name, kind in outputs.items()})
    meta = {"master": "omsimulator", "scheme": "jacobi", "step": step, "wall_time": wall,
            "real_time_factor": n * step / wall if wall > 0 else float("inf"), "us_per_step": wall / max(n, 1) * 1e6,
            "components": [{"name": c.name, "fmu": c.fmu, "parameters": numeric_parameters(c)} for c in components],
            "connections": [f"{s[0]}.{s[1]} -> {d[0]}.{d[1]}" for d, s in links.items()],
            "unconnected_inputs": list(unconnected), "messages": []}
    return Results.from_columns(data, meta)


def _read_mat(path: Path) -> dict[str, np.ndarray]:
    """Trajectories by name from an OMSimulator ``.mat`` result file (the transposed ``Atrajectory`` layout:
    ``name`` and ``dataInfo`` per variable, ``data_1`` for parameters, ``data_2`` for signals)."""
    mat = loadmat(str(path))
    info = mat["dataInfo"]
    rows = [str(row).ljust(info.shape[1]) for row in mat["name"]]           # loadmat strips trailing blanks
    names = ["".join(chars).strip("\0 ") for chars in zip(*rows)]
    out = {}
    for j, name in enumerate(names):
        matrix, column = int(info[0, j]), int(info[1, j])
        data = mat[f"data_{matrix if matrix else 2}"]
        row = data[abs(column) - 1] if column else data[0]
        out[name] = -row if column < 0 else row
    return out


def _columns(trajectories: dict, start: float) -> dict[str, np.ndarray]:
    """Signals by ``<instance>.<variable>`` at each communication point after ``start``.

    OMSimulator writes each point before and after the exchange of values (the row after it is kept), and
    its time is a sum of steps: where the sum falls short of the stop time by rounding it takes one more
    step of about 1e-14 s (the point before that step is kept)."""
    t = trajectories["time"]
    last = np.flatnonzero(np.r_[np.diff(t) > 0, True])                 # the row after the exchange
    close = np.r_[False, np.diff(t[last]) < 1e-9 * np.maximum(1.0, np.abs(t[last][1:]))]
    keep = last[~close & (t[last] > start + 1e-9)]
    out = {"time": t[keep]}
    for name, values in trajectories.items():
        if name != "time" and len(values) == len(t):
            out[name.split(".", 2)[-1]] = values[keep]                   # <model>.<system>.<instance>.<var>
    return out


def run_omsimulator_ssp(ssp: str | Path, duration: float | None = None, step: float | None = None,
                        timeout: float = 3600.0) -> Results:
    """Run an SSP package with the ``OMSimulator`` program.

    Parameters
    ----------
    ssp : path
        ``.ssp`` file (e.g. from ``python -m sideslip export-ssp``).
    duration, step : float, optional
        Stop time and communication step [s] (default: the package's).
    timeout : float
        Wall-clock limit [s].

    Returns
    -------
    Results
        Every recorded signal at each communication point from ``t = step`` (OMSimulator writes each
        point before and after the exchange: the row after it is kept), columns
        ``<instance>.<variable>``.
    """
    program = _home() / "bin" / "OMSimulator"
    ssp = Path(ssp).resolve()
    with tempfile.TemporaryDirectory(prefix="sideslip_oms_") as tmp:
        with zipfile.ZipFile(ssp) as z:
            z.extract("SystemStructure.ssd", tmp)
        start, stop, base_step = read_experiment(Path(tmp) / "SystemStructure.ssd")
        step = step or base_step
        stop = start + duration if duration is not None else stop
        result = Path(tmp) / "result.mat"
        cmd = [str(program), f"--tempDir={tmp}", f"--resultFile={result}", f"--stopTime={stop!r}", str(ssp)]
        if step:
            cmd.insert(1, f"--stepSize={step!r}")
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=tmp)
        if proc.returncode != 0 or not result.is_file():
            raise MasterError(f"OMSimulator failed on {ssp} (exit {proc.returncode}):\n"
                              + (proc.stdout + proc.stderr)[-3000:])
        data = _columns(_read_mat(result), start)
    return Results.from_columns(data, meta={"master": "omsimulator-ssp", "log": proc.stdout[-3000:]})
