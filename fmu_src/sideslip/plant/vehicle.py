"""The 8-DOF vehicle plant: the dynamics of :mod:`sideslip.plant.dynamics` integrated by RK4.

:class:`VehiclePlant` is the model of the plant FMU: it holds the state, integrates
``dx/dt = f(x, u, p)`` (:class:`~sideslip.plant.dynamics.PlantModel`) over each communication
step with its inputs held, realises the yaw-moment request ``Mz_dyc`` through the in-wheel
motors, and produces the truth outputs of :data:`sideslip.signals.PLANT_OUTPUTS`.

Integration: classical RK4 on the comm step split into ``n`` equal sub-steps chosen per
step from the stiffest mode, the wheel spin ``R^2 C_sigma / (I_w max(|R w|, v_min))``
(plus brake regularisation and, with wheel-slip control, its gain on the wheel's torque), so that
``lambda h_sub <= z_max``.  At road speeds one
RK4 step per 1 ms suffices; at walking speed it takes several.  The in-wheel motor
torque follows its first-order lag analytically (exact within a step).

The step runs compiled (:mod:`sideslip.plant.kernel`, the same doubles) where this platform's binary is
present and ``compiled`` is 1; this module's Python is the reference it is checked against.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from math import atan2, cos, sin

from ..constants import GRAVITY
from ..model import Model
from ..params import check, param
from ..signals import PLANT_INPUTS, PLANT_OUTPUTS
from ..units import wrap_angle
from ..vehicles import VehicleConfig, VehicleParams
from . import kernel
from .dynamics import MAGIC_FORMULA, N_STATES, SLIP_CONTROL_SPEED, PlantInputs, PlantModel, St
from .tires import MagicFormula

__all__ = ["St", "PlantConfig", "VehiclePlant"]

_WHEEL_SPEEDS = slice(St.W_FL, St.W_RR + 1)
_PSI = St.PSI.value       # IntEnum member lookups cost ~0.1 us each: the hot path indexes with these


@dataclass(frozen=True)
class PlantConfig(VehicleConfig):
    """Parameters of the plant FMU / :class:`VehiclePlant` (besides the vehicle itself)."""

    vx0: float = param(0.0, "Velocity", "Initial longitudinal speed (wheels rolling freely)", ge=0, le=80)
    yaw0: float = param(0.0, "Angle", "Initial yaw angle", ge=-math.pi, le=math.pi)
    X0: float = param(0.0, "Position", "Initial east position", ge=-1e6, le=1e6)
    Y0: float = param(0.0, "Position", "Initial north position", ge=-1e6, le=1e6)
    v_min: float = param(1.0, "Velocity", "Slip regularisation speed (tire acts as a damper below it)",
                         gt=0.05, le=5.0)
    omega_eps: float = param(0.5, "AngularVelocity", "Regularisation of brake and rolling-resistance torque "
                             "near zero wheel speed", gt=0.01, le=10.0)
    tau_load: float = param(0.01, "Time", "Lag of the accelerations used for load transfer", gt=1e-3, le=0.2)
    z_max: float = param(1.0, "Dimensionless", "Largest stiffness x RK4 sub-step (accuracy knob, RK4 is "
                         "stable below 2.78)", gt=0.01, le=2.5)
    max_substeps: int = param(64, "Dimensionless", "Upper bound of RK4 sub-steps per communication step",
                              ge=1, le=10000)
    tire_model: int = param(0, "Dimensionless", "Tire model: 0 Dugoff (the plant of Pi 2011, the papers' tables), "
                            "1 Pacejka Magic Formula 5.2 with combined slip", choices=(0, 1))
    wheel_slip_max: float = param(0.0, "Dimensionless", "Wheel-slip control (ABS on the brakes, slip limit of the "
                                  "in-wheel motors): a wheel's brake or motor torque is cut from this longitudinal "
                                  "slip to twice it (0: none, the wheels lock and spin freely)", ge=0, le=0.5)
    compiled: int = param(1, "Dimensionless", "Step computation: 1 compiled C where the FMU carries it for this "
                          "platform (the same doubles, faster), 0 the pure-Python reference",
                          choices=(0, 1))

    def __post_init__(self):
        check(self)


class VehiclePlant(kernel.CompiledStep, Model):
    """The 8-DOF vehicle with Dugoff or Magic Formula tires, load transfer, in-wheel motors and RK4.

    Parameters
    ----------
    config : PlantConfig, optional
        Plant parameters (defaults if omitted).
    vehicle : VehicleParams, optional
        Vehicle; loaded from ``config.vehicle`` / ``config.vehicle_overrides`` if omitted.

    Notes
    -----
    Call :meth:`step` with the held inputs of a communication step, then read
    :meth:`outputs` (order :data:`sideslip.signals.PLANT_OUTPUTS`).
    """

    input_names = PLANT_INPUTS
    output_names = PLANT_OUTPUTS

    def __init__(self, config: PlantConfig | None = None, vehicle: VehicleParams | None = None):
        self.config = cfg = config or PlantConfig()
        self.vehicle = v = vehicle or cfg.vehicle_params()
        self.dynamics = PlantModel(v, cfg.v_min, cfg.omega_eps, cfg.tau_load, cfg.tire_model, cfg.wheel_slip_max)
        self._motor_arm = (v.t_f if v.motor_axle == "front" else v.t_r) / v.R_w   # Mz = arm * dT
        self._mu_cache = (None, (v.C_alpha_f, v.C_alpha_r))
        self._decay = (None, 0.0)          # (half sub-step, motor-lag decay over it)
        # stiffness of the wheel-spin mode: R^2 C_sigma / (I_w max(|R w|, v_min)) + brake term + the slip
        # control's gain on the wheel's brake and motor torque, R / (I_w slip_max) over the slip's speed (_substeps)
        slip = cfg.wheel_slip_max
        self._stiff = (v.R_w, cfg.v_min, v.R_w * v.R_w * v.C_sigma / v.I_w, 1.0 / (v.I_w * cfg.omega_eps),
                       v.R_w / (v.I_w * slip) if slip > 0.0 else 0.0, 1.0 / cfg.z_max, cfg.max_substeps)
        self._compile()
        self.reset()

    def _compile(self) -> None:
        self._native = (kernel.PlantKernel(self._kernel_constants()).step
                        if self.config.compiled and kernel.available() else None)

    def _kernel_constants(self) -> list[float]:
        """The constants of the compiled step, in the order of the C ``Constants`` struct (plant_kernel.c)."""
        d, v = self.dynamics, self.vehicle
        no_mf = [0.0] * len(MagicFormula._fields)
        mf_front, mf_rear = d.mf if d.tire_model == MAGIC_FORMULA else (no_mf, no_mf)
        return [*d.k, *d.splits, *d.static, *mf_front, *mf_rear, *self._stiff, self._motor_arm, v.motor_T_max,
                v.motor_tau, float(d.tire_model), GRAVITY]

    # ------------------------------------------------------------------ state handling
    def reset(self) -> None:
        """Back to the initial condition of the configuration (rolling freely at ``vx0``)."""
        cfg, v = self.config, self.vehicle
        w0 = cfg.vx0 / v.R_w
        x = [0.0] * N_STATES
        x[St.VX] = cfg.vx0
        x[St.W_FL] = x[St.W_FR] = x[St.W_RL] = x[St.W_RR] = w0
        x[St.X], x[St.Y], x[St.PSI] = cfg.X0, cfg.Y0, cfg.yaw0
        self.x = x
        self._reset_clock()
        self.dT_motor = 0.0          # actual motor torque difference [N m]
        self.n_substeps = 1
        self._u = PlantInputs()
        self._out = self._evaluate_outputs()

    # ------------------------------------------------------------------ dynamics
    def _held(self, u):
        """Held inputs of the derivative for ``u`` (:class:`PlantInputs` order), with the cornering
        stiffness cached per friction value."""
        mu = u[3]
        if self._mu_cache[0] != mu:
            self._mu_cache = (mu, self.vehicle.cornering_stiffness(mu))
        return self.dynamics.held(u, self._mu_cache[1])

    def _substeps(self, h: float, tb: float, t_motor: float) -> int:
        """Number of RK4 sub-steps so that (stiffest wheel mode) x h_sub <= z_max, with the wheel's brake torque
        ``tb`` and motor torque ``t_motor`` [N m] under the slip control (a wheel's ground speed taken as no less
        than half the car's)."""
        radius, v_min, c_wheel, c_brake, c_slip, inv_z, n_max = self._stiff
        w1, w2, w3, w4 = self.x[_WHEEL_SPEEDS]
        den = radius * min(abs(w1), abs(w2), abs(w3), abs(w4))
        v_slip = 0.5 * abs(self.x[0])
        stiff = (c_wheel / (den if den > v_min else v_min) + c_brake * tb
                 + c_slip * (tb + t_motor) / (v_slip if v_slip > SLIP_CONTROL_SPEED else SLIP_CONTROL_SPEED))
        n = int(math.ceil(h * stiff * inv_z - 1e-12))
        return n if 1 <= n <= n_max else (1 if n < 1 else n_max)

    def step(self, h: float, delta_f: float = 0.0, T_drive: float = 0.0, T_brake: float = 0.0,
             Mz_dyc: float = 0.0, mu: float = 1.0, bank_angle: float = 0.0, F_wind_y: float = 0.0,
             M_wind_z: float = 0.0) -> None:
        """Advance by one communication step ``h`` [s] with inputs held over the step.

        Inputs are those of :data:`sideslip.signals.PLANT_INPUTS` (SI units); they must be
        finite (the FMU toolkit sanitises host inputs before they get here).

        Raises
        ------
        ValueError
            If an input is not finite or ``h <= 0``.
        """
        if not math.isfinite(delta_f + T_drive + T_brake + Mz_dyc + mu + bank_angle + F_wind_y + M_wind_z):
            raise ValueError("plant inputs must be finite")
        self._tick(h)
        self._u = u = (delta_f, T_drive, T_brake, mu, bank_angle, F_wind_y, M_wind_z)    # PlantInputs order
        if self._native is not None:
            if self._mu_cache[0] != mu:
                self._mu_cache = (mu, self.vehicle.cornering_stiffness(mu))
            caf, car = self._mu_cache[1]
            self.n_substeps, self.x, self.dT_motor, self._out = self._native(
                self.x, self.dT_motor, (delta_f, T_drive, T_brake, Mz_dyc, mu, bank_angle, F_wind_y, M_wind_z),
                caf, car, h)
            return
        v = self.vehicle
        held = self._held(u)
        # in-wheel motors: Mz = (t / R) dT, saturated, first-order lag (exact)
        dT_cmd = Mz_dyc / self._motor_arm
        lim = v.motor_T_max
        dT_cmd = lim if dT_cmd > lim else (-lim if dT_cmd < -lim else dT_cmd)

        dT = self.dT_motor
        n = self._substeps(h, held.brake_front if held.brake_front > held.brake_rear else held.brake_rear,
                           max(abs(dT), abs(dT_cmd)))
        self.n_substeps = n
        hs = h / n
        half = 0.5 * hs
        h6 = hs / 6.0
        if self._decay[0] != half:
            tau = v.motor_tau
            self._decay = (half, math.exp(-half / tau) if tau > 0.0 else 0.0)
        decay_half = self._decay[1]
        x = self.x
        deriv = self.dynamics.derivative
        for _ in range(n):
            dT_mid = dT_cmd + (dT - dT_cmd) * decay_half
            dT_end = dT_cmd + (dT_mid - dT_cmd) * decay_half
            k1 = deriv(x, held, dT)
            k2 = deriv([a + half * b for a, b in zip(x, k1)], held, dT_mid)
            k3 = deriv([a + half * b for a, b in zip(x, k2)], held, dT_mid)
            k4 = deriv([a + hs * b for a, b in zip(x, k3)], held, dT_end)
            x = [a + h6 * (b1 + 2.0 * (b2 + b3) + b4) for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]
            dT = dT_end
        x[_PSI] = wrap_angle(x[_PSI])
        self.x = x
        self.dT_motor = dT
        self._out = self._outputs_at(x, held)

    # ------------------------------------------------------------------ outputs
    def _evaluate_outputs(self) -> tuple:
        """Outputs of the current state for the last held inputs (used after reset)."""
        return self._outputs_at(self.x, self._held(self._u))

    def _outputs_at(self, x, held) -> tuple:
        """Plant outputs at state ``x`` for the held inputs ``held`` (see :meth:`_held`)."""
        aux: list = []
        self.dynamics.derivative(x, held, self.dT_motor, aux)
        ax_spec, ay_road, fy_f, fy_r, fz1, fz2, fz3, fz4, a1, a2, a3, a4, share = aux
        vx, vy, r, phi, p, w1, w2, w3, w4, X, Y, psi, _, _ = x
        gsb, cb = held.g_sin_bank, held.cos_bank
        bank = atan2(gsb, GRAVITY * cb)
        # body-fixed accelerometer: road-axis specific force rotated by the suspension roll
        ay_body = cos(phi) * ay_road + sin(phi) * GRAVITY * cb
        return (vx, vy, r, atan2(vy, vx), psi, bank + phi, p, ax_spec, ay_body,
                X, Y, w1, w2, w3, w4, fy_f, fy_r, fz1, fz2, fz3, fz4,
                0.5 * (a1 + a2), 0.5 * (a3 + a4), self._motor_arm * self.dT_motor * share)
