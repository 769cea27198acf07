"""Estimator + LQR controller in one model: sensor signals in, yaw-moment command out.

The estimator is any of :data:`sideslip.estimators.ESTIMATORS` (named like its FMU), built
for the same vehicle; its ``beta_hat``, ``vx_hat``, ``yaw_rate_hat`` (used with ``yaw_rate_source``
1, the default here) and ``valid`` (as ``beta_valid``) feed :class:`LqrDycController`, and the
controller's previous command is the estimator's ``Mz_cmd`` input
(the estimators that model the in-wheel motors' yaw moment, Nguyen 2012 and Pi 2011, need
it; one sample of delay, as in the separate-FMU closed loop).  An estimator that takes the road
friction as an input (Park 2018) gets the parameter ``mu`` the reference model uses.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..estimators import ESTIMATORS
from ..model import Model
from ..params import build, declared_fields, param
from ..signals import ESTIMATOR_COMMON_OUTPUTS, SENSOR_OUTPUTS
from ..vehicles import VehicleParams
from .dyc import LqrDycConfig, LqrDycController

__all__ = ["StabilityControllerConfig", "StabilityController", "STABILITY_INPUTS"]

STABILITY_INPUTS = tuple(
    [s for s in SENSOR_OUTPUTS if any(s in cls.input_names for cls in ESTIMATORS.values())]
    + sorted({n for cls in ESTIMATORS.values() for n in cls.input_names} - set(SENSOR_OUTPUTS) - {"Mz_cmd", "mu"})
    + ["dyc_enable"])
"""Every input any estimator needs (sensor order first), except the command and the friction,
which it gets internally; then the controller's ``dyc_enable``."""


@dataclass(frozen=True)
class StabilityControllerConfig(LqrDycConfig):
    """:class:`LqrDycConfig` plus the choice of the embedded estimator."""

    estimator: str = param("Park2018Observer", "Dimensionless", "Embedded sideslip estimator (estimator FMU name)",
                           choices=tuple(ESTIMATORS))
    Ts: float = param(0.0, "Time", "Sample period of the embedded estimator (0: its own default)", ge=0, le=1.0)
    estimator_profile: int = param(1, "Dimensionless", "Profile of the embedded estimator: 0 as published, "
                                   "1 hardened (its parameter profile)", choices=(0, 1))
    yaw_rate_source: int = param(1, "Dimensionless", "Yaw rate fed back: 0 the gyro (yaw_rate_m), 1 the "
                                 "embedded estimator's (yaw_rate_hat)", choices=(0, 1))


class StabilityController(Model):
    """An estimator in front of the LQR direct-yaw-moment controller (see module docstring)."""

    config_class = StabilityControllerConfig
    input_names = STABILITY_INPUTS
    output_names = LqrDycController.output_names + ESTIMATOR_COMMON_OUTPUTS

    def __init__(self, config: StabilityControllerConfig | None = None, vehicle: VehicleParams | None = None):
        self.config = cfg = config or StabilityControllerConfig()
        self.vehicle = vehicle or cfg.vehicle_params()
        est_cls = ESTIMATORS[cfg.estimator]
        names = {f.name for f, _ in declared_fields(est_cls.config_class)}
        values = {k: getattr(cfg, k) for k in ("vehicle", "vehicle_overrides", "mu") if k in names}
        if cfg.Ts > 0:
            values["Ts"] = cfg.Ts
        if "profile" in names:
            values["profile"] = cfg.estimator_profile
        self.estimator = est_cls(build(est_cls.config_class, values), vehicle=self.vehicle)
        self.controller = LqrDycController(LqrDycConfig(**{f.name: getattr(cfg, f.name)
                                                           for f, _ in declared_fields(LqrDycConfig)}),
                                           vehicle=self.vehicle)
        pos = {n: i for i, n in enumerate(self.input_names)}
        internal = {"Mz_cmd": -1, "mu": -2}      # -1: the last command, -2: the parameter mu
        self._est_ix = [pos[n] if n in pos else internal[n] for n in self.estimator.input_names]
        self._ctl_ix = (pos["delta_m"], pos["yaw_rate_m"], pos["dyc_enable"])
        self._est_u = [0.0] * len(self._est_ix)
        self._yaw_rate_hat, self._valid = (self.estimator.output_names.index(n) for n in ("yaw_rate_hat", "valid"))
        # the embedded estimator's friction estimate, for friction_source = 1 (-1: it has none)
        self._mu_hat = self.estimator.output_names.index("mu_hat") if "mu_hat" in self.estimator.output_names else -1
        self.reset()

    def reset(self) -> None:
        """Reset estimator and controller."""
        self._reset_clock()
        self.estimator.reset()
        self.controller.reset()
        self._out = self.controller.outputs() + self.estimator.outputs()[:len(ESTIMATOR_COMMON_OUTPUTS)]

    def step(self, h: float, *u) -> None:
        """Advance by ``h`` [s] with the sensor signals ``u`` (``input_names`` order)."""
        self._tick(h)
        est, ctl, eu = self.estimator, self.controller, self._est_u
        mz, mu = ctl.Mz, self.config.mu
        for j, i in enumerate(self._est_ix):
            eu[j] = u[i] if i >= 0 else (mz if i == -1 else mu)
        est.step(h, *eu)
        i_delta, i_gyro, i_enable = self._ctl_ix
        out = est.outputs()
        ctl.step(h, u[i_delta], est.vx, est.beta, u[i_gyro], out[self._yaw_rate_hat], out[self._valid], u[i_enable],
                 out[self._mu_hat] if self._mu_hat >= 0 else 0.0, est.beta_std)
        self._out = ctl.outputs() + out[:len(ESTIMATOR_COMMON_OUTPUTS)]
