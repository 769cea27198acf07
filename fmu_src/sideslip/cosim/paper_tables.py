"""The papers' result tables, reproduced with the FMUs in closed loop.

Each function runs the scenarios of one paper through the fmpy master (estimator FMUs next
to driver, plant and sensors; several runs in parallel on a process pool) and returns the
figures the paper reports next to the paper's own values; ``format_*`` turn them into the
Markdown tables of the README.  ``python -m sideslip paper NAME`` prints them.

* :func:`park2018_accuracy` - Table 3 of Park 2018: max and RMS sideslip error [deg] per
  case for the integrated observer, its bicycle and kinematic EKFs, the open-loop estimator
  of its figures, and the two project baselines.
* :func:`park2018_gps_outage` - a GPS outage inserted in a Park scenario: error during the
  outage and time to recover.
* :func:`kim2016_accuracy` - Table 3 of Kim 2016: RMSE of sideslip [rad], yaw rate [rad/s]
  and steering angle [rad] on the two tracks, with the fault flag (false alarms).
* :func:`kim2016_fault_detection` - detection delay of stuck and offset steering-sensor
  faults.
* :func:`nguyen2012_accuracy` - Table III of Nguyen 2012: RMSD of sideslip [rad] of the SRKF,
  MRKF and DACMRKF, and their error between GPS fixes.
* :func:`pi2011_accuracy` - Table 4 of Pi 2011: normalised error (eq 48) of the method and the
  model- and kinematics-based baselines on three roads.
* :func:`yoon2014_accuracy` - Yoon 2014 Section V: sideslip RMS per run and overall with the
  error sources of Table II, the ablations, and Table III's disturbance levels.
"""
from __future__ import annotations

import math
import sys
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import numpy as np

from ..fmi.build import DEFAULT_OUT, ensure_fmus
from .metrics import wrap
from .runner import run_scenario

__all__ = ["PARK2018_TABLE3", "KIM2016_TABLE3", "NGUYEN2012_TABLE3", "PI2011_TABLE4", "nguyen2012_accuracy",
           "format_nguyen2012_accuracy", "pi2011_accuracy", "format_pi2011_accuracy", "yoon2014_accuracy",
           "format_yoon2014_accuracy", "run_jobs", "park2018_accuracy", "park2018_gps_outage",
           "kim2016_accuracy", "kim2016_fault_detection", "format_park2018_accuracy", "format_park2018_gps_outage",
           "format_kim2016_accuracy", "format_kim2016_fault_detection"]

_DEG = 180.0 / math.pi

PARK2018_TABLE3 = {1: (0.218, 0.063), 2: (0.623, 0.177), 3: (0.386, 0.144), 4: (0.834, 0.340), 5: (6.714, 2.455)}
"""Park 2018 Table 3: case -> (maximum, RMS) sideslip error of the integrated observer [deg]."""

KIM2016_TABLE3 = {40: {"beta": 0.054, "yaw_rate": 0.046, "delta": 0.017},
                  80: {"beta": 0.063, "yaw_rate": 0.046, "delta": 0.016}}
"""Kim 2016 Table 3: speed limit [km/h] -> RMSE of beta [rad], yaw rate [rad/s], steering angle [rad]."""

PARK_ESTIMATORS = ("Park2018Observer", "OpenLoopKinematic", "LinearBicycleObserver")
PARK_COLUMNS = (("integrated", "Park2018Observer", "beta_hat"),
                ("bicycle EKF", "Park2018Observer", "beta_hat_bicycle"),
                ("kinematic EKF", "Park2018Observer", "beta_hat_kinematic"),
                ("open loop (Park)", "Park2018Observer", "beta_hat_openloop"),
                ("OpenLoopKinematic", "OpenLoopKinematic", "beta_hat"),
                ("LinearBicycleObserver", "LinearBicycleObserver", "beta_hat"))
"""Table columns: (label, estimator instance, estimate)."""


# ------------------------------------------------------------------------------ running
def _job(args):
    """One closed-loop run in a worker: metrics plus the requested recorded fields."""
    scenario, estimators, overrides, params, fields, fmu_dir, duration, options = args
    run = run_scenario(scenario, estimators, fmu_dir=fmu_dir, overrides=overrides, params=params,
                       duration=duration, **options)
    res = run.results
    return run.metrics, {f: np.asarray(res[f], dtype=float) for f in ("time", *fields)}


def run_jobs(jobs, fmu_dir=DEFAULT_OUT, workers: int = 2) -> list:
    """Run ``(scenario, estimators, overrides, params, fields[, duration[, options]])`` jobs, in parallel.

    ``options`` are more keyword arguments of :func:`run_scenario` (``controller``,
    ``control_source``).

    Returns
    -------
    list of (dict, dict)
        Per job, in order: the run's metrics and ``{field: array}`` of ``fields``.
    """
    names = {e.split("=")[-1] for job in jobs for e in job[1]} | {"VehiclePlant", "VehicleSensors", "ManeuverDriver"}
    names |= {job[6]["controller"] for job in jobs if len(job) > 6 and job[6].get("controller")}
    ensure_fmus(sorted(names), fmu_dir)             # build once, before the workers start
    args = [(*job[:5], str(fmu_dir), job[5] if len(job) > 5 else None, job[6] if len(job) > 6 else {})
            for job in jobs]
    if workers <= 1 or len(args) == 1:
        return [_job(a) for a in args]
    # spawn, not fork: a forked child inherits the parent's loaded FMUs and interpreter state of
    # pythonfmu, which is not fork-safe (a child can die at start-up).  A spawned child starts
    # from the parent's sys.path, where every FMU loaded so far has put its resources/ folder
    # (with a copy of this package) in front: put this package's own folder first for them.
    saved = list(sys.path)
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    try:
        with ProcessPoolExecutor(max_workers=min(workers, len(args)), mp_context=get_context("spawn")) as pool:
            return list(pool.map(_job, args))
    finally:
        sys.path[:] = saved


# ------------------------------------------------------------------------------ Park 2018
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
    for c, (metrics, _) in zip(cases, run_jobs(jobs, fmu_dir, workers)):
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
    (_, nominal), (_, outage) = run_jobs(jobs, fmu_dir, workers)
    t = outage["time"]
    during = (t >= a) & (t < b)
    out = {"scenario": scenario, "window": [a, b], "band_deg": band_deg,
           "gps_valid_during": float(outage["sensors.gps_valid"][during].mean())}
    for f in fields[:3]:
        name = f.split(".", 1)[1]
        e_out = wrap(outage[f] - outage["plant.beta"]) * _DEG
        e_nom = wrap(nominal[f] - nominal["plant.beta"]) * _DEG
        diff = np.abs(wrap(outage[f] - nominal[f])) * _DEG
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


# ------------------------------------------------------------------------------ Kim 2016
_KIM_FIELDS = ("Kim2016SteeringEKF.delta_residual", "Kim2016SteeringEKF.delta_fault")


def _kim_row(metrics: dict, arrays: dict) -> dict:
    m = metrics["estimators"]["Kim2016SteeringEKF"]
    return {"beta": m["beta_hat"]["rms"] / _DEG, "yaw_rate": m["yaw_rate_hat"]["rms"] / _DEG,
            "delta": m["delta_hat"]["rms"] / _DEG,
            "max_abs_residual": float(np.max(np.abs(arrays["Kim2016SteeringEKF.delta_residual"]))),
            "false_alarm": bool(np.any(arrays["Kim2016SteeringEKF.delta_fault"] > 0.5))}


def kim2016_accuracy(fmu_dir=DEFAULT_OUT, workers: int = 2, extra_scenarios=()) -> dict:
    """Kim 2016 Table 3 on ``kim2016_track_40/80`` (plus fault-free ``extra_scenarios``).

    Returns
    -------
    dict
        ``{scenario: {"beta": rad, "yaw_rate": rad/s, "delta": rad, "max_abs_residual": rad,
        "false_alarm": bool, "paper": {...}}}`` (RMSE; ``paper`` only for the two tracks).
    """
    names = ["kim2016_track_40", "kim2016_track_80", *extra_scenarios]
    jobs = [(n, ("Kim2016SteeringEKF",), None, None, _KIM_FIELDS) for n in names]
    out = {}
    for n, (metrics, arrays) in zip(names, run_jobs(jobs, fmu_dir, workers)):
        row = _kim_row(metrics, arrays)
        speed = int(n.rsplit("_", 1)[1]) if n.startswith("kim2016_track_") else None
        if speed in KIM2016_TABLE3:
            row["paper"] = KIM2016_TABLE3[speed]
        out[n] = row
    return out


def format_kim2016_accuracy(table: dict) -> str:
    """Markdown table of :func:`kim2016_accuracy`."""
    lines = ["| scenario | beta RMSE [rad] | yaw rate RMSE [rad/s] | steering RMSE [rad] | max abs residual [rad] "
             "| false alarm |", "|---|---:|---:|---:|---:|---|"]
    for n, r in table.items():
        p = r.get("paper")
        cell = (lambda k: f"{r[k]:.4f} ({p[k]:.3f})") if p else (lambda k: f"{r[k]:.4f}")
        lines.append(f"| {n} | {cell('beta')} | {cell('yaw_rate')} | {cell('delta')} | {r['max_abs_residual']:.4f} "
                     f"| {'yes' if r['false_alarm'] else 'no'} |")
    return "\n".join(lines) + "\n\n(paper's Table 3 in parentheses)"


KIM_FAULTS = (("kim2016_track_80", "offset", 0.08, 60.0), ("kim2016_track_80", "offset", 0.06, 60.0),
              ("kim2016_track_40", "offset", -0.08, 100.0), ("kim2016_track_80", "stuck", 0.0, 60.0))
"""Injected steering-sensor faults: (scenario, mode, offset [rad], start time [s])."""


def kim2016_fault_detection(fmu_dir=DEFAULT_OUT, workers: int = 2, faults=KIM_FAULTS, horizon: float = 30.0) -> list:
    """Detection delay of injected steering-sensor faults.

    For a stuck sensor the fault is invisible until the true angle moves away from the frozen
    value, so the delay is also given from the moment the true road-wheel angle first departs
    from it by more than the detector's threshold.

    Returns
    -------
    list of dict
        ``scenario, mode, offset, t_fault, delay_s`` (nan: not flagged within ``horizon``) and,
        for ``stuck``, ``delay_after_departure_s``.
    """
    from ..estimators.kim2016 import Kim2016Config

    threshold = Kim2016Config().fault_threshold
    fields = (*_KIM_FIELDS, "sensors.delta_m", "driver.delta_f")
    jobs = [(sc, ("Kim2016SteeringEKF",), {"sensor_steer_fault": mode, "sensor_steer_fault_time": tf,
                                            "sensor_steer_fault_offset": off}, None, fields, tf + horizon)
            for sc, mode, off, tf in faults]
    out = []
    for (sc, mode, off, tf), (_, arr) in zip(faults, run_jobs(jobs, fmu_dir, workers)):
        t = arr["time"]
        flagged = np.nonzero(arr["Kim2016SteeringEKF.delta_fault"] > 0.5)[0]
        t_flag = float(t[flagged[0]]) if flagged.size else float("nan")
        row = {"scenario": sc, "mode": mode, "offset": off, "t_fault": tf, "delay_s": t_flag - tf,
               "flagged_before_fault": bool(flagged.size and t_flag < tf)}
        if mode == "stuck":
            frozen = arr["sensors.delta_m"][np.searchsorted(t, tf) + 20]
            departed = np.nonzero((t > tf) & (np.abs(arr["driver.delta_f"] - frozen) > threshold))[0]
            row["delay_after_departure_s"] = (t_flag - float(t[departed[0]])) if departed.size else float("nan")
        out.append(row)
    return out


def format_kim2016_fault_detection(rows: list) -> str:
    """Markdown table of :func:`kim2016_fault_detection`."""
    lines = ["| scenario | fault | from [s] | flagged after [s] |", "|---|---|---:|---:|"]
    for r in rows:
        fault = f"offset {r['offset']:+.2f} rad" if r["mode"] == "offset" else "stuck"
        delay = f"{r['delay_s']:.2f}"
        if r["mode"] == "stuck":
            delay += f" ({r['delay_after_departure_s']:.2f} after the true angle leaves the frozen value)"
        lines.append(f"| {r['scenario']} | {fault} | {r['t_fault']:g} | {delay} |")
    return "\n".join(lines)


# ------------------------------------------------------------------------------ Nguyen 2012
NGUYEN2012_TABLE3 = {"nguyen2012_lanechange": {"srkf": 1.02e-2, "mrkf": 0.86e-2, "dacmrkf": 0.38e-2},
                     "nguyen2012_cornering": {"srkf": 1.12e-2, "mrkf": 0.87e-2, "dacmrkf": 0.41e-2}}
"""Nguyen 2012 Table III: RMSD of the sideslip angle [rad]."""

NGUYEN_MODES = ("srkf", "mrkf", "dacmrkf")


def nguyen2012_accuracy(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None, bin_s: float = 0.02) -> dict:
    """Nguyen 2012 Table III: the three filters side by side (one FMU, three instances).

    Parameters
    ----------
    params : dict, optional
        ``{"<parameter>": value}`` applied to all three instances (e.g. ``discretization``).
    bin_s : float
        Width of the bins of time since the last GPS fix for the inter-sample error [s].

    Returns
    -------
    dict
        ``{scenario: {"rmsd": {mode: rad}, "paper": {mode: rad}, "inter_sample": {mode: [rad per
        bin]}, "bin_s": bin_s}}``.
    """
    ests = tuple(f"{m}=Nguyen2012DACMRKF" for m in NGUYEN_MODES)
    overrides = {f"{m}.{k}": v for m in NGUYEN_MODES for k, v in (params or {}).items()}
    overrides.update({f"{m}.mode": m for m in NGUYEN_MODES})
    fields = ["plant.beta", "sensors.gps_fresh", *(f"{m}.beta_hat" for m in NGUYEN_MODES),
              *(f"{m}.valid" for m in NGUYEN_MODES)]
    names = list(NGUYEN2012_TABLE3)
    out = {}
    for name, (metrics, arr) in zip(names, run_jobs([(n, ests, None, overrides, fields) for n in names],
                                                    fmu_dir, workers)):
        t = arr["time"]
        fixes = t[arr["sensors.gps_fresh"] > 0.5]
        last = np.searchsorted(fixes, t, side="right") - 1          # index of the last fix at or before t
        since = np.where(last >= 0, t - fixes[np.maximum(last, 0)], np.inf)
        bins = np.where(last >= 0, np.floor(np.where(last >= 0, since, 0.0) / bin_s), -1).astype(int)
        n_bins = int(round(0.2 / bin_s))
        row = {"rmsd": {}, "paper": NGUYEN2012_TABLE3[name], "inter_sample": {}, "bin_s": bin_s}
        for m in NGUYEN_MODES:
            row["rmsd"][m] = metrics["estimators"][m]["beta_hat"]["rms"] / _DEG
            err = arr[f"{m}.beta_hat"] - arr["plant.beta"]
            ok = (arr[f"{m}.valid"] > 0.5) & (last >= 0)
            row["inter_sample"][m] = [float(np.sqrt(np.mean(err[ok & (bins == b)] ** 2))) for b in range(n_bins)]
        out[name] = row
    return out


def format_nguyen2012_accuracy(table: dict) -> str:
    """Markdown: RMSD per filter (paper in parentheses), then the error by time since the last fix."""
    lines = ["| scenario | " + " | ".join(m.upper() for m in NGUYEN_MODES) + " |",
             "|---|" + "---:|" * len(NGUYEN_MODES)]
    for name, row in table.items():
        lines.append(f"| {name} | " + " | ".join(f"{row['rmsd'][m] * 100:.3f}e-2 ({row['paper'][m] * 100:.2f}e-2)"
                                                  for m in NGUYEN_MODES) + " |")
    for name, row in table.items():
        b = row["bin_s"] * 1e3
        n = len(row["inter_sample"][NGUYEN_MODES[0]])
        lines += ["", f"{name}: RMS sideslip error [1e-3 rad] by time since the last GPS fix",
                  "| filter | " + " | ".join(f"{k * b:g}-{(k + 1) * b:g} ms" for k in range(n)) + " |",
                  "|---|" + "---:|" * n]
        for m in NGUYEN_MODES:
            lines.append(f"| {m.upper()} | " + " | ".join(f"{v * 1e3:.2f}" for v in row["inter_sample"][m]) + " |")
    return "\n".join(lines)


# ------------------------------------------------------------------------------ Pi 2011
PI2011_TABLE4 = {"pi2011_high": {"method": (5.1, 0.388), "model": (35.5, 6.4), "kinematic": (16.3, 7.0)},
                 "pi2011_medium": {"method": (8.0, 0.307), "model": (41.7, 7.8), "kinematic": (9.9, 4.7)},
                 "pi2011_low": {"method": (12.2, 1.5), "model": (135.2, 28.0), "kinematic": (164.9, 102.4)}}
"""Pi 2011 Table 4: road -> estimator -> (max, mean) normalised error of eq 48 [%]."""

PI_COLUMNS = (("method", "Pi2011FuzzyEKF"), ("model", "LinearBicycleObserver"), ("kinematic", "OpenLoopKinematic"))


def pi2011_accuracy(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None) -> dict:
    """Pi 2011 Table 4: max and mean normalised sideslip error (eq 48) of the method and the two baselines.

    Returns
    -------
    dict
        ``{road: {column: {"max": %, "mean": %}, "paper": {column: (max, mean)}}}``.
    """
    names = list(PI2011_TABLE4)
    ests = tuple(fmu for _, fmu in PI_COLUMNS)
    out = {}
    for name, (metrics, _) in zip(names, run_jobs([(n, ests, None, params, ()) for n in names], fmu_dir, workers)):
        row = {}
        for label, fmu in PI_COLUMNS:
            b = metrics["estimators"][fmu]["beta_hat"]
            row[label] = {"max": b["norm_max_pct"], "mean": b["norm_mean_pct"]}
        row["paper"] = PI2011_TABLE4[name]
        out[name] = row
    return out


def format_pi2011_accuracy(table: dict) -> str:
    """Markdown: max / mean normalised error [%] per road, the paper's in parentheses."""
    lines = ["| road | " + " | ".join(f"{label} ({fmu})" for label, fmu in PI_COLUMNS) + " |",
             "|---|" + "---:|" * len(PI_COLUMNS)]
    for name, row in table.items():
        cells = [f"{row[lb]['max']:.1f} / {row[lb]['mean']:.2f} ({row['paper'][lb][0]:g} / {row['paper'][lb][1]:g})"
                 for lb, _ in PI_COLUMNS]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# ------------------------------------------------------------------------------ Yoon 2014
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
    results = iter(run_jobs(jobs, fmu_dir, workers))
    out = {}
    for level in disturbances:
        runs, pooled = {}, {v: [] for v in YOON_VARIANTS}
        for sc in scenarios:
            metrics, arr = next(results)
            runs[sc] = {v: metrics["estimators"][v]["beta_hat"]["rms"] for v in YOON_VARIANTS}
            moving = np.hypot(arr["plant.vx"], arr["plant.vy"]) > 2.0
            for v in YOON_VARIANTS:
                ok = moving & (arr[f"{v}.valid"] > 0.5)
                pooled[v].append(wrap(arr[f"{v}.beta_hat"][ok] - arr["plant.beta"][ok]) * _DEG)
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
