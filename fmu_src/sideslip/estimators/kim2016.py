"""Kim, Yoon, Kim (2016), "Estimation of the steering angle based on extended Kalman filter".

An EKF on ``x = [beta, gamma, delta]`` (eq 16) with the speed ``v_x`` as input (eq 17) and
the in-vehicle (ESC) signals ``z = [a_y, gamma]`` as measurements (eq 21).  The steering
sensor is *not* an input: ``delta`` is estimated, so the measured angle can be checked
against it.

* Prediction, eq 18: the linear bicycle model (eqs 7-9) advanced by an Euler step (eq 15)
  for ``beta`` and ``gamma``; the steering model of eq 10, ``delta_k = (l_f + l_r) / v_x
  gamma_{k-1}`` (Ackermann, small sideslip), for ``delta``.  Jacobian eq 19 (printed with the
  ``T`` misplaced on the diagonal; here ``I + T A`` as the derivative of eq 18 gives).
* Measurement, eq 22 re-derived: the printed first row ends in ``C_af delta`` (a force, not an
  acceleration).  From eq 1, ``a_y = v_x (d(beta)/dt + gamma) = (F_yf + F_yr) / m`` with the
  linear tires of eqs 3-4, so
  ``a_y = -(C_af + C_ar)/m beta + (C_ar l_r - C_af l_f)/(m v_x) gamma + C_af/m delta``
  (every term of the printed row divided by ``m``, which eq 23 then differentiates).
* Noise: ``R = diag(sigma_ay^2, sigma_gamma^2)`` from Table 2 (1 m/s2, 0.1 rad/s) by
  default; the paper gives no ``Q`` (eq 20), the defaults below were chosen on the
  ``kim2016_track_*`` scenarios.
* Steering-sensor fault detection (the use the paper proposes in its conclusion): the
  residual ``delta_m - delta_hat`` is low-pass filtered (time constant ``residual_tau``); a
  fault is flagged when its magnitude stays above ``fault_threshold`` for ``fault_confirm``
  seconds, and the flag is latched (cleared by a reset) unless ``fault_latch`` is false.

The cornering stiffnesses are the vehicle's nominal axle values (Table 1 for ``kim2016_asm``).
The accelerometer is not roll-compensated, as in the paper: at the 3 m/s2 of its track the
``g sin(phi)`` error (about 0.2 m/s2) is a fifth of the sensor noise of Table 2.

Hardened profile (``profile = 1``, the default; ``profile = 0`` is the method above), additions for
sensors and vehicles other than the paper's, each with the failure it answers:

* **A gyro offset state** ``b_g`` (``gamma_m = gamma + b_g``, a slow random walk): the method takes the
  yaw rate as the truth of its model, so an offset shifts the yaw rate, the estimated steering and the
  sideslip with them; at speed the offset shows against ``a_y / v_x``.  It is not bounded to a
  datasheet's offset: the state also takes up what the linear model gets wrong in the yaw rate, and
  a 1 deg/s bound (with ``valid`` false at it) left Kim 2016 valid 0 % of a banked circle and 22 % of
  a snow circle on the training set, where the estimate was better than predicting zero.
* **Truthful uncertainty and validity**: the reported std is inflated by the consistency of the
  innovations and adds the linear tires' model error, the sideslip's variance is raised beyond
  their range (:class:`~sideslip.estimators.model_trust.ModelTrust`, with the steering sensor's
  angle); ``valid`` is false while the innovations are inconsistent, while the std exceeds
  ``valid_std_max`` and while the steering residual exceeds ``residual_valid``: beyond the linear
  range the estimated steering absorbs what the linear tires cannot explain, and the residual
  against the steering sensor shows it (on packed snow at the limit it reaches 0.12 rad, in a lane
  change on dry asphalt 0.02).
* **The kinematics as a check** (:class:`~sideslip.estimators.model_checks.KinematicCheck`): where both
  axles saturate together (a sine steer as the friction drops to 0.4) the tire-linearity test and the
  steering residual see little for a second while the car slides by 5 deg; the estimate's departure
  from ``d(beta)/dt = a_y / v_x - r`` enters the reported std (``kinematic_check``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ..bicycle import BicycleModel
from ..params import param
from ..signals import WHEEL_SPEEDS_M
from .base import input_enum
from .kalman import InnovationMonitor, KalmanFilter
from .model_trust import LinearTireConfig, ModelTrust
from .profiles import ProfiledEstimator

__all__ = ["Kim2016Config", "Kim2016SteeringEKF", "St", "kim_f", "kim_F", "kim_h", "kim_H"]



class St(IntEnum):
    """State of eq 16, and the gyro offset of the hardened profile."""
    BETA, GAMMA, DELTA, BG = range(4)


# ------------------------------------------------------------------------------ the model
def kim_F(x, vx: float, model: BicycleModel, ts: float) -> np.ndarray:
    """Eq 19: Jacobian of :func:`kim_f`; ``[[I + T A, T b], [0, l / v_x, 0]]`` with ``A``, ``b`` of eq 9.

    Eq 18 is linear in the state for a given ``v_x``, so this is also its transition matrix.
    """
    a, b = model.matrices(vx)
    F = np.zeros((3, 3))
    F[:St.DELTA, :St.DELTA] = np.eye(2) + ts * a
    F[:St.DELTA, St.DELTA] = ts * b[:, 0]
    F[St.DELTA, St.GAMMA] = model.l / vx                  # eq 10: delta = (l_f + l_r) gamma / v_x
    return F


def kim_f(x, vx: float, model: BicycleModel, ts: float) -> np.ndarray:
    """Eq 18: Euler step (eq 15) of the bicycle model (eq 9) and the steering model (eq 10)."""
    return kim_F(x, vx, model, ts) @ np.asarray(x, dtype=float)


def kim_H(vx: float, model: BicycleModel) -> np.ndarray:
    """Eq 23 (of the re-derived eq 22): rows ``a_y = v_x (d(beta)/dt + gamma)`` and ``gamma``."""
    a, b = model.matrices(vx)
    H = np.zeros((2, 3))
    H[0, :St.DELTA] = vx * a[0]                           # v_x d(beta)/dt ...
    H[0, St.GAMMA] += vx                                  # ... + v_x gamma
    H[0, St.DELTA] = vx * b[0, 0]
    H[1, St.GAMMA] = 1.0
    return H


def kim_h(x, vx: float, model: BicycleModel) -> np.ndarray:
    """Eq 22 re-derived: ``[a_y, gamma]`` predicted from the state (linear in ``x``)."""
    return kim_H(vx, model) @ np.asarray(x, dtype=float)


# ------------------------------------------------------------------------------ configuration
@dataclass(frozen=True)
class Kim2016Config(LinearTireConfig):
    """Parameters of :class:`Kim2016SteeringEKF` (Table 2 values for ``R``)."""

    vehicle: str = param("kim2016_asm", "Dimensionless", "Vehicle parameter set: bundled name or TOML path")
    mu: float = param(1.0, "FrictionCoefficient", "Friction for which the nominal cornering stiffness is taken",
                      ge=0.05, le=1.5)
    q_beta: float = param(1e-7, "AngleVariance", "Q(1,1) of eq 20: sideslip process noise per sample",
                          gt=0, le=1)
    q_gamma: float = param(1e-4, "AngularVelocityVariance", "Q(2,2) of eq 20: yaw-rate process noise per sample",
                           gt=0, le=1)
    q_delta: float = param(1e-5, "AngleVariance", "Q(3,3) of eq 20: steering-model noise per sample",
                           gt=0, le=1)
    sigma_ay: float = param(1.0, "Acceleration", "Lateral-acceleration noise (Table 2), R(1,1) = sigma^2",
                            gt=0, le=20)
    sigma_gamma: float = param(0.1, "AngularVelocity", "Yaw-rate noise (Table 2), R(2,2) = sigma^2", gt=0, le=5)
    residual_tau: float = param(0.5, "Time", "Time constant of the low-pass filter on delta_m - delta_hat",
                                gt=0, le=60)
    fault_threshold: float = param(0.05, "Angle", "Fault when |filtered residual| exceeds this (road-wheel angle)",
                                   gt=0, le=1)
    fault_confirm: float = param(0.3, "Time", "... for at least this long", ge=0, le=60)
    fault_latch: bool = param(True, "Dimensionless", "Keep the fault flag once raised (until reset)")
    # hardened profile (module docstring)
    q_bias: float = param(1e-10, "AngularVelocityVariance", "Hardened: random-walk variance of the gyro offset per "
                          "sample", gt=0, le=1)
    bias_std0: float = param(0.012, "AngularVelocity", "Hardened: initial uncertainty of the gyro offset", gt=0, le=1)
    residual_valid: float = param(0.03, "Angle", "Hardened: steering residual above which the linear model no longer "
                                  "explains the car (the estimate is not valid)", gt=0, le=1)


# ------------------------------------------------------------------------------ the filter
class Kim2016SteeringEKF(ProfiledEstimator):
    """Kim 2016 EKF on ``[beta, gamma, delta]`` with the steering-sensor residual test."""

    config_class = Kim2016Config
    input_names = ("ay_m", "yaw_rate_m", "delta_m", *WHEEL_SPEEDS_M)
    extra_outputs = ("delta_hat", "delta_residual", "delta_fault", "bias_yaw_rate_hat")
    In = input_enum("In", input_names)

    def _init_filter(self):
        cfg = self.config
        self.model = BicycleModel.from_vehicle(self.vehicle, cfg.mu, nominal=True)
        if self.hardened:
            self._hardened_init()
        else:
            self.kf = KalmanFilter([0.0, 0.0, 0.0], np.diag([1e-4, 1e-2, 1e-4]))           # eq 16
            self._Q = np.diag([cfg.q_beta, cfg.q_gamma, cfg.q_delta])
        self._R = np.diag([cfg.sigma_ay ** 2, cfg.sigma_gamma ** 2])
        self.bias = 0.0
        self._lpf = math.exp(-self.Ts / cfg.residual_tau)
        self.delta = self.residual = 0.0
        self.fault = False
        self._over = 0.0                       # time the residual has been over the threshold [s]

    def _extras(self) -> tuple:
        return (self.delta, self.residual, 1.0 if self.fault else 0.0, self.bias)

    def _sample(self, u):
        I, cfg, ts, model = self.In, self.config, self.Ts, self.model
        vx = self.speed(u)
        self.vx = vx
        if vx < cfg.v_min:                     # eqs 7-10 divide by v_x: hold, and restart the residual test
            self.valid = False
            self.yaw_rate = u[I.YAW_RATE_M]
            self._over = 0.0
            return
        kf = self.kf
        F = kim_F(kf.x, vx, model, ts)
        H = kim_H(vx, model)
        if self.hardened:
            F, H = self._hardened_gyro_offset(F, H)
        kf.predict(F @ kf.x, F, self._Q)                   # eq 18 (linear for a given v_x)
        nis = kf.update(np.array([u[I.AY_M], u[I.YAW_RATE_M]]) - H @ kf.x, H, self._R)
        x = kf.x
        self.beta, self.yaw_rate, self.delta = float(x[St.BETA]), float(x[St.GAMMA]), float(x[St.DELTA])
        self.beta_std = kf.std(St.BETA)
        self.vy = vx * math.tan(self.beta)
        self.valid = True
        if self.hardened:
            self._hardened_uncertainty(u, vx, nis)

        # steering-sensor residual test
        self.residual = self._lpf * self.residual + (1.0 - self._lpf) * (u[I.DELTA_M] - self.delta)
        if self.hardened:
            self.valid = self.valid and abs(self.residual) <= cfg.residual_valid
        self._over = self._over + ts if abs(self.residual) > cfg.fault_threshold else 0.0
        if self._over >= cfg.fault_confirm - 1e-9:
            self.fault = True
        elif not cfg.fault_latch:
            self.fault = False

    # ---------------------------------------------------------------- hardened profile (module docstring)
    def _hardened_init(self) -> None:
        cfg = self.config
        self.kf = KalmanFilter([0.0, 0.0, 0.0, 0.0], np.diag([1e-4, 1e-2, 1e-4, cfg.bias_std0 ** 2]))
        self._Q = np.diag([cfg.q_beta, cfg.q_gamma, cfg.q_delta, cfg.q_bias])
        self._nis = InnovationMonitor(max(1, int(round(1.0 / self.Ts))), cfg.nis_limit)
        self._trust = ModelTrust(self.vehicle, self.Ts, cfg)

    @staticmethod
    def _hardened_gyro_offset(F: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The gyro offset as a state: constant in the model, ``r_m = gamma + b_g``."""
        F = np.pad(F, ((0, 1), (0, 1)))
        F[St.BG, St.BG] = 1.0
        H = np.pad(H, ((0, 0), (0, 1)))
        H[1, St.BG] = 1.0
        return F, H

    def _hardened_uncertainty(self, u, vx: float, nis: float) -> None:
        """The innovations' consistency and the linear-tire checks in the reported std; valid while consistent."""
        I, kf = self.In, self.kf
        self.bias = float(kf.x[St.BG])
        self._nis.add(nis, 2)
        # the steering sensor's angle: the estimated one bends to whatever the linear tires need
        r_true = u[I.YAW_RATE_M] - self.bias
        self._trust.check_kinematics(self.beta, vx, r_true, u[I.AY_M])
        model_std = self._trust.apply(kf.P, St.BETA, vx, r_true, u[I.DELTA_M], u[I.AY_M])
        self.beta_std = math.hypot(kf.std(St.BETA) * self._nis.inflation(), model_std + self._trust.kinematic_sigma)
        self.valid = self._nis.consistent
