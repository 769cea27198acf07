"""Yoon, Peng (2014), "Robust vehicle sideslip angle estimation through a disturbance rejection filter
that integrates a magnetometer with GPS": Section V, with the FMUs in closed loop.

* :func:`yoon2014_accuracy` - sideslip RMS per run and overall with the error sources of
  Table II, the ablations, and Table III's disturbance levels.
"""
from __future__ import annotations


import numpy as np

from ...fmi.build import DEFAULT_OUT
from ...units import DEG, wrap_angle
from ..runs import run_jobs
from ..metrics import scored_samples



YOON_SCENARIOS = tuple(f"yoon2014_{m}_{r}{b}" for m in ("slc", "dlc", "slalom", "jturn") for r in ("asphalt", "ice")
                       for b in ("", "_banked"))
YOON_VARIANTS = {"full": {}, "no_shifting": {"measurement_shifting": False},
                 "no_rejection": {"disturbance_rejection": False}}
"""The method and its two ablations, run side by side (one FMU, three instances)."""
YOON_DISTURBANCES = {"table2": {}, "[0.05,1] at 20%": {"sensor_mag_dist_min": 0.05, "sensor_mag_dist_max": 1.0,
                                                       "sensor_mag_dist_share": 0.2},
                     "[0.05,1] at 40%": {"sensor_mag_dist_min": 0.05, "sensor_mag_dist_max": 1.0,
                                         "sensor_mag_dist_share": 0.4}}
"""Magnetic disturbance levels: Table II's (the scenarios' own) and Table III's two."""


def yoon2014_accuracy(fmu_dir=DEFAULT_OUT, workers: int = 2, scenarios=YOON_SCENARIOS,
                      disturbances=tuple(YOON_DISTURBANCES)) -> dict:
    """Sideslip RMS [deg] of Yoon 2014 and its ablations per run, per disturbance level, and overall.

    Returns
    -------
    dict
        ``{level: {"runs": {scenario: {variant: rms}}, "overall": {variant: rms}}}``; "overall" is
        the RMS over all samples of all runs (each run's valid samples above 2 m/s).
    """
    ests = tuple(f"{v}=Yoon2014DualKF" for v in YOON_VARIANTS)
    params = {f"{v}.{k}": val for v, over in YOON_VARIANTS.items() for k, val in over.items()}
    fields = ["plant.beta", "plant.vx", "plant.vy", *(f"{v}.{f}" for v in YOON_VARIANTS for f in ("beta_hat", "valid"))]
    jobs = [(sc, ests, YOON_DISTURBANCES[level] or None, params, fields) for level in disturbances for sc in scenarios]
    results = iter(run_jobs(jobs, fmu_dir, workers, as_published=True))
    out = {}
    for level in disturbances:
        runs, pooled = {}, {v: [] for v in YOON_VARIANTS}
        for sc in scenarios:
            metrics, arr = next(results)
            runs[sc] = {v: metrics["estimators"][v]["beta_hat"]["rms"] for v in YOON_VARIANTS}
            moving = scored_samples(np.hypot(arr["plant.vx"], arr["plant.vy"]))
            for v in YOON_VARIANTS:
                ok = moving & (arr[f"{v}.valid"] > 0.5)
                pooled[v].append(wrap_angle(arr[f"{v}.beta_hat"][ok] - arr["plant.beta"][ok]) * DEG)
        out[level] = {"runs": runs, "overall": {v: float(np.sqrt(np.mean(np.concatenate(e) ** 2)))
                                                for v, e in pooled.items()}}
    return out


def format_yoon2014_accuracy(table: dict) -> str:
    """Markdown: per run and overall sideslip RMS [deg] of the method and its ablations, per disturbance level."""
    variants = list(YOON_VARIANTS)
    lines = []
    for level, res in table.items():
        lines += [f"Magnetic disturbances: {level}", "",
                  "| run | " + " | ".join(variants) + " |", "|---|" + "---:|" * len(variants)]
        for sc, row in res["runs"].items():
            lines.append(f"| {sc} | " + " | ".join(f"{row[v]:.3f}" for v in variants) + " |")
        lines.append("| **overall** | " + " | ".join(f"**{res['overall'][v]:.3f}**" for v in variants) + " |")
        lines.append("")
    return "\n".join(lines).rstrip()


ACCEPTS_PARAMS = False


def report(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None, extra=()) -> tuple[dict, str]:
    """Section V (only the ``extra`` scenarios when given): ``(figures, Markdown)``."""
    acc = yoon2014_accuracy(fmu_dir, workers, scenarios=tuple(extra) or YOON_SCENARIOS)
    return {"accuracy": acc}, "\n".join(["Yoon 2014: sideslip RMS [deg] of the method and its ablations", "",
                                         format_yoon2014_accuracy(acc)])
