"""Estimator FMUs on a recorded drive, with metrics and a plot (``python -m sideslip replay``).

:func:`replay_log` reads a CSV log (:func:`sideslip.recording.read_log`: contract column names or a
TOML map with units, scale and offset), runs the estimator FMUs on it
(:func:`sideslip.cosim.replay.replay_fmus`) and writes ``estimates.csv``; when the log has a
reference sideslip (an optical or INS sensor, or a simulation's truth) it also scores every
estimator as the benchmark does (:func:`sideslip.studies.accuracy.row_metrics`) and writes
``metrics.json`` and ``sideslip.png``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..cosim.assembly import Component, estimator_instances
from ..cosim.replay import replay_fmus
from ..fmi.build import DEFAULT_OUT
from ..recording import Recording, read_log
from .accuracy import recorded_speed, row_metrics
from .plots import plot_sideslip

__all__ = ["replay_log", "format_replay"]


def replay_log(csv_path, estimators, map_path=None, vehicle: str | None = None, params: dict | None = None,
               step: float = 1e-3, out_dir: str | Path = "out/replay", fmu_dir: str | Path = DEFAULT_OUT) -> dict:
    """Run estimator FMUs on a recorded drive and score them against its reference sideslip.

    Parameters
    ----------
    csv_path, map_path : path
        The log and its optional column map.
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

    Returns
    -------
    dict
        ``source``, ``duration``, ``unconnected_inputs``, ``metrics`` (per instance, empty without a
        reference sideslip) and ``files``.

    Raises
    ------
    LogError
        A log that cannot be used (naming the column and the reason).
    """
    rec = read_log(csv_path, map_path)
    instances = estimator_instances(estimators)
    if not instances:
        raise ValueError("name at least one estimator FMU (--estimator)")
    params = dict(params or {})
    components = []
    for inst, fmu in instances:
        p = {"vehicle": vehicle} if vehicle else {}
        p.update({k.split(".", 1)[1]: v for k, v in params.items() if k.split(".", 1)[0] == inst})
        components.append(Component(fmu, inst, p))
    unknown = {k.split(".", 1)[0] for k in params} - {inst for inst, _ in instances}
    if unknown:
        raise ValueError(f"--param names instances {', '.join(sorted(unknown))}, the run has "
                         f"{', '.join(inst for inst, _ in instances)}")
    res = replay_fmus(rec, components, step, fmu_dir)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    res.to_csv(out / "estimates.csv")
    files = [out / "estimates.csv"]
    metrics = {}
    grid = rec.on_grid(step)
    if "beta" in grid.reference:
        for inst, _ in instances:
            metrics[inst] = row_metrics(grid, res[f"{inst}.beta_hat"], res[f"{inst}.beta_hat_std"],
                                        res[f"{inst}.valid"])
        (out / "metrics.json").write_text(json.dumps({"source": rec.source, "metrics": metrics}, indent=1,
                                                     default=float))
        files += [out / "metrics.json", _plot(grid, res, [i for i, _ in instances], out / "sideslip.png")]
    return {"source": rec.source, "duration": rec.duration, "unconnected_inputs": res.meta["unconnected_inputs"],
            "real_time_factor": res.meta["real_time_factor"], "metrics": metrics, "files": [str(f) for f in files]}


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
    if summary["unconnected_inputs"]:
        lines.append("inputs not in the log (start values used): " + ", ".join(summary["unconnected_inputs"]))
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
