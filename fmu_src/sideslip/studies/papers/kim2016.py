"""Kim, Yoon, Kim (2016), "Estimation of the steering angle based on extended Kalman filter": Table 3
and steering-sensor fault detection, with the FMUs in closed loop.

* :func:`kim2016_accuracy` - Table 3: RMSE of sideslip [rad], yaw rate [rad/s] and steering
  angle [rad] on the two tracks, with the fault flag (false alarms).
* :func:`kim2016_fault_detection` - detection delay of stuck and offset steering-sensor faults.
"""
from __future__ import annotations


import numpy as np

from ...fmi.build import DEFAULT_OUT
from ...units import DEG
from ..runs import run_jobs


KIM2016_TABLE3 = {40: {"beta": 0.054, "yaw_rate": 0.046, "delta": 0.017},
                  80: {"beta": 0.063, "yaw_rate": 0.046, "delta": 0.016}}
"""Kim 2016 Table 3: speed limit [km/h] -> RMSE of beta [rad], yaw rate [rad/s], steering angle [rad]."""


_KIM_FIELDS = ("Kim2016SteeringEKF.delta_residual", "Kim2016SteeringEKF.delta_fault")


def _kim_row(metrics: dict, arrays: dict) -> dict:
    m = metrics["estimators"]["Kim2016SteeringEKF"]
    return {"beta": m["beta_hat"]["rms"] / DEG, "yaw_rate": m["yaw_rate_hat"]["rms"] / DEG,
            "delta": m["delta_hat"]["rms"] / DEG,
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
    for n, (metrics, arrays) in zip(names, run_jobs(jobs, fmu_dir, workers, as_published=True)):
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
    from ...estimators.kim2016 import Kim2016Config

    threshold = Kim2016Config().fault_threshold
    fields = (*_KIM_FIELDS, "sensors.delta_m", "driver.delta_f")
    jobs = [(sc, ("Kim2016SteeringEKF",), {"sensor_steer_fault": mode, "sensor_steer_fault_time": tf,
                                            "sensor_steer_fault_offset": off}, None, fields, tf + horizon)
            for sc, mode, off, tf in faults]
    out = []
    for (sc, mode, off, tf), (_, arr) in zip(faults, run_jobs(jobs, fmu_dir, workers, as_published=True)):
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


ACCEPTS_PARAMS = False


def report(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None, extra=()) -> tuple[dict, str]:
    """Table 3 (plus fault-free ``extra`` scenarios) and the fault detection: ``(figures, Markdown)``."""
    acc = kim2016_accuracy(fmu_dir, workers, extra_scenarios=extra or ())
    faults = kim2016_fault_detection(fmu_dir, workers)
    text = ["Kim 2016 Table 3: RMSE", "", format_kim2016_accuracy(acc), "",
            "Steering-sensor faults", "", format_kim2016_fault_detection(faults)]
    return {"accuracy": acc, "fault_detection": faults}, "\n".join(text)
