"""Accuracy metrics of estimators against a truth: one scorer and one rule for the samples it scores.

* :func:`scored_samples` - sideslip is undefined at standstill, so only samples where the car moves
  faster than :data:`MOVING_SPEED` count; with ``valid_only`` only those where the estimator also says
  ``valid``.  The paper tables score the valid samples (a method is judged where it claims to work);
  the benchmark scores every moving sample (an estimator cannot improve its score by declaring the hard
  parts not valid) and reports the valid ones beside.
* :func:`score` - RMS and maximum error over the scored samples, predict-zero's RMS on the same samples
  and the normalised error of Pi 2011 eq. 48, ``100 |z - z_true| / max |z_true|`` [%].  Angle errors are
  wrapped to (-pi, pi] (:func:`~sideslip.units.wrap_angle`).
* :func:`estimate_metrics` - every estimate of an estimator instance that has a truth counterpart:
  ``beta_hat`` (degrees, as in Table 3 of Park 2018), ``vx_hat``/``vy_hat`` (m/s), ``yaw_rate_hat``
  (deg/s), ``delta_hat`` (deg), ``yaw_hat`` and ``roll_hat`` (deg), and the sub-estimates an estimator
  exposes as ``beta_hat_<name>`` (Park 2018's bicycle, kinematic and open-loop sub-filters), on the
  valid samples, with the share of the run above the speed (``coverage``) and the share of that in
  which the estimator was valid (``valid``).

:func:`trajectory_difference` compares two runs of the same loop (e.g. two masters).
"""
from __future__ import annotations

import numpy as np

from ..units import DEG, wrap_angle

__all__ = ["MOVING_SPEED", "scored_samples", "valid_share", "score", "estimate_metrics", "scenario_summary",
           "format_table", "rms", "command_metrics", "format_command_table", "trajectory_difference"]

MOVING_SPEED = 2.0
"""Speed [m/s] below which sideslip errors are not scored (undefined at standstill)."""

# estimate -> (truth field, scale to report units, unit)
_PAIRS = {
    "beta_hat": ("beta", DEG, "deg"),
    "vx_hat": ("vx", 1.0, "m/s"),
    "vy_hat": ("vy", 1.0, "m/s"),
    "yaw_rate_hat": ("yaw_rate", DEG, "deg/s"),
    "yaw_hat": ("yaw", DEG, "deg"),
    "roll_hat": ("roll", DEG, "deg"),
}
_ANGLES = {"beta_hat", "yaw_hat", "roll_hat"}


def scored_samples(speed, valid=None, valid_only: bool = False, min_speed: float = MOVING_SPEED) -> np.ndarray:
    """The samples scored: the car faster than ``min_speed`` [m/s] and, with ``valid_only``, ``valid`` (> 0.5)."""
    mask = np.asarray(speed) > min_speed
    if valid_only and valid is not None:
        mask = mask & (np.asarray(valid) > 0.5)
    return mask


def valid_share(valid, moving: np.ndarray) -> float:
    """The share of the moving samples in which the estimator says ``valid``."""
    ok = moving & (np.asarray(valid) > 0.5)
    return float(ok.sum() / max(moving.sum(), 1))


def score(error, truth, samples: np.ndarray, scale: float = 1.0) -> dict:
    """RMS and maximum of ``error`` over ``samples``, predict-zero's RMS there (of ``truth``) and Pi 2011 eq. 48.

    Parameters
    ----------
    error, truth : array_like
        The estimate's error (wrapped, for an angle) and the truth, in one unit, every sample.
    samples : ndarray of bool
        The samples scored (:func:`scored_samples`).
    scale : float
        Factor from that unit to the report's (the RMS, maximum and zero RMS are scaled).

    Returns
    -------
    dict
        ``samples``, ``rms``, ``max``, ``zero_rms``, ``norm_max_pct``, ``norm_mean_pct`` (NaN without samples;
        the normalised errors NaN for a truth that is zero throughout).
    """
    e = np.asarray(error, dtype=float)[samples]
    z = np.asarray(truth, dtype=float)[samples]
    nan = float("nan")
    if not e.size:
        return {"samples": 0, **dict.fromkeys(("rms", "max", "zero_rms", "norm_max_pct", "norm_mean_pct"), nan)}
    peak = float(np.max(np.abs(z)))
    norm = 100.0 * np.abs(e) / peak if peak > 0 else np.full_like(e, np.nan)
    return {"samples": int(e.size), "rms": float(np.sqrt(np.mean(e ** 2)) * scale),
            "max": float(np.max(np.abs(e)) * scale), "zero_rms": float(np.sqrt(np.mean(z ** 2)) * scale),
            "norm_max_pct": float(np.max(norm)), "norm_mean_pct": float(np.mean(norm))}


def _speed(results, plant: str) -> np.ndarray:
    return np.hypot(results[f"{plant}.vx"], results[f"{plant}.vy"])


def estimate_metrics(results, estimator: str, plant: str = "plant", driver: str = "driver",
                     t_start: float = 0.0, min_speed: float = MOVING_SPEED) -> dict:
    """Errors of one estimator instance against the plant truth, on its valid samples (module docstring).

    Parameters
    ----------
    results : Results or mapping of arrays
        Recorded run (fields ``time``, ``<instance>.<variable>``).
    estimator, plant, driver : str
        Instance names.
    t_start : float
        Evaluate from this time on [s].
    min_speed : float
        Evaluate only while the plant speed exceeds this [m/s].

    Returns
    -------
    dict
        ``{"coverage": ..., "valid": ..., "samples": ..., "<estimate>": {"rms", "max", "unit",
        "norm_max_pct", "norm_mean_pct"}}``.
    """
    names = set(results.dtype.names if isinstance(results, np.ndarray) else results.keys())
    moving = scored_samples(_speed(results, plant), min_speed=min_speed) & (np.asarray(results["time"]) >= t_start)
    out = {"coverage": float(moving.mean())}
    mask = moving
    valid = f"{estimator}.valid"
    if valid in names:
        out["valid"] = valid_share(results[valid], moving) if moving.any() else 0.0
        mask = moving & (np.asarray(results[valid]) > 0.5)
    out["samples"] = int(mask.sum())
    pairs = dict(_PAIRS)
    pairs["delta_hat"] = (None, DEG, "deg")
    prefix = f"{estimator}.beta_hat_"
    for field in sorted(names):
        if field.startswith(prefix) and field != f"{estimator}.beta_hat_std":
            pairs[field[len(estimator) + 1:]] = _PAIRS["beta_hat"]
    for est, (truth, scale, unit) in pairs.items():
        field = f"{estimator}.{est}"
        if field not in names or not mask.any():
            continue
        ref = np.asarray(results[f"{driver}.delta_f"] if est == "delta_hat" else results[f"{plant}.{truth}"],
                         dtype=float)
        err = np.asarray(results[field], dtype=float) - ref
        if est in _ANGLES or est.startswith("beta_hat"):
            err = wrap_angle(err)
        s = score(err, ref, mask, scale)
        out[est] = {"rms": s["rms"], "max": s["max"], "unit": unit, "norm_max_pct": s["norm_max_pct"],
                    "norm_mean_pct": s["norm_mean_pct"]}
    return out


def scenario_summary(results, plant: str = "plant", min_speed: float = MOVING_SPEED) -> dict:
    """Peak values of the plant truth (sideslip only above ``min_speed``)."""
    mask = scored_samples(_speed(results, plant), min_speed=min_speed)
    beta = np.asarray(results[f"{plant}.beta"])[mask]
    return {"max_abs_beta_deg": float(np.max(np.abs(beta)) * DEG) if beta.size else 0.0,
            "max_abs_ay": float(np.max(np.abs(results[f"{plant}.ay"]))),
            "max_abs_yaw_rate_deg_s": float(np.max(np.abs(results[f"{plant}.yaw_rate"])) * DEG),
            "final_speed": float(np.hypot(results[f"{plant}.vx"][-1], results[f"{plant}.vy"][-1])),
            "duration": float(results["time"][-1])}


def rms(x) -> float:
    """Root mean square of ``x`` (0 for no samples)."""
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x ** 2))) if x.size else 0.0


def command_metrics(results, limit: float, controller: str = "controller", plant: str = "plant",
                    min_speed: float = MOVING_SPEED) -> dict:
    """How a yaw-moment controller did in a run, while the car moves faster than ``min_speed``.

    Parameters
    ----------
    results : Results or mapping of arrays
        With ``plant.{vx,vy,yaw_rate,Mz_act}`` and ``controller.{Mz_cmd,yaw_rate_ref}``.
    limit : float
        The yaw moment the motors give [N m] (:func:`sideslip.control.base.yaw_moment_limit`).

    Returns
    -------
    dict
        ``rms_yaw_rate_error_deg_s`` and ``max_yaw_rate_error_deg_s`` (the plant's yaw rate against the
        controller's own reference), ``rms_Mz_cmd`` and ``max_abs_Mz_cmd`` [N m], ``effort_Nms``
        (``int |Mz_act| dt``), ``saturated_pct`` (share of samples at 99.9 % of ``limit``), ``limit``.
    """
    mask = scored_samples(_speed(results, plant), min_speed=min_speed)
    t = np.asarray(results["time"])
    err = (np.asarray(results[f"{plant}.yaw_rate"]) - np.asarray(results[f"{controller}.yaw_rate_ref"]))[mask] * DEG
    cmd = np.asarray(results[f"{controller}.Mz_cmd"])[mask]
    act = np.abs(np.asarray(results[f"{plant}.Mz_act"]))
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.0
    return {"rms_yaw_rate_error_deg_s": rms(err), "max_yaw_rate_error_deg_s": float(np.max(np.abs(err), initial=0.0)),
            "rms_Mz_cmd": rms(cmd), "max_abs_Mz_cmd": float(np.max(np.abs(cmd), initial=0.0)),
            "effort_Nms": float(act.sum() * dt),
            "saturated_pct": 100.0 * float(np.mean(np.abs(cmd) >= 0.999 * limit)) if cmd.size else 0.0,
            "limit": float(limit)}


def format_command_table(name: str, m: dict) -> str:
    """One controller's :func:`command_metrics` as a text table."""
    rows = [("controller", "yaw-rate error RMS [deg/s]", "max [deg/s]", "Mz_cmd RMS [N m]", "max [N m]",
             "effort [N m s]", "saturated [%]"),
            (name, f"{m['rms_yaw_rate_error_deg_s']:.3f}", f"{m['max_yaw_rate_error_deg_s']:.2f}",
             f"{m['rms_Mz_cmd']:.0f}", f"{m['max_abs_Mz_cmd']:.0f}", f"{m['effort_Nms']:.0f}",
             f"{m['saturated_pct']:.1f}")]
    return _columns(rows)


def _columns(rows) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def format_table(per_estimator: dict) -> str:
    """Text table of sideslip (and other) errors per estimator."""
    rows = [("estimator", "beta RMS [deg]", "beta max [deg]", "eq48 max [%]", "eq48 mean [%]", "vy RMS [m/s]",
             "r RMS [deg/s]", "valid [%]", "coverage [%]")]
    for name, m in per_estimator.items():
        b = m.get("beta_hat", {})
        rows.append((name, f"{b.get('rms', float('nan')):.3f}", f"{b.get('max', float('nan')):.3f}",
                     f"{b.get('norm_max_pct', float('nan')):.2f}", f"{b.get('norm_mean_pct', float('nan')):.3f}",
                     f"{m.get('vy_hat', {}).get('rms', float('nan')):.3f}",
                     f"{m.get('yaw_rate_hat', {}).get('rms', float('nan')):.3f}",
                     f"{100 * m.get('valid', float('nan')):.1f}", f"{100 * m['coverage']:.1f}"))
    return _columns(rows)


def trajectory_difference(reference, other) -> dict:
    """Largest differences between two recordings of the same loop, per field and overall.

    Rows are matched by time (``other`` may start later, e.g. libcosim's rows start at one
    step); every field of ``other`` except ``time`` is compared.

    Returns
    -------
    dict
        ``max_abs`` and ``max_scaled`` (difference over the field's scale ``max(1, max|x|)``)
        overall, the fields where they occur (``max_abs_field``, ``max_scaled_field``), and
        ``per_field``: ``{field: (max_abs, max_scaled)}``.

    Raises
    ------
    ValueError
        When the time grids do not match.
    """
    t_ref, t_other = np.asarray(reference["time"]), np.asarray(other["time"])
    start = int(np.searchsorted(t_ref, t_other[0] - 1e-12))
    rows = slice(start, start + len(t_other))
    if len(t_ref[rows]) != len(t_other) or np.max(np.abs(t_ref[rows] - t_other)) > 1e-9:
        raise ValueError("the two recordings do not share a time grid")
    per_field = {}
    for name in other.dtype.names if hasattr(other, "dtype") else other.names:
        if name == "time":
            continue
        a = np.asarray(reference[name][rows], dtype=float)
        b = np.asarray(other[name], dtype=float)
        d = float(np.max(np.abs(a - b))) if len(a) else 0.0
        per_field[name] = (d, d / max(1.0, float(np.max(np.abs(a))) if len(a) else 1.0))
    abs_field = max(per_field, key=lambda k: per_field[k][0])
    scaled_field = max(per_field, key=lambda k: per_field[k][1])
    return {"max_abs": per_field[abs_field][0], "max_abs_field": abs_field,
            "max_scaled": per_field[scaled_field][1], "max_scaled_field": scaled_field, "per_field": per_field}
