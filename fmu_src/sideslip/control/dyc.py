"""LQR direct-yaw-moment controller (Nguyen 2012 section IV, Fig. 4).

``N_z = sat(N_ff + N_fb)`` with

* the reference model (eqs 21-22, friction-limited): :mod:`sideslip.control.reference`;
* the feed-forward ``G_ff`` of eq 24: :mod:`sideslip.control.feedforward`;
* the LQR feedback ``g_beta (beta* - beta_hat) + g_gamma (gamma* - gamma)`` of eqs 25-26:
  :mod:`sideslip.control.lqr`; the yaw rate is the gyro's (the contract's ``yaw_rate_m``);
* saturation at what the in-wheel motors can give, ``motor_T_max t / R_w`` (the plant's
  motors apply ``+-dT`` on the two wheels of their axle, each limited to ``motor_T_max``).

No wind-up: the controller has no integrator.  Its only states are the reference lags and the
feed-forward filter, driven by the steering and speed alone, never by the saturated output, so
a saturated command leaves saturation as soon as the unsaturated one does.

Below ``v_min`` the bicycle model (it divides by ``v_x``) says nothing useful: the command is
zero and the references and filter keep running on ``v_min``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..bicycle import BicycleModel
from ..model import SampledModel
from ..params import ParameterError, check, param
from ..signals import CONTROLLER_INPUTS, LQR_OUTPUTS
from ..vehicles import VehicleConfig, VehicleParams
from .feedforward import ScheduledFeedforward
from .lqr import gain_schedule
from .reference import ReferenceModel

__all__ = ["LqrDycConfig", "LqrDycController", "yaw_moment_limit"]


@dataclass(frozen=True)
class LqrDycConfig(VehicleConfig):
    """Parameters of :class:`LqrDycController` (the paper gives no numbers for any of them)."""

    mu: float = param(1.0, "FrictionCoefficient", "Road friction for the yaw-rate limit of the reference and the "
                      "nominal cornering stiffness", ge=0.05, le=1.5)
    Ts_control: float = param(0.001, "Time", "Sample period of the controller", gt=0, le=0.1)
    q_beta: float = param(1.0e10, "AngleWeight", "Weight of the sideslip error in eq 26", gt=0,
                          le=1e16)
    q_gamma: float = param(3.0e8, "AngularVelocityWeight", "Weight of the yaw-rate error in eq 26", gt=0,
                           le=1e16)
    q_N: float = param(1.0, "TorqueWeight", "Weight of the yaw moment in eq 26", gt=0, le=1e16)
    tau_beta: float = param(0.15, "Time", "Lag of the sideslip reference (eq 21)", gt=0, le=5)
    tau_gamma: float = param(0.10, "Time", "Lag of the yaw-rate reference (eq 22)", ge=0, le=5)
    tau_ff: float = param(0.02, "Time", "Low-pass that makes the feed-forward of eq 24 proper", gt=0, le=1)
    feedforward: bool = param(True, "Dimensionless", "Use the feed-forward of eq 24")
    Mz_max: float = param(0.0, "Torque", "Yaw-moment limit (0: what the vehicle's in-wheel motors can give)",
                          ge=0, le=2.0e4)
    v_min: float = param(5.0, "Velocity", "Below this speed the command is zero", gt=0.5, le=30)
    v_max: float = param(70.0, "Velocity", "Top of the speed range of the gain schedule", gt=5, le=150)

    def __post_init__(self):
        check(self)
        if self.v_max <= self.v_min:
            raise ParameterError("v_max", self.v_max, f"> v_min = {self.v_min:g} m/s")


def yaw_moment_limit(vehicle: VehicleParams) -> float:
    """Largest yaw moment the in-wheel motors give, ``motor_T_max t / R_w`` [N m]."""
    track = vehicle.t_f if vehicle.motor_axle == "front" else vehicle.t_r
    return vehicle.motor_T_max * track / vehicle.R_w


class LqrDycController(SampledModel):
    """Reference model + feed-forward + scheduled LQR + saturation (see module docstring).

    Parameters
    ----------
    config : LqrDycConfig, optional
    vehicle : VehicleParams, optional
        Overrides ``config.vehicle``.
    """

    config_class = LqrDycConfig
    input_names = CONTROLLER_INPUTS
    output_names = LQR_OUTPUTS

    def __init__(self, config: LqrDycConfig | None = None, vehicle: VehicleParams | None = None):
        self.config = cfg = config or LqrDycConfig()
        self.vehicle = vehicle or cfg.vehicle_params()
        self.model = BicycleModel.from_vehicle(self.vehicle, cfg.mu, nominal=True)
        self.Ts = cfg.Ts_control
        self.Mz_max = cfg.Mz_max if cfg.Mz_max > 0 else yaw_moment_limit(self.vehicle)
        self.reference = ReferenceModel(self.model, cfg.tau_beta, cfg.tau_gamma, self.Ts, cfg.mu)
        self.gains = gain_schedule(self.model, cfg.q_beta, cfg.q_gamma, cfg.q_N, cfg.v_min, cfg.v_max)
        self.ff = ScheduledFeedforward(self.model, cfg.tau_beta, cfg.tau_ff, self.Ts, cfg.v_min, cfg.v_max)
        self.reset()

    def reset(self) -> None:
        """Zero command, references and filter state."""
        self._reset_clock()
        self._reset_samples()
        self.reference.reset()
        self.ff.reset()
        self.Mz = self.Mz_ff = self.Mz_fb = 0.0
        self._out = (0.0,) * len(self.output_names)

    def _sample(self, delta: float, vx_hat: float, beta_hat: float, yaw_rate: float) -> None:
        cfg = self.config
        v = min(max(vx_hat, cfg.v_min), cfg.v_max)
        beta_ref, gamma_ref = self.reference.step(delta, v)
        n_ff = self.ff.step(delta, v) if cfg.feedforward else 0.0
        g_beta, g_gamma = self.gains(v)
        n_fb = g_beta * (beta_ref - beta_hat) + g_gamma * (gamma_ref - yaw_rate)     # eq 25
        if vx_hat < cfg.v_min:
            n_ff = n_fb = 0.0
        lim = self.Mz_max
        n = n_ff + n_fb
        self.Mz = lim if n > lim else (-lim if n < -lim else n)
        self.Mz_ff, self.Mz_fb = n_ff, n_fb

    def step(self, h: float, delta_m: float, vx_hat: float, beta_hat: float, yaw_rate_m: float) -> None:
        """Advance by ``h`` [s]; runs a sample at every multiple of ``Ts_control``.

        Non-finite inputs give a zero command for the sample (and the references hold).
        """
        t = self._tick(h)
        ran = False
        for _ in range(self._samples_due(t)):
            if math.isfinite(delta_m + vx_hat + beta_hat + yaw_rate_m):
                self._sample(delta_m, vx_hat, beta_hat, yaw_rate_m)
            else:
                self.Mz = self.Mz_ff = self.Mz_fb = 0.0
            ran = True
        if ran:
            self._out = (self.Mz, self.reference.beta, self.reference.gamma, self.Mz_ff, self.Mz_fb)
