"""Park, Choi, Hyun, Lee (2018), "Integrated observer approach using in-vehicle sensors and GPS for
vehicle state estimation": Table 3 and a GPS outage, with the FMUs in closed loop.

* :func:`park2018_accuracy` - Table 3: max and RMS sideslip error [deg] per case for the
  integrated observer, its bicycle and kinematic EKFs, the open-loop estimator of its figures,
  and the two project baselines.
* :func:`park2018_gps_outage` - a GPS outage inserted in a Park scenario: error during the
  outage and time to recover.
"""
from __future__ import annotations


import numpy as np

from ...fmi.build import DEFAULT_OUT
from ...units import DEG, wrap_angle
from ..runs import run_jobs


PARK2018_TABLE3 = {1: (0.218, 0.063), 2: (0.623, 0.177), 3: (0.386, 0.144), 4: (0.834, 0.340), 5: (6.714, 2.455)}
"""Park 2018 Table 3: case -> (maximum, RMS) sideslip error of the integrated observer [deg]."""

PARK_ESTIMATORS = ("Park2018Observer", "OpenLoopKinematic", "LinearBicycleObserver")
PARK_COLUMNS = (("integrated", "Park2018Observer", "beta_hat"),
                ("bicycle EKF", "Park2018Observer", "beta_hat_bicycle"),
                ("kinematic EKF", "Park2018Observer", "beta_hat_kinematic"),
                ("open loop (Park)", "Park2018Observer", "beta_hat_openloop"),
                ("OpenLoopKinematic", "OpenLoopKinematic", "beta_hat"),
                ("LinearBicycleObserver", "LinearBicycleObserver", "beta_hat"))
"""Table columns: (label, estimator instance, estimate)."""


def park2018_accuracy(fmu_dir=DEFAULT_OUT, workers: int = 2, cases=(1, 2, 3, 4, 5), params=None) -> dict:
    """Park 2018 Table 3 with the sub-filters and baselines.

    Parameters
    ----------
    params : dict, optional
        ``{"Park2018Observer.<name>": value}`` overrides (ablations).

    Returns
    -------
    dict
        ``{case: {label: {"rms": deg, "max": deg}, "paper": {"rms", "max"}}}``.
    """
    jobs = [(f"park2018_case{c}", PARK_ESTIMATORS, None, params, ()) for c in cases]
    out = {}
    for c, (metrics, _) in zip(cases, run_jobs(jobs, fmu_dir, workers, as_published=True)):
        row = {label: {k: metrics["estimators"][inst][est][k] for k in ("rms", "max")}
               for label, inst, est in PARK_COLUMNS}
        row["paper"] = {"max": PARK2018_TABLE3[c][0], "rms": PARK2018_TABLE3[c][1]}
        out[c] = row
    return out


def format_park2018_accuracy(table: dict) -> str:
    """Markdown: one row per case, RMS / max [deg] per estimator, the paper's integrated observer last."""
    labels = [label for label, _, _ in PARK_COLUMNS]
    lines = ["| case | " + " | ".join(labels) + " | paper (integrated) |",
             "|---|" + "---:|" * (len(labels) + 1)]
    for c, row in table.items():
        cells = [f"{row[lb]['rms']:.3f} / {row[lb]['max']:.3f}" for lb in labels]
        lines.append(f"| {c} | " + " | ".join(cells) + f" | {row['paper']['rms']:.3f} / {row['paper']['max']:.3f} |")
    return "\n".join(lines)


def _recovery_time(t, err, t_end, band):
    """Time after ``t_end`` from which ``|err|`` stays within ``band`` (nan if it never does)."""
    after = t >= t_end
    outside = np.nonzero(after & (np.abs(err) > band))[0]
    if outside.size == 0:
        return 0.0
    if outside[-1] == t.size - 1:
        return float("nan")
    return float(t[outside[-1] + 1] - t_end)


def park2018_gps_outage(fmu_dir=DEFAULT_OUT, scenario: str = "park2018_case3", window=(15.0, 20.0),
                        workers: int = 2, band_deg: float = 0.01) -> dict:
    """A GPS outage in a Park scenario, compared with the same run without it.

    The recovery time of an estimate is the time after the fixes return from which it stays
    within ``band_deg`` of the estimate of the run without outage (same sensor noise, so the
    difference is the outage's effect alone).

    Returns
    -------
    dict
        Per estimate (``beta_hat``, ``beta_hat_kinematic``, ``beta_hat_bicycle``): RMS and max
        error [deg] during the outage with and without it, and ``recovery_s``.
    """
    a, b = window
    fields = [f"Park2018Observer.{e}" for e in ("beta_hat", "beta_hat_kinematic", "beta_hat_bicycle")]
    fields += ["plant.beta", "plant.vx", "plant.vy", "sensors.gps_valid"]
    jobs = [(scenario, ("Park2018Observer",), None, None, fields),
            (scenario, ("Park2018Observer",), {"sensor_gps_outages": f"{a:g}-{b:g}"}, None, fields)]
    (_, nominal), (_, outage) = run_jobs(jobs, fmu_dir, workers, as_published=True)
    t = outage["time"]
    during = (t >= a) & (t < b)
    out = {"scenario": scenario, "window": [a, b], "band_deg": band_deg,
           "gps_valid_during": float(outage["sensors.gps_valid"][during].mean())}
    for f in fields[:3]:
        name = f.split(".", 1)[1]
        e_out = wrap_angle(outage[f] - outage["plant.beta"]) * DEG
        e_nom = wrap_angle(nominal[f] - nominal["plant.beta"]) * DEG
        diff = np.abs(wrap_angle(outage[f] - nominal[f])) * DEG
        out[name] = {"rms_outage": float(np.sqrt(np.mean(e_out[during] ** 2))),
                     "max_outage": float(np.max(np.abs(e_out[during]))),
                     "rms_nominal": float(np.sqrt(np.mean(e_nom[during] ** 2))),
                     "max_nominal": float(np.max(np.abs(e_nom[during]))),
                     "max_shift_during": float(np.max(diff[during])),
                     "max_shift_after": float(np.max(diff[t >= b])),
                     "recovery_s": _recovery_time(t, diff, b, band_deg)}
    return out


def format_park2018_gps_outage(res: dict) -> str:
    """Markdown table of :func:`park2018_gps_outage`."""
    a, b = res["window"]
    lines = [f"GPS outage {a:g}-{b:g} s in {res['scenario']}; recovery = time after the fixes return until the "
             f"estimate stays within {res['band_deg']:g} deg of the run without outage.", "",
             "| estimate | error RMS / max during outage [deg] | same window without outage [deg] "
             "| max shift by the outage, during / after [deg] | recovery [s] |",
             "|---|---:|---:|---:|---:|"]
    for name in ("beta_hat", "beta_hat_kinematic", "beta_hat_bicycle"):
        r = res[name]
        lines.append(f"| {name} | {r['rms_outage']:.3f} / {r['max_outage']:.3f} | {r['rms_nominal']:.3f} / "
                     f"{r['max_nominal']:.3f} | {r['max_shift_during']:.3f} / {r['max_shift_after']:.3f} "
                     f"| {r['recovery_s']:.2f} |")
    return "\n".join(lines)


ACCEPTS_PARAMS = True
"""``paper park2018 --param Park2018Observer.NAME=VALUE`` overrides apply to the accuracy table."""


def report(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None, extra=()) -> tuple[dict, str]:
    """Table 3 and the GPS outage: ``(figures, Markdown)`` for ``python -m sideslip paper park2018``."""
    acc = park2018_accuracy(fmu_dir, workers, params=params or None)
    outage = park2018_gps_outage(fmu_dir, workers=workers)
    text = ["Park 2018 Table 3: sideslip error RMS / max [deg]", "", format_park2018_accuracy(acc), "",
            format_park2018_gps_outage(outage)]
    return {"accuracy": acc, "gps_outage": outage}, "\n".join(text)
