"""Vehicle identification from a calibration drive: what an estimator needs that a data sheet does not give.

The drive (``docs/your-car.md``), on a flat, dry pad with the car's production sensors logged:

1. a slow circle (radius about 20 m, 5-7 m/s, lateral acceleration below 2 m/s2) for 30 s to the left and
   30 s to the right, with some straight driving before each;
2. on a straight, a handwheel sine sweep at 15-25 m/s, the frequency rising from 0.2 to 2 Hz over 40 s,
   its amplitude for about 3 m/s2 at the lowest frequency (the tires stay linear);
3. optionally the sweep again on a low-friction surface (about 1 m/s2), its log or time window given as
   low-friction.

What is fitted, each value with a standard deviation (least squares, inflated by the residuals'
correlation time, :func:`_inflation`):

* **yaw-rate offset and scale** - ``r_m = (1 + k) r_w + b_r`` over the moving samples, ``r_w = R_w
  (omega_rr - omega_rl) / t_r`` the rear axle's wheel-speed yaw rate; a rolling-radius error scales
  ``r_w`` and shows in ``k`` only, so ``b_r`` is its offset;
* **the single-track model's axle cornering stiffnesses, yaw inertia, steering gain and offset and the
  lateral accelerometer's offset** - output error: the linear single-track model (the equations of
  :class:`~sideslip.estimators.baselines.LinearBicycleObserver`) driven by ``delta = g (delta_m -
  b_delta)`` and the wheel-speed ``v_x``, its yaw rate and lateral acceleration ``a_y + b_ay`` against
  the measured ones (the yaw rate less ``b_r``; the lateral acceleration as a body-fixed accelerometer reads it,
  ``(1 + k_phi) a_y + b_ay``, where ``k_phi = g d(phi)/d(a_y)`` is the gravity its roll adds), each channel weighted by the inverse of its residual
  RMS (iterated: the maximum-likelihood weights), by :func:`scipy.optimize.least_squares`;
  the steady circles give the gain, the offsets and the understeer, the sweep the stiffnesses' split
  and the inertia;
* **the roll stiffness** - from ``k_phi``: the roll model's steady gradient ``d(phi)/d(a_y) = m_s h_s / (K_phi -
  m_s g h_s)`` (:mod:`~sideslip.estimators.roll`) gives ``K_phi = m_s h_s g (1 + 1 / k_phi)``, split front to rear
  as the base's, the dampers scaled by the square root of the net stiffness ``K_phi - m_s g h_s`` (the base's damping
  ratio; the drive shows the roll's gain, not its damping).  The estimators remove the
  roll's gravity from the lateral accelerometer with it, and a roll model off by a factor puts that factor's share
  of ``g sin(phi)`` into the tire forces (0.9 m/s2 at 0.8 g for a base car 2.6 times stiffer in roll than the car);
* **the longitudinal accelerometer's offset** - the mean of ``ax_m - dv_x/dt`` on straight driving;
* **low-friction stiffnesses** (``C_f_nominal_lo``, ``C_r_nominal_lo``) on the ``low_friction`` windows
  with everything else held; without them they keep the base vehicle's ratio to the dry values.

A parameter the drive does not excite (by its structure, :func:`_excitation`, or its standard deviation above
:data:`LIMITS`) is refused with an :class:`IdentificationError` naming it and the part of the drive that excites it,
unless the caller holds it at the base vehicle's value (``fix``).  The sensor offsets belong to that
drive's sensors, not to the car: they are reported, not written into the vehicle.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from ..constants import GRAVITY
from ..recording import LogError, Recording
from ..units import DEG
from ..vehicles import VehicleParams

__all__ = ["Estimate", "Identification", "IdentificationError", "LIMITS", "FITTED", "identify", "vehicle_toml",
           "single_track"]

STEP = 0.01
"""[s] the grid the drive is fitted on."""
MOVING = 3.0
"""[m/s] samples slower than this are not fitted (the single-track model needs speed)."""
SETTLE = 2.0
"""[s] residuals of a log's first seconds are not fitted (the model starts from a steady state)."""
ROLL = ("K_phi_f", "K_phi_r", "C_phi_f", "C_phi_r")
"""The roll model's parameters written from the fitted roll gain."""

_MODEL = ("C_f_nominal", "C_r_nominal", "I_zz", "steer_gain", "steer_bias", "ay_bias", "ay_roll_gain")
FITTED = ("yaw_rate_bias",) + _MODEL + ("ax_bias",)
"""Every identified quantity; the sensors' are ``*_bias`` and ``steer_gain``."""
_UNITS = {"C_f_nominal": "N/rad", "C_r_nominal": "N/rad", "I_zz": "kg.m2", "steer_gain": "1", "steer_bias": "rad",
          "ay_bias": "m/s2", "ay_roll_gain": "1", "yaw_rate_bias": "rad/s", "ax_bias": "m/s2", "C_f_nominal_lo": "N/rad",
          "C_r_nominal_lo": "N/rad"}
LIMITS = {"C_f_nominal": ("relative", 0.10), "C_r_nominal": ("relative", 0.10), "I_zz": ("relative", 0.15),
          "steer_gain": ("relative", 0.05), "steer_bias": ("absolute", math.radians(0.1)),
          "ay_bias": ("absolute", 0.05), "ay_roll_gain": ("absolute", 0.02), "yaw_rate_bias": ("absolute", math.radians(0.05)),
          "ax_bias": ("absolute", 0.05), "C_f_nominal_lo": ("relative", 0.15), "C_r_nominal_lo": ("relative", 0.15)}
"""Largest standard deviation of an identified value (relative to it, or absolute in SI)."""
_EXCITED_BY = {
    "C_f_nominal": "steering at speed (the sweep) and steady turning", "C_r_nominal": "the sweep and steady turning",
    "I_zz": "steering above 0.5 Hz at 15 m/s or more (the sweep's upper half)",
    "steer_gain": "a slow circle, where the steering angle is the geometry's L/R",
    "steer_bias": "turning both ways (the circle to the left and to the right)",
    "ay_bias": "turning both ways (the circle to the left and to the right)",
    "ay_roll_gain": "turning (the circle and the sweep)",
    "yaw_rate_bias": "straight driving or turning both ways", "ax_bias": "straight driving (at least 5 s)",
    "C_f_nominal_lo": "the sweep on the low-friction surface", "C_r_nominal_lo": "the sweep on the low-friction surface",
}


class IdentificationError(ValueError):
    """A drive that cannot give a parameter: which one, why, and what would."""

    def __init__(self, name: str, reason: str):
        self.name, self.reason = name, reason
        super().__init__(f"cannot identify {name}: {reason}; it needs {_EXCITED_BY[name]} "
                         f"(or hold it at the base vehicle's value with --fix {name})")

    def __reduce__(self):
        return type(self), (self.name, self.reason)


@dataclass(frozen=True)
class Estimate:
    """One identified value with its standard deviation (SI units, :data:`_UNITS`); ``fixed`` when held."""

    value: float
    std: float
    unit: str
    fixed: bool = False


@dataclass
class Identification:
    """The result of :func:`identify`: the fitted vehicle, every estimate, the fit's residuals."""

    vehicle: VehicleParams
    estimates: dict
    residual: dict                   #: RMS of the fit's residuals: ``yaw_rate`` [rad/s], ``ay`` [m/s2]
    samples: int
    beta_rms: float = float("nan")   #: [rad] the fitted model's sideslip against a reference, where the log has one
    notes: list = field(default_factory=list)

    def table(self) -> str:
        """The estimates as text, display units."""
        rows = [f"{'parameter':<16} {'value':>12} {'std':>10}  unit"]
        for name, e in self.estimates.items():
            scale, unit = _display(name)
            std = "held" if e.fixed else f"{e.std * scale:10.4g}"
            rows.append(f"{name:<16} {e.value * scale:12.5g} {std:>10}  {unit}")
        rows.append(f"residual RMS: yaw rate {self.residual['yaw_rate'] * DEG:.3g} deg/s, lateral acceleration "
                    f"{self.residual['ay']:.3g} m/s2 over {self.samples} samples")
        if math.isfinite(self.beta_rms):
            rows.append(f"the fitted single-track model's sideslip against the log's reference: RMS "
                        f"{self.beta_rms * DEG:.3g} deg")
        return "\n".join(rows + self.notes)


def _display(name: str) -> tuple[float, str]:
    unit = _UNITS[name]
    if unit == "rad":
        return DEG, "deg"
    if unit == "rad/s":
        return DEG, "deg/s"
    return 1.0, unit


# ---------------------------------------------------------------------------------------- the model
def single_track(theta, delta_m, vx, vehicle: VehicleParams, step: float = STEP):
    """Yaw rate [rad/s], lateral acceleration [m/s2] and sideslip [rad] of the linear single-track model.

    Parameters
    ----------
    theta : sequence
        ``C_f, C_r`` [N/rad] (axle), ``I_zz`` [kg m2], steering gain ``g`` [-] and offset ``b_delta`` [rad]:
        the road-wheel angle is ``g (delta_m - b_delta)``.
    delta_m, vx : ndarray
        Measured road-wheel angle [rad] and speed [m/s] on a uniform grid of ``step`` [s].

    Notes
    -----
    States ``v_y, r`` with ``m (v_y' + v_x r) = F_yf + F_yr``, ``I_zz r' = l_f F_yf - l_r F_yr``,
    ``F_yf = C_f (delta - (v_y + l_f r) / v_x)``, ``F_yr = -C_r (v_y - l_r r) / v_x``; discretised by the
    trapezoidal rule (A-stable at any speed) with the speed of each step, from the steady state of the
    first sample.
    """
    c_f, c_r, izz, gain, bias = theta
    m, a, b = vehicle.m, vehicle.l_f, vehicle.l_r
    u = gain * (np.asarray(delta_m) - bias)
    v = np.maximum(np.asarray(vx), 1.0)
    a11, a12 = -(c_f + c_r) / (m * v), (b * c_r - a * c_f) / (m * v) - v
    a21, a22 = (b * c_r - a * c_f) / (izz * v), -(a * a * c_f + b * b * c_r) / (izz * v)
    b1, b2 = c_f / m, a * c_f / izz
    h = 0.5 * step
    # (I - h A)^-1 by its adjugate, then M = (I - h A)^-1 (I + h A), N = (I - h A)^-1 2h B
    p11, p12, p21, p22 = 1 - h * a11, -h * a12, -h * a21, 1 - h * a22
    det = p11 * p22 - p12 * p21
    i11, i12, i21, i22 = p22 / det, -p12 / det, -p21 / det, p11 / det
    q11, q12, q21, q22 = 1 + h * a11, h * a12, h * a21, 1 + h * a22
    m11, m12 = i11 * q11 + i12 * q21, i11 * q12 + i12 * q22
    m21, m22 = i21 * q11 + i22 * q21, i21 * q12 + i22 * q22
    n1, n2 = (i11 * b1 + i12 * b2) * h, (i21 * b1 + i22 * b2) * h
    uu = u[:-1] + u[1:]
    det0 = a11[0] * a22[0] - a12[0] * a21[0]
    vy, r = -(a22[0] * b1 - a12[0] * b2) * u[0] / det0, -(-a21[0] * b1 + a11[0] * b2) * u[0] / det0
    n = len(u)
    vys, rs = np.empty(n), np.empty(n)
    vys[0], rs[0] = vy, r
    rows = zip(m11.tolist(), m12.tolist(), m21.tolist(), m22.tolist(), n1.tolist(), n2.tolist(), uu.tolist())
    for k, (c11, c12, c21, c22, d1, d2, w) in enumerate(rows, 1):
        vy, r = c11 * vy + c12 * r + d1 * w, c21 * vy + c22 * r + d2 * w
        vys[k], rs[k] = vy, r
    ay = (c_f * (u - (vys + a * rs) / v) - c_r * (vys - b * rs) / v) / m
    return rs, ay, np.arctan2(vys, v)


# ---------------------------------------------------------------------------------------- the fit
@dataclass
class _Drive:
    """One log on the fitting grid: measured signals, the wheel-speed speed and yaw rate, fitted samples."""

    delta: np.ndarray
    vx: np.ndarray
    r_m: np.ndarray
    r_w: np.ndarray
    ay_m: np.ndarray
    ax_m: np.ndarray
    fitted: np.ndarray
    low: np.ndarray
    beta: np.ndarray | None


def _drive(rec: Recording, vehicle: VehicleParams, low_friction, low_log: bool = False) -> _Drive:
    need = ("delta_m", "yaw_rate_m", "ay_m", "ax_m", "omega_rl_m", "omega_rr_m")
    missing = [n for n in need if n not in rec.signals]
    if missing:
        raise LogError(f"{rec.source}: identification needs {', '.join(missing)} (map the columns in a map file)")
    g = rec.on_grid(STEP)
    s = {k: np.asarray(v, dtype=float) for k, v in g.signals.items()}
    vx = 0.5 * vehicle.R_w * (s["omega_rl_m"] + s["omega_rr_m"])
    r_w = vehicle.R_w * (s["omega_rr_m"] - s["omega_rl_m"]) / vehicle.t_r
    t = g.time - g.time[0]
    fitted = (vx > MOVING) & (t >= SETTLE)
    low = np.full(len(t), low_log)
    for t0, t1 in low_friction:
        low |= (g.time >= t0) & (g.time <= t1)
    beta = np.asarray(g.reference["beta"]) if "beta" in g.reference else None
    return _Drive(s["delta_m"], vx, s["yaw_rate_m"], r_w, s["ay_m"], s["ax_m"], fitted, low, beta)


def _inflation(residual: np.ndarray) -> float:
    """Variance inflation of correlated residuals: ``1 + 2 sum rho_k`` over lags until the autocorrelation
    first falls below 0.05 (the samples' effective number is the count over it)."""
    e = residual - residual.mean()
    var = float(e @ e)
    if var <= 0 or len(e) < 10:
        return 1.0
    total = 0.0
    for lag in range(1, min(len(e) // 4, 2000)):
        rho = float(e[:-lag] @ e[lag:]) / var
        if rho < 0.05:
            break
        total += rho
    return 1.0 + 2.0 * total


def _variances(jac: np.ndarray, residual: np.ndarray, dof: int) -> np.ndarray:
    """The parameters' variances, the diagonal of ``s^2 (J^T J)^-1`` inflated (:func:`_inflation`); a direction
    the data do not determine (a singular value below 1e-9 of the largest) makes the variance of every parameter
    in it infinite, not the zero a pseudo-inverse would give."""
    if not np.isfinite(jac).all() or not np.isfinite(residual).all():
        return np.full(jac.shape[1], np.inf)
    s2 = float(residual @ residual) / max(len(residual) - dof, 1)
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    weight = vt.T ** 2                                   # parameter i's share of direction k
    determined = sv > 1e-9 * sv[0]
    var = weight[:, determined] @ (1.0 / sv[determined] ** 2)
    var[(weight[:, ~determined] > 1e-12).any(axis=1)] = np.inf
    return var * s2 * _inflation(residual)


def _check(name: str, value: float, std: float) -> None:
    kind, limit = LIMITS[name]
    bound = limit * abs(value) if kind == "relative" else limit
    if not (math.isfinite(std) and std <= bound):
        scale, unit = _display(name)
        raise IdentificationError(name, f"its standard deviation {std * scale:.3g} {unit} exceeds "
                                        f"{bound * scale:.3g} {unit}")


TURNING = 0.05
"""[rad/s] a yaw rate that counts as turning, for the excitation checks."""
EXCITED_SHARE = 0.05
"""Share of the moving samples a turn direction needs, for the excitation checks."""


def _excitation(drives, fix) -> None:
    """Refuse what the drive's structure cannot give, whatever the statistics say: the steering offset and the
    lateral accelerometer's offset need turns both ways (one way, they trade against the understeer), the yaw
    inertia steering that changes at speed (5 s with the steering rate above 0.05 rad/s at 10 m/s or more)."""
    r = np.concatenate([d.r_w[d.fitted] for d in drives])
    left, right = float(np.mean(r > TURNING)), float(np.mean(r < -TURNING))
    for name in ("steer_bias", "ay_bias"):
        if name not in fix and min(left, right) < EXCITED_SHARE:
            raise IdentificationError(name, f"the drive turns left on {100 * left:.0f} % and right on "
                                            f"{100 * right:.0f} % of its moving samples (at least "
                                            f"{100 * EXCITED_SHARE:.0f} % each way)")
    if "I_zz" not in fix:
        rate = [np.abs(np.gradient(np.convolve(d.delta, np.ones(5) / 5, mode="same"), STEP)) for d in drives]
        seconds = sum(float(np.sum(d.fitted & (d.vx >= 10.0) & (q > 0.05))) * STEP for d, q in zip(drives, rate))
        if seconds < 5.0:
            raise IdentificationError("I_zz", f"the steering changes at 10 m/s or more for {seconds:.1f} s "
                                              "(at least 5 s)")


def _yaw_rate_offset(drives) -> tuple[float, float]:
    r_w = np.concatenate([d.r_w[d.fitted] for d in drives])
    r_m = np.concatenate([d.r_m[d.fitted] for d in drives])
    if len(r_w) < 100:
        raise IdentificationError("yaw_rate_bias", f"the log has {len(r_w)} samples faster than {MOVING:g} m/s")
    design = np.column_stack([r_w, np.ones_like(r_w)])
    coef, *_ = np.linalg.lstsq(design, r_m, rcond=None)
    var = _variances(design, r_m - design @ coef, 2)
    return float(coef[1]), float(math.sqrt(var[1]))


def _ax_offset(drives) -> tuple[float, float]:
    parts = []
    for d in drives:
        dv = np.gradient(np.convolve(d.vx, np.ones(25) / 25, mode="same"), STEP)
        straight = d.fitted & (np.abs(d.r_w) < 0.01)
        straight[:25], straight[-25:] = False, False
        parts.append((d.ax_m - dv)[straight])
    e = np.concatenate(parts)
    if len(e) < 5.0 / STEP:
        raise IdentificationError("ax_bias", f"the log has {len(e) * STEP:.1f} s of straight driving")
    return float(e.mean()), float(e.std() * math.sqrt(_inflation(e) / len(e)))


def _model_residuals(drives, vehicle, b_r, weights, which):
    """The residual function of the model fit over ``which`` samples (``fitted`` or ``low``)."""
    def residuals(theta):
        yaw, lateral = [], []
        for d in drives:
            keep = d.fitted & (d.low if which == "low" else ~d.low)
            if not keep.any():
                continue
            r, ay, _ = single_track(theta[:5], d.delta, d.vx, vehicle)
            yaw.append(((r - (d.r_m - b_r)) / weights[0])[keep])
            lateral.append((((1.0 + theta[6]) * ay + theta[5] - d.ay_m) / weights[1])[keep])
        return np.concatenate(yaw + lateral)         # the yaw-rate half, then the lateral-acceleration half
    return residuals


def _fit_model(drives, vehicle, b_r, start, fixed):
    """Least squares of the model's free parameters (the fixed ones held), re-weighted per channel."""
    free = [i for i, n in enumerate(_MODEL) if n not in fixed]
    theta = np.array(start, dtype=float)
    scale = np.abs(theta) + np.array([0, 0, 0, 0, 0.01, 0.1, 0.05])      # offsets have no natural scale of their own
    # a stiffness or an inertia stays within 0.05-20x the base's, the gain within 0.5-2, the offsets within a
    # sensor's range (an unstable model is no answer): in units of the scale
    upper = np.array([20.0, 20.0, 20.0, 2.0, 0.1, 5.0, 0.5]) / np.r_[1, 1, 1, 1, scale[4:]]
    lower = np.r_[0.05, 0.05, 0.05, 0.5, -upper[4:]]
    weights = (math.radians(1.0), 0.5)
    for _ in range(3):
        fun = _model_residuals(drives, vehicle, b_r, weights, "fitted")

        def sub(x):
            full = theta.copy()
            full[free] = x * scale[free]
            return fun(full)
        res = least_squares(sub, theta[free] / scale[free], bounds=(lower[free], upper[free]), x_scale="jac")
        theta[free] = res.x * scale[free]
        half = len(res.fun) // 2
        new = (weights[0] * float(np.sqrt(np.mean(res.fun[:half] ** 2))),
               weights[1] * float(np.sqrt(np.mean(res.fun[half:] ** 2))))
        done = np.allclose(new, weights, rtol=0.02)
        weights = new
        if done:
            break
    var = np.zeros(len(_MODEL))
    var[free] = _variances(res.jac / scale[free], res.fun, len(free))
    return theta, var, weights


def identify(recordings, base: VehicleParams, fix=(), low_friction=(), low_friction_logs=()) -> Identification:
    """Identify a vehicle from a calibration drive (module docstring).

    Parameters
    ----------
    recordings : Recording or sequence of Recording
        The drive, in one log or several (each log starts from its own steady state).
    base : VehicleParams
        The car as known: mass, geometry, rolling radius and track (used, not fitted), and the values a held
        parameter keeps.
    fix : sequence of str
        Names of :data:`FITTED` to hold at the base's value (the sensors' offsets at zero, the gain at 1).
    low_friction : sequence of (t0, t1)
        Time windows [s] of the logs driven on a low-friction surface.
    low_friction_logs : Recording or sequence of Recording
        Logs driven on a low-friction surface throughout.

    Raises
    ------
    IdentificationError
        A parameter the drive does not excite, naming it and what would.
    LogError
        A log without the signals it needs.
    """
    recs = [recordings] if isinstance(recordings, Recording) else list(recordings)
    unknown = [n for n in fix if n not in FITTED]
    if unknown:
        raise ValueError(f"--fix {unknown[0]}: not an identified parameter; one of {', '.join(FITTED)}")
    lows = [low_friction_logs] if isinstance(low_friction_logs, Recording) else list(low_friction_logs)
    drives = [_drive(r, base, low_friction) for r in recs] + [_drive(r, base, (), True) for r in lows]
    _excitation(drives, set(fix))
    est = {}
    if "yaw_rate_bias" in fix:
        b_r, est["yaw_rate_bias"] = 0.0, Estimate(0.0, 0.0, "rad/s", True)
    else:
        b_r, sd = _yaw_rate_offset(drives)
        _check("yaw_rate_bias", b_r, sd)
        est["yaw_rate_bias"] = Estimate(b_r, sd, "rad/s")
    held = {"C_f_nominal": base.C_f_nominal, "C_r_nominal": base.C_r_nominal, "I_zz": base.I_zz, "steer_gain": 1.0,
            "steer_bias": 0.0, "ay_bias": 0.0, "ay_roll_gain": 0.0}
    theta, var, weights = _fit_model(drives, base, b_r, [held[n] for n in _MODEL], set(fix))
    for i, name in enumerate(_MODEL):
        if name in fix:
            est[name] = Estimate(held[name], 0.0, _UNITS[name], True)
            continue
        sd = math.sqrt(var[i])
        _check(name, theta[i], sd)
        est[name] = Estimate(float(theta[i]), sd, _UNITS[name])
    if "ax_bias" in fix:
        est["ax_bias"] = Estimate(0.0, 0.0, "m/s2", True)
    else:
        value, sd = _ax_offset(drives)
        _check("ax_bias", value, sd)
        est["ax_bias"] = Estimate(value, sd, "m/s2")
    est.update(_low_friction(drives, base, b_r, theta, weights, bool(low_friction) or bool(lows)))
    fitted = {n: est[n].value for n in ("C_f_nominal", "C_r_nominal", "I_zz", "C_f_nominal_lo", "C_r_nominal_lo")}
    if "ay_roll_gain" not in fix:
        fitted.update(_roll(base, est["ay_roll_gain"].value))
    vehicle = base.with_overrides(fitted)
    return _summary(drives, vehicle, theta, b_r, est)


def _roll(base: VehicleParams, k_phi: float) -> dict:
    """The roll stiffnesses and dampers of the fitted roll gain ``k_phi`` (module docstring)."""
    if k_phi <= 0.0:
        raise IdentificationError("ay_roll_gain", f"the fitted roll gain {k_phi:.4g} is not positive (the "
                                  "accelerometer reads less than the car's acceleration in a turn: mounted or "
                                  "scaled wrong)")
    mgh = base.m_s * GRAVITY * base.h_s
    k_old = base.K_phi_f + base.K_phi_r
    k_new = mgh * (1.0 + 1.0 / k_phi)
    front = base.K_phi_f / k_old
    damping = math.sqrt((k_new - mgh) / (k_old - mgh))     # of the net roll stiffness: the damping ratio kept
    return {"K_phi_f": front * k_new, "K_phi_r": (1.0 - front) * k_new, "C_phi_f": base.C_phi_f * damping,
            "C_phi_r": base.C_phi_r * damping}


def _low_friction(drives, base, b_r, theta, weights, given: bool) -> dict:
    ratio_f, ratio_r = base.C_f_nominal_lo / base.C_f_nominal, base.C_r_nominal_lo / base.C_r_nominal
    if not given:                                  # held at the base vehicle's ratio to the dry value
        return {"C_f_nominal_lo": Estimate(theta[0] * ratio_f, 0.0, "N/rad", True),
                "C_r_nominal_lo": Estimate(theta[1] * ratio_r, 0.0, "N/rad", True)}
    if not any((d.fitted & d.low).any() for d in drives):
        raise IdentificationError("C_f_nominal_lo", "no moving sample falls in the low-friction windows")
    fun = _model_residuals(drives, base, b_r, weights, "low")

    def sub(x):
        return fun(np.r_[x * theta[:2], theta[2:]])
    res = least_squares(sub, np.array([ratio_f, ratio_r]), bounds=(0.02, 5.0), x_scale="jac")
    var = _variances(res.jac / theta[:2], res.fun, 2)
    out = {}
    for i, name in enumerate(("C_f_nominal_lo", "C_r_nominal_lo")):
        value, sd = float(res.x[i] * theta[i]), math.sqrt(var[i])
        _check(name, value, sd)
        out[name] = Estimate(value, sd, "N/rad")
    return out


def _summary(drives, vehicle, theta, b_r, est) -> Identification:
    er, ea, eb, n = [], [], [], 0
    for d in drives:
        keep = d.fitted & ~d.low
        r, ay, beta = single_track(theta[:5], d.delta, d.vx, vehicle)
        er.append((r - (d.r_m - b_r))[keep])
        ea.append(((1.0 + theta[6]) * ay + theta[5] - d.ay_m)[keep])
        if d.beta is not None:
            eb.append((beta - d.beta)[keep])
        n += int(keep.sum())
    rms = lambda parts: float(np.sqrt(np.mean(np.concatenate(parts) ** 2)))   # noqa: E731
    return Identification(vehicle, est, {"yaw_rate": rms(er), "ay": rms(ea)}, n, rms(eb) if eb else float("nan"))


# ---------------------------------------------------------------------------------------- the file
def vehicle_toml(result: Identification, base: str, logs) -> str:
    """A vehicle file inheriting ``base`` with the identified values in ``[params]`` and every estimate with its
    standard deviation in ``[identified]`` (the sensors' offsets, which belong to that drive, there only)."""
    lines = [f"# identified by `python -m sideslip identify` from {', '.join(str(p) for p in logs)}",
             f"base = {_quote(base)}", "", "[params]"]
    for name in ("C_f_nominal", "C_r_nominal", "I_zz", "C_f_nominal_lo", "C_r_nominal_lo"):
        lines.append(f"{name} = {getattr(result.vehicle, name):.6g}")
    if not result.estimates["ay_roll_gain"].fixed:              # the roll model of the fitted roll gain
        lines += [f"{name} = {getattr(result.vehicle, name):.6g}" for name in ROLL]
    lines += ["", "[identified]", "# value and standard deviation in SI units; 'held' values were not fitted"]
    for name, e in result.estimates.items():
        lines.append(f"{name} = {{ value = {e.value:.6g}, std = {e.std:.3g}, unit = {_quote(e.unit)}"
                     + (", held = true }" if e.fixed else " }"))
    lines.append(f"residual = {{ yaw_rate = {result.residual['yaw_rate']:.4g}, ay = {result.residual['ay']:.4g}, "
                 f"samples = {result.samples} }}")
    return "\n".join(lines) + "\n"


def _quote(text: str) -> str:
    return '"' + str(text).replace("\\", "\\\\").replace('"', '\\"') + '"'
