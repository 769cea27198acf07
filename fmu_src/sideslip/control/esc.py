"""A baseline ESC-style yaw-moment controller: yaw-rate PI plus a sideslip limiter.

What production stability control does in spirit (van Zanten, *Bosch ESP systems: 5 years of
experience*, SAE 2000-01-1633), realised with the in-wheel motors' yaw moment instead of
single-wheel brake pressure, so that the evaluation shows
what the LQR of :mod:`sideslip.control.dyc` buys over it:

* the same friction-limited reference as the LQR (:mod:`sideslip.control.reference`); the
  controller acts only when the yaw rate leaves a dead band around it (``deadband``), as ESC
  stays out of normal driving;
* PI on the yaw-rate error beyond the dead band, ``N_yaw = K_p (e + (1/T_i) int e dt)`` with
  ``K_p = k_p I_zz``: ``k_p`` [1/s] is the yaw damping the controller adds, independent of the
  car.  The integral is :mod:`sideslip.control.base`'s (conditional integration; it bleeds off with ``T_i``
  once the error is inside the dead band);
* the sideslip limiter of :mod:`sideslip.control.base` (``k_beta``, ``beta_limit``), weighted by the
  estimator's ``valid``.

The gains were chosen on FMVSS 126 runs of the SUV (5 s, steer from 1 s: 5A left and 6.5A right on mu 0.8, 6.5A
on mu 0.5), the small car's slalom and the Sonata's brake in a turn on snow of the estimator benchmark's training
set, ``sensors+mismatch``; a stiffer sideslip limiter overshoots (docs, "Design history").  The mu 0.8 runs are
also in the control evaluation, so that the evaluation does not hold the baseline's tuning out.

Both parts then pass the fade-in, bumpless transfer, rate limit and saturation of
:mod:`sideslip.control.base`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..params import param, redefault
from ..signals import ESC_OUTPUTS
from ..vehicles import VehicleParams
from .base import YawMomentConfig, YawMomentController, dead_zone

__all__ = ["EscConfig", "BaselineEsc"]


@dataclass(frozen=True)
class EscConfig(YawMomentConfig):
    """Parameters of :class:`BaselineEsc`."""

    k_p: float = param(4.0, "InverseTime", "Yaw damping the PI adds: K_p = k_p I_zz", ge=0, le=100)
    T_i: float = param(0.5, "Time", "Integral time of the yaw-rate PI", gt=0, le=100)
    deadband: float = redefault(YawMomentConfig, "deadband", 0.035)
    k_beta: float = redefault(YawMomentConfig, "k_beta", 10.0)


class BaselineEsc(YawMomentController):
    """Yaw-rate PI with dead band and a sideslip limiter (see module docstring).

    Parameters
    ----------
    config : EscConfig, optional
    vehicle : VehicleParams, optional
        Overrides ``config.vehicle``.
    """

    config_class = EscConfig
    output_names = ESC_OUTPUTS

    def __init__(self, config: EscConfig | None = None, vehicle: VehicleParams | None = None):
        cfg = config or EscConfig()
        super().__init__(cfg, vehicle)
        self.K_p = cfg.k_p * self.vehicle.I_zz
        self._bleed = math.exp(-self.Ts / cfg.T_i)
        self.reset()

    def _law(self, delta, v, beta_ref, gamma_ref, beta_hat, yaw_rate, w_beta):
        cfg = self.config
        e = dead_zone(gamma_ref - yaw_rate, cfg.deadband)
        return self.K_p * (e + self._integrate(e) / cfg.T_i), self._limiter(beta_hat, w_beta)
