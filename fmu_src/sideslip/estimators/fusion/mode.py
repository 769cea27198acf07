"""One filter of the fusion: its time update, wheel-speed update and tire updates of a sample.

:class:`FusionModel` holds what every filter of an estimator shares (the configuration, the process
noise, the bounds, the vehicle's axles) and runs one :class:`Mode`'s sample; the EKF has one mode, the
IMM two, which differ in how much they trust the tire model (``r_scale``) and in extra process noise
on the lateral velocity (``q_vy``).

How the measurements are weighed:

* **Wheel speeds** - a Huber gate caps the weight of a residual beyond ``pseudo_gate`` of its std (a
  locking or spinning wheel is weighed as if at the gate).
* **Tire pseudo-measurements** - their noise is the tire's transient (relaxation: the slip rate times
  ``relaxation_length / v_x``), ``sigma_slip`` and the brush model's error, which grows with the
  friction utilisation squared (``slip_model_error``), at the utilisation of a friction
  ``friction_doubt`` std below the estimate, plus ``stiffness_doubt`` per prior std by which a
  stiffness scale lies below the vehicle file's beyond one std and the friction's own fall (a slide the
  stiffness absorbed rather than a file's error).  In the EKF the error's correlation inflates it
  (``slip_correlation_time / Ts``), covariance matching over ``adapt_window`` (an
  :class:`~sideslip.estimators.kalman.InnovationMonitor` per axle) and a Huber gate; the IMM's
  likelihoods need the per-sample (white) noise and its slide mode is its robustness.  Beyond
  ``utilisation_max`` the slip is a lower bound: a state sliding further is not corrected.  Where the
  state's slip of an axle is beyond the brush tire's at ``utilisation_max``, the axle carries all its
  friction and its force measures the friction (``sliding_friction``,
  :func:`~sideslip.estimators.fusion.models.sliding_friction_measurement`).
* **Bounded states** - the stiffness scales, the friction and the delay are clamped after each update;
  the friction also from below by the measured acceleration.  A parameter whose variance has reached its
  prior's gets no process noise, so that one nothing shows cannot grow without bound.
"""
from __future__ import annotations

import math

import numpy as np

from ..kalman import DelayedMeasurements, InnovationMonitor, KalmanFilter
from .friction_test import friction_test
from .models import (AxlePseudo, Geometry, SampleInputs, ScalarMeasurement, axle_pseudo, kinematic_step,
                     sliding_friction_measurement, wheel_measurement)
from .state import Fs

__all__ = ["Mode", "FusionModel"]

_VX, _VY, _LN_CF, _LN_CR, _LN_MU, _E_W = (int(s) for s in (Fs.VX, Fs.VY, Fs.LN_CF, Fs.LN_CR, Fs.LN_MU, Fs.E_W))


class Mode:
    """One extended Kalman filter on the model, with its pseudo-measurement scale and extra lateral process noise.

    Parameters
    ----------
    kf : KalmanFilter
        The filter.
    r_scale : float
        Multiple of the tire pseudo-measurements' std.
    q_vy : float
        Extra process noise of the lateral velocity per sample [m2/s2].
    window : int
        Samples of the covariance matching.
    history : int
        Samples kept for delayed GNSS fixes (0: none, the estimator re-runs instead).
    """

    __slots__ = ("kf", "r_scale", "q_vy", "monitors", "delayed", "slip", "utilisation", "friction_llr")

    def __init__(self, kf: KalmanFilter, r_scale: float, q_vy: float, window: int, history: int):
        self.kf, self.r_scale, self.q_vy = kf, r_scale, q_vy
        self.monitors = (InnovationMonitor(window), InnovationMonitor(window))   # per axle: covariance matching
        self.delayed = DelayedMeasurements(kf, history) if history else None    # fix extrapolation
        self.slip = (0.0, 0.0)               # the axles' slip angles of the last sample [rad] (their rate)
        self.utilisation = 0.0               # the larger axle's friction utilisation
        self.friction_llr = 0.0              # CUSUM of the low-friction hypothesis (friction_test)


class FusionModel:
    """What the filters of one estimator share, and one filter's sample (module docstring).

    Parameters
    ----------
    config : SideslipFusionConfig
        The estimator's parameters.
    geometry : Geometry
        The vehicle file's axles.
    front_undriven : bool
        The undriven wheels are the front ones (they turn with the steering).
    q, p_cap : ndarray
        Process noise per sample and the variances beyond which a state gets none (per state).
    bounds : tuple
        ``(state, low, high)`` of the bounded states.
    robust : bool
        The EKF's robustness (correlation, covariance matching, Huber) on the tire pseudo-measurements.
    compiled : sideslip.plant.kernel.FusionKernel, optional
        The compiled kinematic step, wheel-speed and tire measurements (the same doubles); None: the Python models.
    """

    __slots__ = ("config", "ts", "geometry", "front_undriven", "q", "p_cap", "bounds", "robust", "correlation",
                 "ln_mu_floor", "_ln_mu0", "_inv_mu_std", "_inv_c_std", "_compiled_kinematic", "_compiled_wheel",
                 "_compiled_axles")

    def __init__(self, config, geometry: Geometry, front_undriven: bool, q: np.ndarray, p_cap: np.ndarray,
                 bounds: tuple, robust: bool, compiled=None):
        cfg = config
        self.config, self.ts, self.geometry, self.front_undriven = cfg, cfg.Ts, geometry, front_undriven
        self.q, self.p_cap, self.bounds, self.robust = q, p_cap, bounds, robust
        self.correlation = max(cfg.slip_correlation_time / cfg.Ts, 1.0) if robust else 1.0
        self.ln_mu_floor = math.log(cfg.mu_min)        # the road carries what the car is measured to do (the inputs')
        self._ln_mu0, self._inv_mu_std, self._inv_c_std = math.log(cfg.mu0), 1.0 / cfg.mu_std0, 1.0 / cfg.stiffness_std0
        # bound methods, not the kernel: an FMU state takes them from its template (a kernel's buffers are not data)
        self._compiled_kinematic, self._compiled_wheel, self._compiled_axles = (
            (None, None, None) if compiled is None else (compiled.kinematic, compiled.wheel, compiled.axles))

    def axles(self, x: np.ndarray, inp: SampleInputs) -> tuple:
        """:func:`~sideslip.estimators.fusion.models.axle_pseudo` of the state ``x``, compiled where it runs (its
        rows are then valid until the next call)."""
        if self._compiled_axles is None:
            return axle_pseudo(x, inp, self.geometry, self.config.utilisation_max)
        h_f, a_f, u_f, s_f, g_f, h_r, a_r, u_r, s_r, g_r, front, rear = self._compiled_axles(x, inp)
        return AxlePseudo(h_f, front, a_f, u_f, s_f, g_f), AxlePseudo(h_r, rear, a_r, u_r, s_r, g_r)

    def advance(self, mode: Mode, inp: SampleInputs, vx_ref: float) -> float:
        """Time update and the wheel-speed and tire updates of one filter for one sample; returns the log-likelihood
        of the tire pseudo-measurements."""
        kf = mode.kf
        xp, F = (kinematic_step(kf.x, inp.ax, inp.ay, inp.r_m, self.ts) if self._compiled_kinematic is None
                 else self._compiled_kinematic(kf.x, inp.ax, inp.ay, inp.r_m))
        # a parameter whose variance has reached its prior's gets no more process noise (nothing shows it)
        q = self.q * (kf.P.ravel()[::len(kf.x) + 1] < self.p_cap)      # (the diagonal's view)
        q[_VY] += mode.q_vy
        kf.predict(xp, F, q)
        x = kf.x
        self._huber_update(kf, wheel_measurement(x, inp, self.front_undriven) if self._compiled_wheel is None
                           else self._compiled_wheel(x.item(_VX), x.item(_E_W), x.item(_LN_MU), inp.delta,
                                                     inp.v_wheel, inp.ax))
        loglik = self._tire_updates(mode, inp, vx_ref) if vx_ref > self.config.v_min else 0.0
        self.bound(kf)
        return loglik

    def bound(self, kf: KalmanFilter) -> None:
        """Clamp the bounded states (module docstring)."""
        x = kf.x
        values = x.tolist()                 # compared as Python floats: one conversion instead of one per state
        for i, lo, hi in self.bounds:
            if values[i] < lo:
                x[i] = lo
            elif values[i] > hi:
                x[i] = hi
        if x.item(_LN_MU) < self.ln_mu_floor:
            x[_LN_MU] = self.ln_mu_floor

    def _huber_update(self, kf: KalmanFilter, m: ScalarMeasurement) -> None:
        """A scalar update whose residual beyond ``pseudo_gate`` of its std is weighed as if at the gate."""
        y, row, r = m
        gate2 = self.config.pseudo_gate ** 2
        Ph = kf.P.dot(row)
        prior = float(row.dot(Ph))
        var = prior + r
        if y * y > gate2 * var:
            r += y * y / gate2 - var
        kf.update_scalar(y, row, r, Ph, prior)

    def _tire_updates(self, mode: Mode, inp: SampleInputs, vx_ref: float) -> float:
        """The two axles' tire updates (the sliding friction where an axle slides); their log-likelihood."""
        cfg, kf = self.config, mode.kf
        x0 = kf.x
        axles = self.axles(x0, inp)
        if cfg.friction_test > 0.0 and friction_test(mode, kf, x0, axles, inp, vx_ref, cfg, self.geometry,
                                                     self.correlation):
            x0 = kf.x
            axles = self.axles(x0, inp)
        front, rear = axles
        rates = ((front.slip - mode.slip[0]) / self.ts, (rear.slip - mode.slip[1]) / self.ts)
        mode.slip = (front.slip, rear.slip)
        mode.utilisation = max(front.utilisation, rear.utilisation)
        # the friction's uncertainty is not in the rows where the tire is linear (d alpha / d ln mu ~ 0): a road
        # slipperier than estimated would make the brush model wrong by more than its own utilisation says
        doubt = math.exp(cfg.friction_doubt * math.sqrt(kf.P.item(_LN_MU, _LN_MU)))
        # how far each axle's stiffness lies below the file beyond its prior std and the friction's fall
        mu_fall = abs(x0.item(_LN_MU) - self._ln_mu0) * self._inv_mu_std
        softness = (-x0.item(_LN_CF) * self._inv_c_std - 1.0 - mu_fall,
                    -x0.item(_LN_CR) * self._inv_c_std - 1.0 - mu_fall)
        loglik = 0.0
        for axle, rate, monitor, soft in zip(axles, rates, mode.monitors, softness):
            h, alpha = axle.residual, axle.slip
            slip_state = alpha - h / vx_ref if alpha >= 0.0 else h / vx_ref - alpha     # along the force
            if cfg.sliding_friction and axle.utilisation > 0.05 and slip_state > axle.slip_at_max:
                # the state's slip is beyond the brush tire's at utilisation_max (where its inverse has no answer):
                # the axle slides, |F_y| = F_max, which measures the friction and says nothing of the slip
                y, row, rs = sliding_friction_measurement(axle, kf.x, x0, cfg.sliding_friction_std ** 2
                                                          * self.correlation)
                Ph = kf.P.dot(row)
                prior = float(row.dot(Ph))
                var = prior + rs
                nis = kf.update_scalar(y, row, rs, Ph, prior)
                loglik -= 0.5 * (nis + math.log(2.0 * math.pi * var))
                continue
            loglik += self._pseudo_update(mode, axle, h + float(axle.row.dot(kf.x - x0)), rate, monitor, soft,
                                          doubt, vx_ref)
        return loglik

    def _pseudo_update(self, mode: Mode, axle, h: float, rate: float, monitor: InnovationMonitor, soft: float,
                       doubt: float, vx_ref: float) -> float:
        """One axle's tire pseudo-measurement with the residual ``h`` after the other axle's update (linearised);
        its log-likelihood (0 when skipped)."""
        cfg, kf, row, alpha = self.config, mode.kf, axle.row, axle.slip
        util = axle.utilisation
        if util >= cfg.utilisation_max and h * alpha <= 0.0:
            return 0.0                      # saturated: the clipped slip is a lower bound, and the state's slip
            #                                 exceeds it the same way (a slide): nothing to correct
        util *= doubt
        util = util if util < 1.0 else 1.0
        rel = cfg.slip_model_error * util * util
        if soft > 0.0:
            rel += cfg.stiffness_doubt * soft
        s = (cfg.sigma_slip + rel * abs(alpha) + cfg.relaxation_length / vx_ref * abs(rate)) * vx_ref * mode.r_scale
        rr = s * s * self.correlation
        Ph = kf.P.dot(row)
        prior = float(row.dot(Ph))
        monitor.add(h * h / (prior + rr))
        if self.robust:                     # covariance matching (EKF only)
            rr *= monitor.inflation() ** 2
        var = prior + rr
        if self.robust and h * h > cfg.pseudo_gate ** 2 * var:   # Huber: weighed as if at the gate
            rr += h * h / cfg.pseudo_gate ** 2 - var
            var = h * h / cfg.pseudo_gate ** 2
        nis = kf.update_scalar(-h, row, rr, Ph, prior)
        return -0.5 * (nis + math.log(2.0 * math.pi * var))
