"""Baseline estimators of Pi 2011 section 3, against which every method is compared.

* :class:`OpenLoopKinematic` - direct integration of the kinematic relation (Pi 2011
  eqs 21-22): ``d(beta)/dt = (a_y + g sin(bank)) / v_x - r``.  Robust to parameters, drifts
  with any sensor bias.
* :class:`LinearBicycleObserver` - the linear single-track model (Pi 2011 eq 20) with the
  yaw rate as measurement, as a time-varying linear Kalman filter on the shared core (the
  Kalman gain plays the role of the Luenberger gain ``G`` and gives ``beta_hat_std``).
  Accurate in the linear range with the right cornering stiffness, wrong beyond it.

What each says of itself goes beyond the paper, which gives estimates only; the estimates are the paper's.
``beta_hat_std`` is truthful: the open-loop integration's grows with the sensor offsets it cannot remove
(``ay_offset_std``, ``yaw_rate_offset_std``), the bicycle filter's adds the vehicle file's stiffness error
(``stiffness_error`` times the rear slip angle) and is inflated by the consistency of its yaw-rate innovations
(:class:`~sideslip.estimators.kalman.InnovationMonitor`: beyond the tires' linear range the measured yaw rate
leaves the model's).  ``valid`` is false while the bicycle filter's innovations are inconsistent (``nis_limit``),
above ``valid_std_max`` of std and for ``valid_hold`` after any break
(:class:`~sideslip.estimators.base.ValidityGate`); the open-loop integration is valid only until its std reaches
``valid_std_max``.  Neither has the inputs of the consistency check of the other estimators
(:class:`~sideslip.estimators.model_checks.ModelConsistency`); ``consistency_check = false`` gives the paper's
baselines as they were: the filter's covariance as the std and valid whenever moving.

Both take the speed from the undriven wheels and the front road-wheel angle from the
steering sensor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from enum import IntEnum

import numpy as np

from ..bicycle import BicycleModel
from ..constants import GRAVITY
from ..params import param
from ..signals import WHEEL_SPEEDS_M
from .base import (Estimator, EstimatorConfig, ValidityGate, input_enum, nis_limit_param, valid_hold_param,
                   valid_std_max_param)
from .discrete import SpeedCache
from .kalman import InnovationMonitor, KalmanFilter

__all__ = ["OpenLoopKinematic", "OpenLoopConfig", "LinearBicycleObserver", "BicycleObserverConfig"]



# ------------------------------------------------------------------------------ open loop
@dataclass(frozen=True)
class OpenLoopConfig(EstimatorConfig):
    """Parameters of :class:`OpenLoopKinematic`."""

    bank: float = param(0.0, "Angle", "Road bank angle assumed in eq 22", ge=-0.5, le=0.5)
    ay_sigma: float = param(0.05, "Acceleration", "Lateral-acceleration noise for the error growth", ge=0, le=10)
    yaw_rate_sigma: float = param(0.002, "AngularVelocity", "Yaw-rate noise for the error growth", ge=0, le=1)
    ay_offset_std: float = param(0.3, "Acceleration", "Uncertainty of the lateral accelerometer's offset and a road's "
                                 "crossfall, for the error growth (0.3: an automotive offset and 2 % crossfall; 0: "
                                 "offset-free on a level road)", ge=0, le=10)
    yaw_rate_offset_std: float = param(0.005, "AngularVelocity", "Uncertainty of the gyro's offset, for the error "
                                       "growth (0: offset-free)", ge=0, le=1)
    valid_std_max: float = valid_std_max_param()


class OpenLoopKinematic(Estimator):
    """Pi 2011 eq 22: ``beta = int((a_y + g phi_r) / v_x - r) dt``.

    ``beta_hat_std`` grows as the integrated sensor noise (a random walk) and, linearly, with the offsets it
    integrates (``ay_offset_std / v_x`` and ``yaw_rate_offset_std`` per second); ``valid`` is false once it exceeds
    ``valid_std_max`` (always, with ``consistency_check`` false).
    """

    config_class = OpenLoopConfig
    needs = "offset-free a_y and yaw rate: it integrates them with no correction, so an offset drifts"
    input_names = ("ay_m", "yaw_rate_m", *WHEEL_SPEEDS_M)
    In = input_enum("In", input_names)

    def _init_filter(self):
        self._var = self._drift_ay = self._drift_r = 0.0

    def _sample(self, u):
        I, cfg, ts = self.In, self.config, self.Ts
        vx = self.speed(u)
        r = u[I.YAW_RATE_M]
        self.yaw_rate, self.vx = r, vx
        if vx < cfg.v_min:                     # eq 22 divides by v_x: hold below v_min
            self.valid = False
            return
        self.beta += ts * ((u[I.AY_M] + GRAVITY * math.sin(cfg.bank)) / vx - r)   # Pi 2011 eq 22
        self.beta = math.remainder(self.beta, 2.0 * math.pi)
        self._var += ts * ts * ((cfg.ay_sigma / vx) ** 2 + cfg.yaw_rate_sigma ** 2)
        self._drift_ay += ts * cfg.ay_offset_std / vx          # a constant offset's error grows, it does not average
        self._drift_r += ts * cfg.yaw_rate_offset_std
        self.beta_std = math.sqrt(self._var + self._drift_ay ** 2 + self._drift_r ** 2)
        self.vy = vx * math.tan(self.beta) if abs(self.beta) < 1.5 else 0.0
        self.valid = self.beta_std <= cfg.valid_std_max or not cfg.consistency_check


# ------------------------------------------------------------------------------ linear bicycle
@dataclass(frozen=True)
class BicycleObserverConfig(EstimatorConfig):
    """Parameters of :class:`LinearBicycleObserver`."""

    mu: float = param(1.0, "FrictionCoefficient", "Friction for which the nominal cornering stiffness is taken",
                      ge=0.05, le=1.5)
    q_beta: float = param(1e-6, "AngleVariance", "Process noise of beta per sample", gt=0, le=1)
    q_r: float = param(1e-5, "AngularVelocityVariance", "Process noise of the yaw rate per sample", gt=0, le=1)
    r_yaw: float = param(2.5e-5, "AngularVelocityVariance", "Yaw-rate measurement noise variance", gt=0, le=1)
    stiffness_error: float = param(0.3, "Dimensionless", "Relative error of the vehicle file's cornering stiffness "
                                   "in the reported std (consistency_check)", ge=0, le=2)
    nis_limit: float = nis_limit_param(10.0)
    valid_std_max: float = valid_std_max_param()
    valid_hold: float = valid_hold_param()


def _steering_model(model: BicycleModel, vx: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq 20's ``A`` and the steering column of ``B`` (the yaw moment is not an input here)."""
    a, b = model.matrices(vx)
    return a, b[:, :1]


class Lin(IntEnum):
    """State of :class:`LinearBicycleObserver`."""
    BETA, R = range(2)


class LinearBicycleObserver(Estimator):
    """Pi 2011 eq 20 as a linear Kalman filter: states ``[beta, r]``, input ``delta_f``, measure ``r``."""

    config_class = BicycleObserverConfig
    needs = "tires in their linear range with the nominal cornering stiffness (no adaptation, no friction limit)"
    input_names = ("delta_m", "yaw_rate_m", *WHEEL_SPEEDS_M)
    In = input_enum("In", input_names)

    def _init_filter(self):
        cfg = self.config
        self.model = BicycleModel.from_vehicle(self.vehicle, cfg.mu, nominal=True)
        self._matrices = SpeedCache(partial(_steering_model, self.model), self.Ts)
        self.kf = KalmanFilter([0.0, 0.0], np.diag([1e-4, 1e-4]))
        self._Q = np.diag([cfg.q_beta, cfg.q_r])
        self._r_yaw = cfg.r_yaw
        checked = cfg.consistency_check
        self._nis = InnovationMonitor(max(1, int(round(1.0 / self.Ts))), cfg.nis_limit) if checked else None
        self._gate = ValidityGate(cfg.valid_std_max, cfg.valid_hold) if checked else None

    def _sample(self, u):
        I = self.In
        vx = self.speed(u)
        self.advance(vx, u[I.DELTA_M], u[I.YAW_RATE_M])

    def advance(self, vx: float, delta: float, r_m: float) -> None:
        """One filter sample with speed ``vx`` [m/s], road-wheel angle ``delta`` [rad] and measured
        yaw rate ``r_m`` [rad/s] (also used by Yoon 2014 for straight driving)."""
        self.vx = vx
        if vx < self.config.v_min:             # the model is singular at v_x -> 0: hold
            self.valid = False
            self.yaw_rate = r_m
            return
        F, FG = self._matrices(vx)              # Pi 2011 eq 20 (sideslip / yaw-rate form), zero-order hold
        kf = self.kf
        kf.predict(FG.dot((kf.x[Lin.BETA], kf.x[Lin.R], delta)), F, self._Q)
        nis = kf.update_state(Lin.R, r_m - kf.x[Lin.R], self._r_yaw)
        self.beta, self.yaw_rate = kf.x.tolist()
        self.beta_std = kf.std(Lin.BETA)
        self.vy = vx * math.tan(self.beta)
        self.valid = True
        if self._nis is not None:                  # what the filter cannot know of its model (module docstring)
            self._nis.add(nis)
            alpha_r = self.vehicle.l_r * self.yaw_rate / vx - self.beta          # the rear slip angle
            self.beta_std = math.hypot(self.beta_std * self._nis.inflation(),
                                       self.config.stiffness_error * abs(alpha_r))
            self.valid = self._nis.consistent
