"""The fusion estimator: its filters, the GNSS fixes at their own time, the magnetometer, the outputs."""
from __future__ import annotations

import math
from collections import deque

import numpy as np
from scipy.linalg.lapack import dpotrf as _potrf

from ...constants import GRAVITY
from ...params import parse_bool
from ...plant import kernel
from ...signals import WHEEL_SPEEDS_M
from ..base import Estimator, ValidityGate, beta_std, input_enum
from ..delay import DelayLine, GpsLatency
from ..imm import InteractingMultipleModel
from ..kalman import InnovationMonitor, KalmanFilter
from .config import EKF, IMM, SideslipFusionConfig
from .inputs import InputConditioner
from .magnetometer import MagnetometerHeading
from .mode import FusionModel, Mode
from .models import Geometry, gnss_measurement, magnetometer_model
from .state import Fs, initial_state
from .tire_model import axle_stiffness

__all__ = ["SideslipFusion"]

# plain-int copies of the indices: indexing with an IntEnum member costs four times more
_VX, _VY, _PSI, _B_R, _B_AX, _B_AY, _D_DELTA, _LN_CF, _LN_CR, _LN_MU, _E_W, _G_Y, _K_AY, _D_GNSS, _B_MAG = (
    int(s) for s in Fs)
_ONE = np.array([1.0])
"""The EKF's mode probabilities."""


GNSS_INPUTS = ("gps_ve", "gps_vn", "gps_fresh", "gps_valid")
"""The GNSS inputs: unread when ``use_gnss`` is false."""


class SideslipFusion(Estimator):
    """GNSS / IMU / wheel-speed / steering fusion with a self-calibrating tire model
    (:mod:`sideslip.estimators.fusion`)."""

    config_class = SideslipFusionConfig
    input_names = ("ax_m", "ay_m", "yaw_rate_m", "delta_m", *WHEEL_SPEEDS_M, "gps_ve", "gps_vn", "gps_fresh",
                   "gps_valid", "mag_x", "mag_y", "mag_z")
    extra_outputs = ("yaw_hat", "bias_yaw_rate_hat", "bias_ax_hat", "bias_ay_hat", "steer_offset_hat", "Cf_hat",
                     "Cr_hat", "mu_hat", "friction_utilisation", "gps_delay_hat", "slide_probability", "roll_gain_error_hat")
    needs = ("the vehicle's geometry and mass roughly right; GNSS velocity for the best accuracy (without it the "
             "tire model, calibrated while GNSS was there, carries the estimate)")
    In = input_enum("In", input_names)

    @classmethod
    def unused_inputs(cls, parameters: dict) -> tuple:
        """The GNSS inputs when ``use_gnss`` is false."""
        return () if parse_bool("use_gnss", parameters.get("use_gnss", True)) else GNSS_INPUTS

    def _init_filter(self) -> None:
        cfg, ts, v = self.config, self.Ts, self.vehicle
        self._geometry = Geometry.from_vehicle(v)
        self._conditioner = InputConditioner(v, ts, cfg.yaw_acc_cutoff, cfg.combined_slip, cfg.mu_min, cfg.mu_max)
        x0, p0, q, p_cap, bounds = initial_state(cfg)
        window = max(int(round(cfg.adapt_window / ts)), 1)
        history = int(math.ceil(cfg.max_delay / ts)) + 2
        self._max_lag = history - 2
        # the delay state: the body's accelerations of its samples for its Jacobian
        self._acc_line = DelayLine(history, 2) if cfg.delay_state else None
        # the scalar models compiled where they run (the same doubles as the Python's)
        compiled = (kernel.FusionKernel((*self._geometry, GRAVITY, ts, cfg.utilisation_max,
                                         float(v.drive_split_front <= 0.0), cfg.mag_norm_gate, cfg.mag_declination,
                                         cfg.mag_tilt_std, cfg.mag_roll_error, cfg.sigma_mag,
                                         cfg.mag_tilt_correlation_time, cfg.mag_gate,
                                         *self._conditioner.kernel_constants()), len(x0))
                    if cfg.compiled and kernel.available() else None)
        self._conditioner.compiled = None if compiled is None else compiled.inputs
        # the EKF's robustness: correlated model error, covariance matching, Huber; the IMM's is its slide filter,
        # whose likelihoods need the per-sample (white) noise
        self._model = FusionModel(cfg, self._geometry, v.drive_split_front <= 0.0, q, p_cap, bounds,
                                  robust=cfg.formulation == EKF, compiled=compiled)
        # the samples a delayed fix needs: the filters' own (extrapolation) or the inputs and snapshots (re-run)
        self._history = None if cfg.fix_extrapolation else deque(maxlen=history)
        per_filter = history if cfg.fix_extrapolation else 0
        self._modes = [Mode(KalmanFilter(x0, np.diag(p0)), 1.0, 0.0, window, per_filter)]
        self._imm = None
        if cfg.formulation == IMM:                  # a grip filter and a slide filter
            self._modes.append(Mode(KalmanFilter(x0, np.diag(p0)), cfg.slide_factor, (cfg.slide_accel * ts) ** 2,
                                    window, per_filter))
            self._imm = InteractingMultipleModel([0.9, 0.1], cfg.mode_switch)
        self._x, self._P = x0.copy(), np.diag(p0)              # the combined estimate
        self._heading_known = False
        self._latency = GpsLatency(ts, cfg.gps_latency, cfg.gps_latency_std, cfg.identify_delay and not cfg.delay_state,
                                   min(cfg.max_delay, 0.5))
        self._gps_nis = InnovationMonitor(10, cfg.nis_limit)
        self._gate = ValidityGate(cfg.valid_std_max, cfg.valid_hold)
        self._magnetometer = MagnetometerHeading(cfg, ts, compiled)
        self._x_rate = 0.0
        self._started = False
        self._extra_values = self._compute_extras()

    @property
    def mode_probabilities(self) -> np.ndarray:
        """The filters' probabilities (the IMM's; one filter for the EKF)."""
        return self._imm.probabilities if self._imm is not None else _ONE

    def kalman_filters(self) -> list:
        return [m.kf for m in self._modes]

    # ---------------------------------------------------------------- the filters
    def _sample_all(self, inp, vx_ref: float) -> None:
        """One sample of every filter and, for the IMM, the mixing before and the mode probabilities after."""
        if self._imm is None:
            self._model.advance(self._modes[0], inp, vx_ref)
            return
        c = self._imm.mix(self.kalman_filters())
        self._imm.update([self._model.advance(m, inp, vx_ref) for m in self._modes], c)

    def _combine(self) -> None:
        """The combined estimate ``self._x``, ``self._P`` (the IMM's moment-matched mixture)."""
        if self._imm is None:
            self._x, self._P = self._modes[0].kf.x, self._modes[0].kf.P
        else:
            self._x, self._P = self._imm.combine(self.kalman_filters())

    def _snapshot(self) -> list:
        return [(m.kf.x.copy(), m.kf.P.copy(), m.slip) for m in self._modes] + [self.mode_probabilities.copy()]

    def _restore(self, snap: list) -> None:
        for m, (x, P, slip) in zip(self._modes, snap):
            m.kf.x, m.kf.P, m.slip = x.copy(), P.copy(), slip
        if self._imm is not None:
            self._imm.probabilities = snap[-1].copy()

    # ---------------------------------------------------------------- GNSS
    def _gnss_update(self, ve: float, vn: float, accel: float, lag: int = 0, acc=None,
                     at: float = 0.0) -> float | None:
        """Apply a fix taken ``lag`` samples ago to every filter (extrapolated to now,
        :class:`~sideslip.estimators.kalman.DelayedMeasurements`; at the current sample without them); returns the
        (probability-weighted) NIS, None if the fix was skipped.  With the delay state, ``acc`` is the body's
        measured ``(a_x, a_y)`` of the sample the fix is compared with and ``at`` its age [s]."""
        # the delay's uncertainty: noise of the acceleration's size, or (delay state) the state's
        noise = self.config.sigma_gnss ** 2 + (0.0 if acc is not None else (accel * self._latency.std) ** 2)
        z = np.array([ve, vn])
        updates = []
        for m in self._modes:
            x_s, P_s = (m.kf.x, m.kf.P) if m.delayed is None else m.delayed.past(lag)
            # the IMM's mixing moves its filters without their stored samples, whose covariance the corrections of
            # later fixes can then leave indefinite: such a fix is skipped, not applied with a negative NIS (the raw
            # LAPACK Cholesky: np.linalg.cholesky's checks cost more than the factorisation)
            if _potrf(P_s, lower=1, clean=0)[1] != 0:
                return None
            y, H, R = gnss_measurement(z, x_s, P_s, noise, acc, at)
            updates.append((y, H, R, H.dot(P_s).dot(H.T) + R if self._imm is not None else None))  # the IMM's S
        nis_sum, logs = 0.0, []
        for m, (y, H, R, S) in zip(self._modes, updates):
            nis = m.kf.update(y, H, R) if m.delayed is None else m.delayed.update(lag, y, H, R)
            self._model.bound(m.kf)
            nis_sum += nis
            if self._imm is not None:                   # the modes' likelihoods
                logs.append(-0.5 * (nis + math.log(max(np.linalg.det(S), 1e-300))))
        if self._imm is not None:
            self._imm.update(logs, self._imm.probabilities)
        return nis_sum / len(self._modes)

    def _apply_fix(self, ve: float, vn: float, accel: float) -> float | None:
        """A fix taken ``delay`` ago, at its own sample: extrapolated to now (``fix_extrapolation``), or applied there
        and the filter re-run to now from the stored inputs."""
        hist = self._history
        if self._acc_line is not None:
            lag = min(max(int(round(float(self._x[_D_GNSS]) / self.Ts)), 0), self._max_lag)
            # the sample compared is the oldest kept while fewer are (after the heading's initialisation): the
            # linearisation's age must be that sample's
            kept = len(self._modes[0].delayed) if hist is None else len(hist)
            lag = min(lag, max(kept - 1, 0))
            acc = self._acc_line.delayed(lag)
        else:
            lag, acc = self._latency.lag(self.Ts), None
        if hist is None:
            return self._gnss_update(ve, vn, accel, lag, acc, lag * self.Ts)
        if lag <= 0 or lag >= len(hist):
            nis = self._gnss_update(ve, vn, accel, 0, acc)
            hist[-1][2] = self._snapshot()
            return nis
        s = len(hist) - 1 - lag
        self._restore(hist[s][2])
        nis = self._gnss_update(ve, vn, accel, 0, acc, lag * self.Ts)
        hist[s][2] = self._snapshot()
        for j in range(s + 1, len(hist)):
            inp, vx_ref, _, heading = hist[j]
            self._sample_all(inp, vx_ref)
            if heading is not None:                     # the magnetometer's update of that sample, again
                self._heading_update(*heading)
            hist[j][2] = self._snapshot()
        return nis

    def _init_heading(self, ve: float, vn: float) -> None:
        """The heading from a fix's course minus the current sideslip; its cross-covariances dropped."""
        course = math.atan2(vn, ve)
        for m in self._modes:
            x, P = m.kf.x, m.kf.P
            beta = math.atan2(x[Fs.VY], max(x[Fs.VX], 0.1))
            # the course of the fix's time: the heading has turned by the yaw rate times the delay since
            x[Fs.PSI] = math.remainder(course - beta + self._x_rate * self._delay(), 2.0 * math.pi)
            P[Fs.PSI, :] = 0.0
            P[:, Fs.PSI] = 0.0
            P[Fs.PSI, Fs.PSI] = 0.05 ** 2 + P[Fs.VY, Fs.VY] / max(x[Fs.VX] ** 2, 1.0)
        self._heading_known = True

    def _fix(self, ve: float, vn: float, inp, vx_ref: float) -> None:
        """A fresh GNSS fix: the delay's identification, then the heading's initialisation or the fix's update."""
        cfg = self.config
        speed = math.hypot(ve, vn)
        if speed > cfg.course_speed:
            self._latency.add_fix(math.atan2(vn, ve), self._x_rate)
        if not self._heading_known or self._P[_PSI, _PSI] > cfg.heading_reset ** 2:
            if speed > cfg.course_speed:
                self._init_heading(ve, vn)
                if self._history is None:
                    for m in self._modes:
                        m.delayed.clear()
                else:
                    self._history.clear()
                    self._history.append([inp, vx_ref, self._snapshot(), None])
        else:
            nis = self._apply_fix(ve, vn, math.hypot(inp.ax, inp.ay))
            if nis is not None:
                self._gps_nis.add(nis, 2)
        self._combine()

    # ---------------------------------------------------------------- magnetometer
    def _heading_update(self, psi_m: float, r: float) -> None:
        """A magnetometer's heading ``psi_m`` of variance ``r`` [rad2], to every filter."""
        for m in self._modes:
            h, row = magnetometer_model(m.kf.x)
            m.kf.update_scalar(math.remainder(psi_m - h, 2.0 * math.pi), row, r)
        self._combine()

    # ---------------------------------------------------------------- the sample
    def _sample(self, u):
        I, cfg = self.In, self.config
        vw = self.speed(u)
        if not self._started:                          # start at the wheels' speed, straight ahead
            if vw < 0.5 * cfg.v_min:
                self.vx, self.yaw_rate, self.valid = vw, u[I.YAW_RATE_M], False
                return
            for m in self._modes:
                m.kf.x[Fs.VX] = vw
                m.kf.P[Fs.VX, Fs.VX] = 0.1 ** 2
                m.kf.P[Fs.VY, Fs.VY] = (0.05 * vw) ** 2
            self._started = True
        x = self._x            # the offsets as Python floats: the sample's scalar arithmetic on NumPy scalars is slow
        inp = self._conditioner(u[I.AX_M], u[I.AY_M], u[I.YAW_RATE_M], u[I.DELTA_M], vw, x.item(_B_AX), x.item(_B_AY),
                                x.item(_K_AY))
        self._model.ln_mu_floor = self._conditioner.ln_mu_floor
        if self._acc_line is not None:
            self._acc_line.push(inp[:2])
        vx_ref = float(self._x[_VX])
        self._sample_all(inp, vx_ref)
        if self._history is None:
            for m in self._modes:
                m.delayed.push()
        else:
            self._history.append([inp, vx_ref, self._snapshot(), None])
        self._combine()
        self._x_rate = inp.r_m - self._x.item(_B_R)
        self._latency.push(self._x_rate, self.beta)
        gnss = cfg.use_gnss and u[I.GPS_VALID] != 0.0
        if gnss and u[I.GPS_FRESH] != 0.0:
            self._fix(u[I.GPS_VE], u[I.GPS_VN], inp, vx_ref)
        if cfg.use_magnetometer and self._heading_known:
            heading = self._magnetometer.measure((u[I.MAG_X], u[I.MAG_Y], u[I.MAG_Z]), self._conditioner.roll.phi,
                                                 self._x, self._P)
            if heading is not None:
                self._heading_update(*heading)
                if self._history is not None:              # a fix's re-run repeats it
                    self._history[-1][2:] = [self._snapshot(), heading]
        self._outputs(inp, vw, gnss)

    def _outputs(self, inp, vw: float, gnss: bool) -> None:
        """The estimate, its std and validity of the combined state."""
        cfg, x, P = self.config, self._x, self._P
        x[_PSI] = math.remainder(x.item(_PSI), 2.0 * math.pi)
        for m in self._modes:
            m.kf.x[_PSI] = math.remainder(m.kf.x.item(_PSI), 2.0 * math.pi)
        vx, vy = x.item(_VX), x.item(_VY)
        self.vx, self.vy, self.yaw_rate = vx, vy, inp.r_m - x.item(_B_R)
        self.beta = math.atan2(vy, vx) if vx > 0.1 else 0.0
        std = beta_std(vx, vy, P.item(_VX, _VX), P.item(_VY, _VY), P.item(_VX, _VY))
        if gnss and self._heading_known:
            std *= self._gps_nis.inflation()
        self.beta_std = std
        # locked wheels (their speed within +-v_min) say nothing of the speed; a consistent GNSS velocity still
        # does (wheels turning backwards are a car the model does not describe)
        rolling = vw > cfg.v_min or (cfg.locked_wheels_valid and gnss and vw > -cfg.v_min)
        self.valid = (vx > cfg.v_min and rolling and (self._heading_known or not gnss)
                      and (not gnss or self._gps_nis.consistent))
        self._extra_values = self._compute_extras()

    def _delay(self) -> float:
        """The GNSS delay in use [s]."""
        return float(self._x[_D_GNSS]) if self.config.delay_state else self._latency.value

    def _extras(self) -> tuple:
        return self._extra_values

    def _compute_extras(self) -> tuple:
        """The extra outputs of the current estimate (once per sample: the outputs read them every step)."""
        x, g = self._x.tolist(), self._geometry
        mu = math.exp(x[_LN_MU])
        c_f = axle_stiffness(g.c_f, g.c_f_lo, g.mu_lo, mu)[0] * math.exp(x[_LN_CF])
        c_r = axle_stiffness(g.c_r, g.c_r_lo, g.mu_lo, mu)[0] * math.exp(x[_LN_CR])
        if self._imm is None:
            utilisation, slide = self._modes[0].utilisation, 0.0
        else:
            prob = self.mode_probabilities
            utilisation, slide = sum(p * m.utilisation for p, m in zip(prob, self._modes)), float(prob[1])
        return (math.remainder(x[_PSI], 2.0 * math.pi), x[_B_R], x[_B_AX], x[_B_AY], x[_D_DELTA], c_f, c_r, mu,
                min(float(utilisation), 1.0), self._delay(), slide, x[_K_AY])
