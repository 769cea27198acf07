"""Estimator FMUs on a recorded drive, with metrics and a plot (``python -m sideslip replay``).

:func:`replay_log` reads a log (CSV, Parquet or MDF: :func:`sideslip.recording.read_log`, contract column
names or a TOML map with units, scale and offset), lets a logged speed stand in for missing wheel speeds when
asked, checks the log's plausibility (:func:`sideslip.recording.plausibility`), runs the estimator FMUs on it
(:func:`sideslip.cosim.replay.replay_fmus`) and writes ``estimates.csv`` and ``metrics.json`` (the findings, the
metrics and the record that reproduces the run: :func:`replay_record`); when the log has a reference sideslip (an
optical or INS sensor, or a simulation's truth) it also scores every estimator as the benchmark does
(:func:`sideslip.studies.accuracy.row_metrics`) and plots ``sideslip.png``.
"""
from __future__ import annotations

import hashlib
import json
import math
import shlex
from pathlib import Path

import numpy as np

from ..cosim.assembly import Component, estimator_instances
from ..cosim.replay import replay_fmus
from ..fmi.build import DEFAULT_OUT
from ..recording import Recording, plausibility, read_log, recorded_speed
from ..vehicles import load_vehicle
from .accuracy import row_metrics
from .plots import plot_sideslip

__all__ = ["replay_log", "format_replay", "replay_record"]


def replay_log(csv_path, estimators, map_path=None, vehicle: str | None = None, params: dict | None = None,
               step: float = 1e-3, out_dir: str | Path = "out/replay", fmu_dir: str | Path = DEFAULT_OUT,
               wheel_speeds_from: str | None = None, window: tuple | None = None, progress: bool = True) -> dict:
    """Run estimator FMUs on a recorded drive and score them against its reference sideslip.

    Parameters
    ----------
    csv_path, map_path : path
        The log (CSV, Parquet or MDF: :data:`sideslip.recording.LOG_READERS`) and its optional column map.
    estimators : list of str
        Estimator FMUs, ``NAME`` or ``instance=NAME``.
    vehicle : str, optional
        Every estimator's ``vehicle`` parameter (a bundled name or a TOML file of the logged car).
    params : dict, optional
        ``{"instance.name": value}`` parameter overrides.
    step : float
        Communication step [s] (the log is resampled onto it).
    out_dir, fmu_dir : path
        Where the results go; the built FMUs.
    wheel_speeds_from : str, optional
        What stands in for missing wheel speeds (:meth:`sideslip.recording.Recording.with_wheel_speeds`; default:
        the map's ``wheel_speeds_from``).
    window : (float, float), optional
        Time span [s] the metrics and the plot cover (the estimators run over the whole log).

    Returns
    -------
    dict
        ``source``, ``duration``, ``unconnected_inputs``, ``plausibility`` (what looks wrong in the log),
        ``metrics`` (per instance, empty without a reference sideslip), ``record`` (what reproduces the run) and
        ``files``.

    Raises
    ------
    LogError
        A log that cannot be used (naming the column and the reason).
    """
    instances = estimator_instances(estimators)
    if not instances:
        raise ValueError("name at least one estimator FMU (--estimator)")
    params = dict(params or {})
    unknown = {k.split(".", 1)[0] for k in params} - {inst for inst, _ in instances}
    if unknown:
        raise ValueError(f"--param names instances {', '.join(sorted(unknown))}, the run has "
                         f"{', '.join(inst for inst, _ in instances)}")
    components = []
    for inst, fmu in instances:
        p = {"vehicle": vehicle} if vehicle else {}
        p.update({k.split(".", 1)[1]: v for k, v in params.items() if k.split(".", 1)[0] == inst})
        components.append(Component(fmu, inst, p))
    car = load_vehicle(vehicle or _default_vehicle(instances[0][1]))
    rec = read_log(csv_path, map_path).with_wheel_speeds(car, wheel_speeds_from)
    findings = plausibility(rec, car)
    res = replay_fmus(rec, components, step, fmu_dir, progress=progress)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    res.to_csv(out / "estimates.csv")
    files = [out / "estimates.csv"]
    metrics = {}
    grid = rec.on_grid(step)
    scored, scored_res = (grid.window(*window), res.window(*window)) if window else (grid, res)
    if "beta" in grid.reference:
        for inst, _ in instances:
            metrics[inst] = row_metrics(scored, scored_res[f"{inst}.beta_hat"], scored_res[f"{inst}.beta_hat_std"],
                                        scored_res[f"{inst}.valid"])
        files.append(_plot(scored, scored_res, [i for i, _ in instances], out / "sideslip.png"))
    record = replay_record(csv_path, map_path, vehicle, components, step, window, rec.wheel_speeds_from)
    (out / "metrics.json").write_text(json.dumps({"source": rec.source, "window": window, "plausibility": findings,
                                                  "metrics": metrics, "record": record}, indent=1, default=float))
    files.insert(1, out / "metrics.json")
    return {"source": rec.source, "duration": rec.duration, "unconnected_inputs": res.meta["unconnected_inputs"],
            "real_time_factor": res.meta["real_time_factor"], "plausibility": findings, "metrics": metrics,
            "wheel_speeds_from": rec.wheel_speeds_from, "record": record, "files": [str(f) for f in files]}


def _default_vehicle(fmu: str) -> str:
    from ..fmi.catalogue import fmu_spec

    return fmu_spec(fmu).config_class.__dataclass_fields__["vehicle"].default


def _file_record(path) -> dict | None:
    if path is None:
        return None
    p = Path(path)
    if not p.is_file():
        return {"name": str(path)}
    data = p.read_bytes()
    entry = {"path": str(p.resolve()), "sha256": hashlib.sha256(data).hexdigest()}
    if p.suffix.lower() == ".toml":
        entry["text"] = data.decode("utf-8", errors="replace")
    return entry


def replay_record(log, map_path, vehicle, components, step, window, wheel_speeds_from) -> dict:
    """What reproduces a replay: the log (path, SHA-256), the map and the vehicle file (their text), every
    estimator's parameters, the step, the window, the stand-in for wheel speeds, the versions of the software, and
    the command that runs it again."""
    import platform
    from importlib.metadata import PackageNotFoundError, version

    def ver(name):
        try:
            return version(name)
        except PackageNotFoundError:
            return None

    command = ["python", "-m", "sideslip", "replay", "--log", str(log)]
    command += ["--map", str(map_path)] if map_path else []
    command += ["--vehicle", str(vehicle)] if vehicle else []
    for c in components:
        command += ["--estimator", c.name if c.name == c.fmu else f"{c.name}={c.fmu}"]
        command += [arg for k, v in c.parameters.items() if k != "vehicle" for arg in ("--param", f"{c.name}.{k}={v}")]
    command += ["--step", f"{step:g}"]
    command += ["--wheel-speeds-from", wheel_speeds_from] if wheel_speeds_from else []
    command += ["--window", f"{window[0]:g}:{window[1]:g}"] if window else []
    return {"log": _file_record(log), "map": _file_record(map_path), "vehicle": _file_record(vehicle)
            if vehicle and Path(str(vehicle)).suffix == ".toml" else vehicle,
            "estimators": [{"instance": c.name, "fmu": c.fmu, "parameters": dict(c.parameters)} for c in components],
            "step": step, "window": list(window) if window else None, "wheel_speeds_from": wheel_speeds_from,
            "versions": {"sideslip-fmu": ver("sideslip-fmu"), "fmpy": ver("fmpy"), "pythonfmu": ver("pythonfmu"),
                         "numpy": ver("numpy"), "scipy": ver("scipy"), "python": platform.python_version()},
            "command": " ".join(shlex.quote(a) for a in command)}


def _plot(rec: Recording, res, instances, path: Path) -> Path:
    """The reference and estimated sideslip over the log (samples below the evaluation speed blanked)."""
    ref = {"time": rec.time, "ref.beta": rec.reference["beta"]}
    speed = recorded_speed(rec)
    ref["ref.vx"], ref["ref.vy"] = speed, np.zeros_like(speed)
    for inst in instances:
        ref[f"{inst}.beta_hat"] = res[f"{inst}.beta_hat"]
    return plot_sideslip(ref, instances, path, title=f"replay of {Path(rec.source).name}", plant="ref")


def format_replay(summary: dict) -> str:
    """The replay's metrics as a Markdown table."""
    lines = [f"replay of {summary['source']} ({summary['duration']:.1f} s, "
             f"{summary['real_time_factor']:.1f}x real time)"]
    if summary.get("wheel_speeds_from"):
        lines.append(f"wheel speeds: {summary['wheel_speeds_from']} stands in for them (free rolling, no slip)")
    if summary["unconnected_inputs"]:
        lines.append("inputs not in the log (start values used): " + ", ".join(summary["unconnected_inputs"]))
    for finding in summary.get("plausibility", ()):
        lines.append("CHECK THE LOG: " + finding)
    if not summary["metrics"]:
        lines.append("the log has no reference sideslip: estimates written, no metrics")
        return "\n".join(lines)
    lines += ["", "| estimator | RMS [deg] | max [deg] | predict-zero RMS [deg] | valid | RMS err / RMS std |",
              "|---|---:|---:|---:|---:|---:|"]
    for inst, m in summary["metrics"].items():
        ratio = m["std_ratio"]
        lines.append(f"| {inst} | {m['rms']:.3f} | {m['max']:.3f} | {m['zero_rms']:.3f} | {100 * m['valid']:.0f} % | "
                     f"{ratio:.2f} |" if math.isfinite(ratio) else f"| {inst} | {m['rms']:.3f} | {m['max']:.3f} | "
                     f"{m['zero_rms']:.3f} | {100 * m['valid']:.0f} % | - |")
    return "\n".join(lines)
