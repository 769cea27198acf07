"""Accuracy metrics of estimators against plant truth, and scenario summaries.

* RMS and maximum error of every estimate that has a truth counterpart: ``beta_hat``
  (degrees, as in Table 3 of Park 2018), ``vx_hat``/``vy_hat`` (m/s), ``yaw_rate_hat``
  (deg/s), plus ``delta_hat`` (deg) and ``yaw_hat`` (deg) where an estimator has them.
* The normalised error of Pi 2011 eq. 48, ``100 |z - z_true| / max |z_true|`` [%],
  reported as its maximum and mean.
* Sub-estimates an estimator exposes as ``beta_hat_<name>`` (Park 2018's bicycle,
  kinematic and open-loop sub-filters) are scored like ``beta_hat``.
* Sideslip is undefined at standstill, so samples with a plant speed below
  ``min_speed`` (default 2 m/s) are excluded, and so are the samples in which the estimator
  says it is not ``valid`` (before its first sample, below its own minimum speed); the share
  of the run above ``min_speed`` (``coverage``) and the share of that in which the estimator
  was valid (``valid``) are reported with the errors.
Angle errors are wrapped to (-pi, pi].

:func:`trajectory_difference` compares two runs of the same loop (e.g. two masters).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["wrap", "estimate_metrics", "scenario_summary", "format_table", "trajectory_difference",
           "EVAL_MIN_SPEED"]

EVAL_MIN_SPEED = 2.0
"""Speed [m/s] below which sideslip errors are not evaluated."""

_DEG = 180.0 / math.pi

# estimate -> (truth field, scale to report units, unit)
_PAIRS = {
    "beta_hat": ("beta", _DEG, "deg"),
    "vx_hat": ("vx", 1.0, "m/s"),
    "vy_hat": ("vy", 1.0, "m/s"),
    "yaw_rate_hat": ("yaw_rate", _DEG, "deg/s"),
    "yaw_hat": ("yaw", _DEG, "deg"),
    "roll_hat": ("roll", _DEG, "deg"),
}
_ANGLES = {"beta_hat", "yaw_hat", "roll_hat"}


def wrap(angle):
    """Wrap angles to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2.0 * np.pi)


def _mask(results, plant: str, t_start: float, min_speed: float) -> np.ndarray:
    speed = np.hypot(results[f"{plant}.vx"], results[f"{plant}.vy"])
    return (speed > min_speed) & (results["time"] >= t_start)


def estimate_metrics(results, estimator: str, plant: str = "plant", driver: str = "driver",
                     t_start: float = 0.0, min_speed: float = EVAL_MIN_SPEED) -> dict:
    """Errors of one estimator instance against the plant truth.

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
        ``{"coverage": ..., "valid": ..., "<estimate>": {"rms", "max", "unit",
        "norm_max_pct", "norm_mean_pct"}}``.
    """
    mask = _mask(results, plant, t_start, min_speed)
    names = set(results.dtype.names if isinstance(results, np.ndarray) else results.keys())
    out = {"coverage": float(mask.mean())}
    valid = f"{estimator}.valid"
    if valid in names:
        is_valid = np.asarray(results[valid]) > 0.5
        out["valid"] = float(is_valid[mask].mean()) if mask.any() else 0.0
        mask = mask & is_valid
    out["samples"] = int(mask.sum())
    pairs = dict(_PAIRS)
    pairs["delta_hat"] = (None, _DEG, "deg")
    prefix = f"{estimator}.beta_hat_"
    for field in sorted(names):
        if field.startswith(prefix) and field != f"{estimator}.beta_hat_std":
            pairs[field[len(estimator) + 1:]] = _PAIRS["beta_hat"]
    for est, (truth, scale, unit) in pairs.items():
        field = f"{estimator}.{est}"
        if field not in names:
            continue
        ref = results[f"{driver}.delta_f"] if est == "delta_hat" else results[f"{plant}.{truth}"]
        if not mask.any():
            continue
        z_true = np.asarray(ref, dtype=float)[mask]
        err = np.asarray(results[field], dtype=float)[mask] - z_true
        if est in _ANGLES or est.startswith("beta_hat"):
            err = wrap(err)
        peak = float(np.max(np.abs(z_true)))
        norm = 100.0 * np.abs(err) / peak if peak > 0 else np.full_like(err, np.nan)
        out[est] = {"rms": float(np.sqrt(np.mean(err ** 2)) * scale), "max": float(np.max(np.abs(err)) * scale),
                    "unit": unit, "norm_max_pct": float(np.max(norm)), "norm_mean_pct": float(np.mean(norm))}
    return out


def scenario_summary(results, plant: str = "plant", min_speed: float = EVAL_MIN_SPEED) -> dict:
    """Peak values of the plant truth (sideslip only above ``min_speed``)."""
    mask = _mask(results, plant, 0.0, min_speed)
    beta = np.asarray(results[f"{plant}.beta"])[mask]
    return {"max_abs_beta_deg": float(np.max(np.abs(beta)) * _DEG) if beta.size else 0.0,
            "max_abs_ay": float(np.max(np.abs(results[f"{plant}.ay"]))),
            "max_abs_yaw_rate_deg_s": float(np.max(np.abs(results[f"{plant}.yaw_rate"])) * _DEG),
            "final_speed": float(np.hypot(results[f"{plant}.vx"][-1], results[f"{plant}.vy"][-1])),
            "duration": float(results["time"][-1])}


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
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


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
