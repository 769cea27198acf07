"""Nguyen, Wang, Fujimoto, Hori (2012), "Sideslip angle estimation using GPS and disturbance accommodating
multi-rate Kalman filter for electric vehicle stability control".

A linear Kalman filter on the bicycle model with the in-wheel motors' yaw moment as an input,
in three variants selected by ``mode`` (Table II of the paper):

* ``srkf`` - single-rate KF on ``[beta, gamma]``, measuring the yaw rate every sample;
* ``mrkf`` - multi-rate KF on ``[beta, gamma, psi]``, adding the GPS course ``c = psi + beta``
  (eq 3) whenever a fix arrives (``gps_fresh``, 5 Hz in the paper) - the "inter-samples" between
  fixes run on the yaw rate alone (eqs 16-18);
* ``dacmrkf`` - the disturbance-accommodating MRKF on ``[beta, gamma, psi, d1, d2]`` (eq 13):
  the lumped model errors and external disturbances ``d1``, ``d2`` (eqs 8-9) are random-walk
  states (eq 12) entering the sideslip and yaw equations (eqs 4, 7).

Continuous model, eqs 1-7 with ``2 C`` per axle (the vehicle's nominal axle stiffness).  Eqs 2-3
as printed put the yaw-moment disturbance ``N_d`` into the course equation; from eq 9
(``d2`` contains ``N_d / I_z``) it belongs to the yaw equation, ``I_z dgamma/dt = ... + N_z + N_d``,
and the course is ``c = psi + beta``.  The in-wheel motors' yaw moment ``N_z`` (``B_n`` of eq 7)
is the input ``Mz_cmd`` (the controller's output in closed loop; 0 without one).

Discretisation: the exact zero-order hold of the augmented system, ``expm([[A, B], [0, 0]] T)``
(scipy), instead of the first-order ``I + A T`` of eq 11 (``discretization="euler"`` keeps the
paper's).  The model depends on ``v_x``, so the matrices are cached per 0.01 m/s of speed
(:mod:`sideslip.estimators.discrete`; the filter runs every 1 ms).  At the COMS's 5.6 m/s and 1 ms the
fastest mode is ``|lambda| T ~ 0.01``, so the two differ by ``(lambda T)^2 / 2 ~ 5e-5`` relative
per step: the accuracy page of the docs gives the measured effect on the estimates.

Observability: at constant speed the DACMRKF's state on yaw rate and course has rank 4 of 5; the
direction ``(1, 0, -1, -a11, -a21)`` (a sideslip shift taken up by the heading and by ``d1, d2``)
changes neither measurement, so the estimate can wander along it (accuracy page of the docs, Nguyen 2012).

The course is compared with ``psi + beta`` modulo 2 pi (the innovation is wrapped), so laps do
not matter; ``psi`` is started from the first course fix and kept in (-pi, pi].

Hardened profile (``profile = 1``, the default; ``profile = 0`` is the method above), additions for
sensors and vehicles other than the paper's, each with the failure it answers:

* **Gyro offset state** ``b_g`` (``r_m = gamma + b_g``, a slow random walk): an uncompensated
  offset ``b`` drives the estimate along the unobservable direction at ``-b`` rad/s (28 deg RMS on
  a 25 m circle with 0.5 deg/s).  The offset shows in the course: in a steady turn the course rate
  is the true yaw rate.  The additions need the course: ``srkf`` (no GPS) stays as published.
* **Disturbances as first-order Markov processes** (``tau_d``) instead of random walks: the random
  walks leave one direction of ``[beta, gamma, psi, d1, d2]`` unobservable at constant speed
  (rank 4 of 5), along which the offset state could not be told from the sideslip.
* **GPS delay**: the course is compared with ``psi + beta`` of the delay earlier (a
  :class:`~sideslip.estimators.delay.DelayLine` of the sample period); the delay is the prior
  ``gps_latency`` until it is identified from changes of the yaw rate, and what remains uncertain
  adds ``(r sigma_D)^2`` to the course noise (:class:`~sideslip.estimators.delay.GpsLatency`); 0.1 s
  of latency at 0.4 rad/s is 2 deg of course.
* **Course noise from the speed**: a course from velocity noise ``sigma_gps_velocity`` at speed ``v``
  has ``sigma_v / v`` of noise on top of the receiver's ``sigma_course``; below ``course_speed`` the
  course is not used.
* **Truthful uncertainty and validity**: ``beta_hat_std`` is inflated by the course innovations'
  consistency (:class:`~sideslip.estimators.kalman.InnovationMonitor`) and adds the linear tires'
  model error; beyond their range the sideslip's variance is raised
  (:class:`~sideslip.estimators.model_trust.ModelTrust`, which needs the lateral acceleration: the
  input ``ay_m``, unused as published); ``valid`` is false until the heading has been set, while the
  GPS is out longer than ``gps_coast``, while the innovations are inconsistent and while the std
  exceeds ``valid_std_max``; inconsistent yaw-rate innovations (a diverged filter) restart the filter.
  The estimate's departure from the kinematics ``d(beta)/dt = a_y / v_x - r``
  (:class:`~sideslip.estimators.model_checks.KinematicCheck`, ``kinematic_check``) adds to the reported
  std: in a J-turn on a wet road the kinematic blend follows the accelerometer's offset and roll, and
  the check keeps the stretches of more than 3 deg off while valid short.
  The gyro-offset state is not bounded to a datasheet's offset: clamping a Kalman state leaves its
  covariance claiming a freedom the state no longer has, and a filter started in a steady turn then
  restarted every 1.5 s on inconsistent yaw-rate innovations (on ice the state reached 1.7 deg/s,
  and a 1 deg/s bound changed the J-turn's RMS by 0.05 deg).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from functools import partial

import numpy as np

from ..bicycle import BicycleModel
from ..params import param
from ..signals import WHEEL_SPEEDS_M
from ..units import wrap_angle
from .base import input_enum
from .delay import DelayLine, GpsLatency, HardenedGpsLatencyConfig
from .discrete import SpeedCache, euler, zoh
from .kalman import InnovationMonitor, KalmanFilter
from .model_trust import LinearTireConfig, ModelTrust
from .profiles import ProfiledEstimator

__all__ = ["Nguyen2012Config", "Nguyen2012DACMRKF", "St", "continuous_model", "hardened_model", "MODES"]

MODES = {"srkf": 2, "mrkf": 3, "dacmrkf": 5}
"""Mode -> number of states (the leading block of eq 13)."""


class St(IntEnum):
    """State of eq 13, and the gyro offset of the hardened profile."""
    BETA, GAMMA, PSI, D1, D2, BG = range(6)


def continuous_model(model: BicycleModel, vx: float) -> tuple[np.ndarray, np.ndarray]:
    """Augmented continuous model: ``dh/dt = A h + B [delta_f, N_z]`` (eqs 4-7, 12-15).

    ``A = [[A_n, D], [0, 0]]`` with ``A_n`` of eq 6 (and ``dpsi/dt = gamma``) and ``D`` of eq 7;
    ``B = [B_n; 0]``.
    """
    a, b = model.matrices(vx)
    A = np.zeros((5, 5))
    A[:St.PSI, :St.PSI] = a
    A[St.PSI, St.GAMMA] = 1.0
    A[St.BETA, St.D1] = A[St.GAMMA, St.D2] = 1.0         # D of eq 7
    B = np.zeros((5, 2))
    B[:St.PSI] = b
    return A, B


def hardened_model(model: BicycleModel, tau_d: float, vx: float) -> tuple[np.ndarray, np.ndarray]:
    """The hardened profile's model on ``[beta, gamma, psi, d1, d2, b_g]``: eq 13 with Markov
    disturbances ``d' = -d / tau_d`` and a constant gyro offset."""
    A5, B5 = continuous_model(model, vx)
    A = np.zeros((6, 6))
    A[:5, :5] = A5
    A[St.D1, St.D1] = A[St.D2, St.D2] = -1.0 / tau_d
    B = np.zeros((6, 2))
    B[:5] = B5
    return A, B


@dataclass(frozen=True)
class Nguyen2012Config(LinearTireConfig, HardenedGpsLatencyConfig):
    """Parameters of :class:`Nguyen2012DACMRKF`; the paper gives none of Q_w and Q_v in numbers."""

    vehicle: str = param("nguyen2012_coms", "Dimensionless", "Vehicle parameter set: bundled name or TOML path")
    Ts: float = param(0.001, "Time", "Sample period T_c of the filter (1 ms in the paper)", gt=0, le=1.0)
    mode: str = param("dacmrkf", "Dimensionless", "Filter variant of Table II", choices=tuple(MODES))
    discretization: str = param("expm", "Dimensionless", "Model discretisation: exact zero-order hold or the "
                                "first-order approximation of eq 11", choices=("expm", "euler"))
    mu: float = param(0.8, "FrictionCoefficient", "Friction for which the nominal cornering stiffness is taken",
                      ge=0.05, le=1.5)
    q_beta: float = param(1e-4, "Angle", "q11 of eq 20: process noise of beta per sample (std)", gt=0, le=1)
    q_gamma: float = param(2e-4, "AngularVelocity", "q22: process noise of the yaw rate per sample (std)", gt=0,
                           le=1)
    q_psi: float = param(1e-8, "Angle", "q33: process noise of the yaw angle per sample (std)", gt=0, le=1)
    q_d1: float = param(1e-3, "AngularVelocity", "q44: random-walk step of d1 per sample (std)", gt=0, le=1)
    q_d2: float = param(1e-2, "AngularAcceleration", "q55: random-walk step of d2 per sample (std)", gt=0, le=10)
    sigma_gyro: float = param(0.003, "AngularVelocity", "Yaw-rate noise (std) in Q_v of eq 19", gt=0, le=1)
    sigma_course: float = param(0.0025, "Angle", "GPS course noise (std) in Q_v (0.14 deg RMS, Section V.A)",
                                gt=0, le=1)
    # hardened profile (module docstring)
    tau_d: float = param(3.0, "Time", "Hardened: correlation time of the Markov disturbances d1, d2", gt=0.01, le=1e4)
    q_bias: float = param(2e-6, "AngularVelocity", "Hardened: random-walk step of the gyro offset per sample (std)",
                          gt=0, le=0.1)
    bias_std0: float = param(0.012, "AngularVelocity", "Hardened: initial uncertainty of the gyro offset", gt=0, le=1)
    sigma_gps_velocity: float = param(0.1, "Velocity", "Hardened: GPS velocity noise behind the course noise "
                                      "sigma_v / v", ge=0, le=5)
    course_speed: float = param(3.0, "Velocity", "Hardened: speed below which the course is not used", gt=0, le=50)
    gps_coast: float = param(10.0, "Time", "Hardened: GPS outage after which the estimate is not valid", gt=0, le=600)
    yaw_acc_std: float = param(2.0, "AngularAcceleration", "Hardened: yaw acceleration the kinematic yaw-rate "
                               "prediction leaves open (process noise, std)", gt=0, le=100)


class Nguyen2012DACMRKF(ProfiledEstimator):
    """SRKF / MRKF / DACMRKF of Nguyen 2012 (see module docstring)."""

    config_class = Nguyen2012Config
    input_names = ("yaw_rate_m", "delta_m", *WHEEL_SPEEDS_M, "gps_course", "gps_fresh", "gps_valid", "Mz_cmd", "ay_m")
    extra_outputs = ("yaw_hat", "d1_hat", "d2_hat", "bias_yaw_rate_hat", "gps_delay_hat")
    needs = ("as published (profile 0): an offset-free yaw rate (no gyro-offset state: an offset b moves beta_hat "
             "at -b rad/s along the direction it cannot observe); hardened: GPS course, tires near their linear range")
    In = input_enum("In", input_names)

    def _init_filter(self):
        cfg = self.config
        self.hardened = self.hardened and MODES[cfg.mode] > St.PSI      # the SRKF has no course to harden with
        self.bias = 0.0
        if self.hardened:
            self._hardened_init()
            return
        self.n = n = MODES[cfg.mode]
        self.model = BicycleModel.from_vehicle(self.vehicle, cfg.mu, nominal=True)
        self._matrices = SpeedCache(partial(continuous_model, self.model), self.Ts,
                                    zoh if cfg.discretization == "expm" else euler, n)
        q = np.array([cfg.q_beta, cfg.q_gamma, cfg.q_psi, cfg.q_d1, cfg.q_d2])[:n]
        self._Q = np.diag(q ** 2)                                       # eq 20
        self._r_gyro, self._r_course = cfg.sigma_gyro ** 2, cfg.sigma_course ** 2     # eq 19
        self._h_course = np.zeros(n)
        if n > St.PSI:
            self._h_course[[St.BETA, St.PSI]] = 1.0                     # eq 17, second row: c = beta + psi
        self.kf = KalmanFilter(np.zeros(n), np.diag([1e-4, 1e-4, math.pi ** 2, 1e-2, 1e-1][:n]))
        self._heading_set = False
        self._xu = np.zeros(n + 2)             # [state, delta_f, N_z]
        self.yaw = self.d1 = self.d2 = 0.0

    def _extras(self) -> tuple:
        return (wrap_angle(self.yaw), self.d1, self.d2, self.bias, self._latency.value if self.hardened else 0.0)

    def _sample(self, u):
        I, cfg = self.In, self.config
        vx = self.speed(u)
        self.vx = vx
        if vx < cfg.v_min:                      # eqs 1-2 divide by v_x: hold
            self.valid = False
            self.yaw_rate = u[I.YAW_RATE_M] - self.bias
            return
        kf, n = self.kf, self.n
        F, FG = self._matrices(vx)
        xu = self._xu
        xu[:n] = kf.x
        xu[n], xu[n + 1] = u[I.DELTA_M], u[I.MZ_CMD]
        if self.hardened:
            self._hardened_predict(u, vx, FG.dot(xu), F)
            if not self._hardened_gyro_update(u):
                return
            self._hardened_course_update(u, vx)
            self._hardened_outputs(u, vx)
            return
        kf.predict(FG.dot(xu), F, self._Q)                                    # eq 14: K_nd h + G_nd u
        kf.update_state(St.GAMMA, u[I.YAW_RATE_M] - kf.x.item(St.GAMMA), self._r_gyro)  # every T_c
        if self.n > St.PSI and u[I.GPS_FRESH] and u[I.GPS_VALID]:          # every T_s: the course
            self._course_update(u[I.GPS_COURSE])
        x = kf.x.tolist()
        self.beta, self.yaw_rate = x[St.BETA], x[St.GAMMA]
        self.beta_std = math.sqrt(kf.P.item(0))         # P[BETA, BETA]
        self.vy = vx * math.tan(self.beta)
        if self.n > St.PSI:
            self.yaw = x[St.PSI]
        if self.n > St.D1:
            self.d1, self.d2 = x[St.D1], x[St.D2]
        self.valid = True

    def _course_update(self, course: float) -> None:
        """The GPS course ``c = psi + beta`` (eq 17, second row); the first fix sets the heading, ``psi = c - beta``."""
        kf = self.kf
        if not self._heading_set:
            kf.x[St.PSI] = course - kf.x[St.BETA]
            kf.P[St.PSI, :] = kf.P[:, St.PSI] = 0.0
            kf.P[St.PSI, St.PSI] = self._r_course + kf.P[St.BETA, St.BETA]
            self._heading_set = True
        else:
            innovation = math.remainder(course - kf.x[St.PSI] - kf.x[St.BETA], 2.0 * math.pi)
            kf.update_scalar(innovation, self._h_course, self._r_course)
        kf.x[St.PSI] = math.remainder(kf.x[St.PSI], 2.0 * math.pi)

    # ---------------------------------------------------------------- hardened profile
    def _hardened_init(self):
        cfg, ts = self.config, self.Ts
        self.model = BicycleModel.from_vehicle(self.vehicle, cfg.mu, nominal=True)
        dac = MODES[cfg.mode] == 5
        keep = [St.BETA, St.GAMMA, St.PSI] + ([St.D1, St.D2] if dac else []) + [St.BG]
        self._keep = keep
        self.n = n = len(keep)
        full = partial(hardened_model, self.model, cfg.tau_d)

        def model(vx):                                  # the kept states of the 6-state model
            A, B = full(vx)
            return A[np.ix_(keep, keep)], B[keep]
        self._matrices = SpeedCache(model, ts, zoh if cfg.discretization == "expm" else euler)
        q = np.array([cfg.q_beta, cfg.q_gamma, cfg.q_psi, cfg.q_d1, cfg.q_d2, cfg.q_bias])[keep]
        self._Q = np.diag(q ** 2)
        self._ix = {s: i for i, s in enumerate(keep)}
        self._h_gyro = np.zeros(n)
        self._h_gyro[[self._ix[St.GAMMA], self._ix[St.BG]]] = 1.0           # r_m = gamma + b_g
        self._h_course = np.zeros(n)
        self._h_course[[self._ix[St.BETA], self._ix[St.PSI]]] = 1.0         # c = beta + psi
        p0 = [1e-4, 1e-4, math.pi ** 2, 1e-2, 1e-1, cfg.bias_std0 ** 2]
        self.kf = KalmanFilter(np.zeros(n), np.diag([p0[k] for k in keep]))
        self._xu = np.zeros(n + 2)
        self._heading_set = False
        depth = int(round(0.5 / ts)) + 2
        self._course_hist = DelayLine(depth)             # psi + beta of the last 0.5 s
        self._trust = ModelTrust(self.vehicle, ts, cfg)
        self._latency = GpsLatency(ts, cfg.gps_latency, cfg.gps_latency_std, cfg.identify_delay)
        self._yaw_nis = InnovationMonitor(max(1, int(round(0.2 / ts))), cfg.nis_limit)
        self._course_nis = InnovationMonitor(10, cfg.nis_limit)
        self._outage = 0.0
        self.yaw = self.d1 = self.d2 = 0.0

    def _restart(self):
        """Back to the initial state: a diverged filter (e.g. after inputs at their limits) starts over."""
        latency = self._latency
        self._hardened_init()
        self._latency = latency

    def _hardened_predict(self, u, vx: float, x_pred: np.ndarray, F: np.ndarray) -> None:
        """The prediction blended towards the kinematic one beyond the tires' linear range, and the model's
        sideslip error as process noise."""
        I, cfg, ix, kf, ts = self.In, self.config, self._ix, self.kf, self.Ts
        r_m = u[I.YAW_RATE_M]
        # beyond the tires' linear range the model's sideslip and yaw equations are wrong: the predictions
        # blend towards the kinematic ones (beta' = a_y / v_x - gamma, gamma held) by the linearity gap
        gap = self._trust.linearity.update(vx, r_m - kf.x[ix[St.BG]], u[I.DELTA_M], u[I.AY_M], u[I.MZ_CMD])
        w = self._trust.kinematic_weight(cfg.kinematic_gap)
        b, g = ix[St.BETA], ix[St.GAMMA]
        Q = self._Q.copy()
        # the model's sideslip error (a stiffness that may be 30 % off) as process noise on beta, changing over
        # about a second: the course fixes then weigh it against the model, and P knows what is left
        Q[b, b] += self._trust.model_std(u[I.AY_M]) ** 2 * ts
        if w > 1e-3:
            x0 = kf.x
            F = F.copy()
            x_pred[b] = (1.0 - w) * x_pred[b] + w * (x0[b] + ts * (u[I.AY_M] / vx - x0[g]))
            x_pred[g] = (1.0 - w) * x_pred[g] + w * x0[g]
            F[b] *= 1.0 - w
            F[b, b] += w
            F[b, g] -= w * ts
            F[g] *= 1.0 - w
            F[g, g] += w
            Q[b, b] += w * (gap * gap) * ts           # what the model could not explain, per second
            Q[g, g] += w * (cfg.yaw_acc_std * ts) ** 2
        kf.predict(x_pred, F, Q)

    def _hardened_gyro_update(self, u) -> bool:
        """The yaw rate with the gyro offset, ``r_m = gamma + b_g``; False (and the filter restarted) when its
        innovations are inconsistent: a diverged filter."""
        ix, kf = self._ix, self.kf
        x = kf.x
        r_m = u[self.In.YAW_RATE_M]
        self._yaw_nis.add(kf.update_scalar(r_m - x[ix[St.GAMMA]] - x[ix[St.BG]], self._h_gyro,
                                           self.config.sigma_gyro ** 2))
        if not self._yaw_nis.consistent:
            self._restart()
            self.valid = False
            return False
        return True

    def _hardened_course_update(self, u, vx: float) -> None:
        """The course against ``psi + beta`` of the GPS delay earlier, its noise from the speed and the delay."""
        I, cfg, ix, kf = self.In, self.config, self._ix, self.kf
        r_m = u[I.YAW_RATE_M]
        x = kf.x
        self._course_hist.push(x[ix[St.PSI]] + x[ix[St.BETA]])
        self._latency.push(r_m - x[ix[St.BG]], x[ix[St.BETA]])
        gps_ok = u[I.GPS_VALID] != 0.0
        self._outage = 0.0 if gps_ok else self._outage + self.Ts
        if not (u[I.GPS_FRESH] and gps_ok and vx > cfg.course_speed):
            return
        course = u[I.GPS_COURSE]
        r_course = cfg.sigma_course ** 2 + (cfg.sigma_gps_velocity / vx) ** 2 + \
            self._latency.course_variance(r_m - x[ix[St.BG]])
        if not self._heading_set:            # first fix: psi = c - beta, the stored predictions moved with it
            psi0 = course - x[ix[St.BETA]]
            self._course_hist.correct(psi0 - x[ix[St.PSI]])
            kf.x[ix[St.PSI]] = psi0
            i = ix[St.PSI]
            kf.P[i, :] = kf.P[:, i] = 0.0
            kf.P[i, i] = r_course + kf.P[ix[St.BETA], ix[St.BETA]]
            self._heading_set = True
        else:
            self._latency.add_fix(course, r_m - x[ix[St.BG]])
            predicted = self._course_hist.delayed(self._latency.lag(self.Ts)).item(0)
            before = x[ix[St.PSI]] + x[ix[St.BETA]]
            innovation = math.remainder(course - predicted, 2.0 * math.pi)
            self._course_nis.add(kf.update_scalar(innovation, self._h_course, r_course))
            self._course_hist.correct(kf.x[ix[St.PSI]] + kf.x[ix[St.BETA]] - before)
        kf.x[ix[St.PSI]] = math.remainder(kf.x[ix[St.PSI]], 2.0 * math.pi)

    def _hardened_outputs(self, u, vx: float) -> None:
        """The estimate, with the std inflated by the course innovations' consistency and the kinematic check."""
        I, cfg, ix, kf = self.In, self.config, self._ix, self.kf
        x = kf.x.tolist()
        self.beta, self.bias = x[ix[St.BETA]], x[ix[St.BG]]
        self.yaw_rate = x[ix[St.GAMMA]]
        self.yaw = x[ix[St.PSI]]
        if St.D1 in ix:
            self.d1, self.d2 = x[ix[St.D1]], x[ix[St.D2]]
        i = ix[St.BETA]
        self._trust.check_kinematics(self.beta, vx, self.yaw_rate, u[I.AY_M])
        self.beta_std = math.hypot(math.sqrt(kf.P.item(i, i)) * self._course_nis.inflation(),
                                   self._trust.kinematic_sigma)
        self.vy = vx * math.tan(self.beta)
        self.valid = self._heading_set and self._outage <= cfg.gps_coast and self._course_nis.consistent
