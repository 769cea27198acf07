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
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from enum import IntEnum

import numpy as np

from ..bicycle import BicycleModel
from ..params import param
from ..signals import WHEEL_SPEEDS_M
from .base import Estimator, EstimatorConfig, input_enum
from .discrete import SpeedCache, euler, zoh
from .kalman import KalmanFilter

__all__ = ["Nguyen2012Config", "Nguyen2012DACMRKF", "St", "continuous_model", "MODES"]

MODES = {"srkf": 2, "mrkf": 3, "dacmrkf": 5}
"""Mode -> number of states (the leading block of eq 13)."""


class St(IntEnum):
    """State of eq 13."""
    BETA, GAMMA, PSI, D1, D2 = range(5)


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


@dataclass(frozen=True)
class Nguyen2012Config(EstimatorConfig):
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


class Nguyen2012DACMRKF(Estimator):
    """SRKF / MRKF / DACMRKF of Nguyen 2012 (see module docstring)."""

    config_class = Nguyen2012Config
    input_names = ("yaw_rate_m", "delta_m", *WHEEL_SPEEDS_M, "gps_course", "gps_fresh", "gps_valid", "Mz_cmd")
    extra_outputs = ("yaw_hat", "d1_hat", "d2_hat")
    needs = ("an offset-free yaw rate: the method has no gyro-offset state, and an offset b moves beta_hat "
             "at -b rad/s along the direction it cannot observe")
    In = input_enum("In", input_names)

    def _init_filter(self):
        cfg = self.config
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
        return (self.yaw, self.d1, self.d2)

    def _sample(self, u):
        I, cfg = self.In, self.config
        vx = self.speed(u)
        self.vx = vx
        if vx < cfg.v_min:                      # eqs 1-2 divide by v_x: hold
            self.valid = False
            self.yaw_rate = u[I.YAW_RATE_M]
            return
        kf = self.kf
        F, FG = self._matrices(vx)
        xu, n = self._xu, self.n
        xu[:n] = kf.x
        xu[n], xu[n + 1] = u[I.DELTA_M], u[I.MZ_CMD]
        kf.predict(FG.dot(xu), F, self._Q)                                    # eq 14: K_nd h + G_nd u
        kf.update_state(St.GAMMA, u[I.YAW_RATE_M] - kf.x.item(St.GAMMA), self._r_gyro)  # every T_c
        if self.n > St.PSI and u[I.GPS_FRESH] and u[I.GPS_VALID]:          # every T_s: the course
            course = u[I.GPS_COURSE]
            if not self._heading_set:            # first fix: psi = c - beta
                kf.x[St.PSI] = course - kf.x[St.BETA]
                kf.P[St.PSI, :] = kf.P[:, St.PSI] = 0.0
                kf.P[St.PSI, St.PSI] = self._r_course + kf.P[St.BETA, St.BETA]
                self._heading_set = True
            else:
                innovation = math.remainder(course - kf.x[St.PSI] - kf.x[St.BETA], 2.0 * math.pi)
                kf.update_scalar(innovation, self._h_course, self._r_course)
            kf.x[St.PSI] = math.remainder(kf.x[St.PSI], 2.0 * math.pi)
        x = kf.x.tolist()
        self.beta, self.yaw_rate = x[St.BETA], x[St.GAMMA]
        self.beta_std = math.sqrt(kf.P.item(0))         # P[BETA, BETA]
        self.vy = vx * math.tan(self.beta)
        if self.n > St.PSI:
            self.yaw = x[St.PSI]
        if self.n > St.D1:
            self.d1, self.d2 = x[St.D1], x[St.D2]
        self.valid = True
