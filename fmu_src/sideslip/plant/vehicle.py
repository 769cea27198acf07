"""8-DOF vehicle plant (Pi 2011 section 2, re-derived in ISO 8855 axes) with Dugoff tires.

Degrees of freedom: longitudinal ``vx``, lateral ``vy``, yaw ``r``, roll ``phi``/``p`` and
the four wheel spins, plus global position/yaw and two lag states for load transfer.

Re-derivation (the printed eqs 1-4 and 11-14 of 002_... are garbled)
--------------------------------------------------------------------
Axes x forward, y left, z up; roll ``phi > 0`` lowers the right side (rotation about +x);
the sprung CG sits ``h_s`` above a horizontal roll axis, so rolling moves it by
``-h_s phi`` laterally.  Velocities ``vx, vy`` are those of the reference point O, the
vehicle CG at zero roll.  Newton-Euler for the whole car and the roll of the sprung mass
about the roll axis, small roll angles, bank ``theta`` (left side up, gravity
``(0, -g sin theta, -g cos theta)`` in road axes):

    m (dvx - r vy) + m_s h_s (dr phi + 2 r p) = sum Fx_b - F_aero                 (eq 1)
    m (dvy + r vx) - m_s h_s dp + m_s h_s r^2 phi = sum Fy_b + F_w - m g sin(theta) (eq 2)
    I_zz dr - I_xz dp = l_f Fy_bf - l_r Fy_br + t_f/2 (Fx_bfr - Fx_bfl)
                        + t_r/2 (Fx_brr - Fx_brl) + M_w                         (eq 3)
    I_roll dp - I_xz dr = m_s h_s (dvy + r vx + g sin(theta))
                          + (m_s g h_s cos(theta) - K_f - K_r) phi - (C_f + C_r) p  (eq 4)
    I_w dw_i = T_i - R Fx_i - T_brake,i sat(w_i) - f_rr Fz_i R sat(w_i)            (eq 6)

with ``I_roll = I_xx + m_s h_s^2`` (Table 3 of 002 gives I_xx about the sprung CG; about
the roll axis its 750 kg m2 would leave a negative CG inertia).  Eq 2 as printed adds
longitudinal rear forces and eq 4 uses the opposite roll sign of eq 2; eq 1 keeps only
one of the two Coriolis terms.  Eqs 2-4 share the unknowns ``dvy, dr, dp``: their
constant 3x3 mass matrix is inverted once.

Quasi-static load transfer (eqs 11-14, re-derived: the printed signs and subscripts are
inconsistent): per axle, the lateral transfer is the spring/damper roll moment plus the
roll-centre and unsprung contributions,

    dFz_f = (K_f phi + C_f p + (m_s l_rs/l h_ra + m_uf h_uf) ay_f) / t_f,
    Fz_fl/fr = m g cos(theta) l_r/(2 l) - m h_cg ax_f/(2 l) -/+ dFz_f   (rear: + and l_fs, t_r),

where ``ax_f, ay_f`` are the road-frame specific forces (kinematic acceleration minus
gravity) passed through a first-order lag ``tau_load`` (states AXF, AYF).  The lag breaks
the algebraic loop loads -> tire forces -> accelerations -> loads and stands in for the
unmodelled pitch/heave dynamics; with 10 ms it does not change steady-state gains.

Integration: classical RK4 on the comm step split into ``n`` equal sub-steps chosen per
step from the stiffest mode, the wheel spin ``R^2 C_sigma / (I_w max(|R w|, v_min))``
(plus brake regularisation), so that ``lambda h_sub <= z_max``.  At road speeds one
RK4 step per 1 ms suffices; at walking speed it takes several.  The in-wheel motor
torque follows its first-order lag analytically (exact within a step).

Low speed: slips use ``max(|R w|, v_min)`` (see :mod:`.tires`), and brake / rolling-
resistance torques use ``sat(w) = w / (|w| + omega_eps)`` so that a braked car comes to
rest without the sign of ``w`` chattering.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from math import cos, sin, sqrt, atan2

import numpy as np

from ..model import Model
from ..params import check, param
from ..signals import PLANT_INPUTS, PLANT_OUTPUTS
from ..vehicles import GRAVITY, VehicleParams, load_vehicle
from .tires import dugoff

__all__ = ["St", "PlantConfig", "VehiclePlant"]


class St(IntEnum):
    """Indices of the plant state vector."""

    VX = 0      #: longitudinal velocity of O [m/s]
    VY = 1      #: lateral velocity of O [m/s]
    R = 2       #: yaw rate [rad/s]
    PHI = 3     #: suspension roll angle (relative to the road) [rad]
    P = 4       #: roll rate [rad/s]
    W_FL = 5    #: wheel spin rates [rad/s]
    W_FR = 6
    W_RL = 7
    W_RR = 8
    X = 9       #: global east position [m]
    Y = 10      #: global north position [m]
    PSI = 11    #: yaw, counter-clockwise from east [rad]
    AXF = 12    #: lagged longitudinal specific force for load transfer [m/s2]
    AYF = 13    #: lagged lateral specific force (road axes) for load transfer [m/s2]


N_STATES = len(St)


@dataclass(frozen=True)
class PlantConfig:
    """Parameters of the plant FMU / :class:`VehiclePlant` (besides the vehicle itself)."""

    vehicle: str = param("pi2011_suv", "Dimensionless", "Vehicle parameter set: bundled name or TOML path")
    vehicle_overrides: str = param("", "Dimensionless", "Vehicle parameter overrides, e.g. 'm=2000, I_zz=3800'")
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

    def __post_init__(self):
        check(self)


def _wrap(angle: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    return math.pi - (math.pi - angle) % (2.0 * math.pi)


class VehiclePlant(Model):
    """The 8-DOF vehicle with Dugoff tires, load transfer, in-wheel motors and RK4.

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
        self.vehicle = v = vehicle or load_vehicle(cfg.vehicle, cfg.vehicle_overrides)
        g, l = GRAVITY, v.l
        mshs = v.m_s * v.h_s
        mass = np.array([[v.m, 0.0, -mshs],
                         [0.0, v.I_zz, -v.I_xz],
                         [-mshs, -v.I_xz, v.I_roll]])
        minv = np.linalg.inv(mass).tolist()
        h_ra = v.h_roll_axis
        # constants of the derivative, unpacked as locals (attribute lookups are slow)
        self._k = (
            v.m, mshs, g, v.l_f, v.l_r, 0.5 * v.t_f, 0.5 * v.t_r, v.R_w, 1.0 / v.I_w, v.C_sigma,
            v.m * v.h_cg / (2 * l),
            v.K_phi_f / v.t_f, v.K_phi_r / v.t_r, v.C_phi_f / v.t_f, v.C_phi_r / v.t_r,
            (v.m_s * v.l_rs / l * h_ra + v.m_uf * v.h_uf) / v.t_f,
            (v.m_s * v.l_fs / l * h_ra + v.m_ur * v.h_ur) / v.t_r,
            cfg.v_min, cfg.omega_eps, *minv[0], *minv[1], *minv[2],
            v.C_phi_f + v.C_phi_r, 1.0 / cfg.tau_load,
            v.f_rr * v.R_w, 0.5 * v.rho_air * v.CdA, v.eps_v,
            1.0 if v.motor_axle == "front" else 0.0, 0.0 if v.motor_axle == "front" else 1.0,
        )
        self._splits = (0.5 * v.drive_split_front, 0.5 * (1.0 - v.drive_split_front),
                        0.5 * v.brake_split_front, 0.5 * (1.0 - v.brake_split_front))
        # static wheel loads on a flat road, gravity-roll and roll-stiffness terms (scaled by bank)
        self._static = (v.m * g * v.l_r / (2 * l), v.m * g * v.l_f / (2 * l), v.m * g, mshs * g,
                        v.K_phi_f + v.K_phi_r)
        self._motor_arm = (v.t_f if v.motor_axle == "front" else v.t_r) / v.R_w   # Mz = arm * dT
        self._mu_cache = (None, (v.C_alpha_f, v.C_alpha_r))
        # stiffness of the wheel-spin mode: R^2 C_sigma / (I_w max(|R w|, v_min)) + brake term
        self._stiff = (v.R_w, cfg.v_min, v.R_w * v.R_w * v.C_sigma / v.I_w, 1.0 / (v.I_w * cfg.omega_eps),
                       1.0 / cfg.z_max, cfg.max_substeps)
        self.reset()

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
        self._u = (0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
        self._out = self._evaluate_outputs()

    # ------------------------------------------------------------------ dynamics
    def _held(self, delta_f, T_drive, T_brake, mu, bank_angle, F_wind_y, M_wind_z) -> tuple:
        """Quantities of the derivative that are constant while the inputs are held."""
        v = self.vehicle
        if self._mu_cache[0] != mu:
            self._mu_cache = (mu, v.cornering_stiffness(mu))
        caf, car = self._mu_cache[1]
        d_f, d_r, b_f, b_r = self._splits
        tb = T_brake if T_brake > 0.0 else 0.0
        fz0f, fz0r, mg, mshs_g, kphi = self._static
        cb, sb = cos(bank_angle), sin(bank_angle)
        return (cos(delta_f), sin(delta_f), d_f * T_drive, d_r * T_drive, b_f * tb, b_r * tb, mu, caf, car,
                fz0f * cb, fz0r * cb, mg * sb, mshs_g * cb - kphi, mshs_g * sb, GRAVITY * sb, cb,
                F_wind_y, M_wind_z)

    def _deriv(self, x, held, dT, out=None):
        """State derivative (eqs 1-6 re-derived, 7-14) at state ``x``.

        ``held`` comes from :meth:`_held`; ``dT`` is the motor torque difference [N m].
        """
        (m, mshs, g, lf, lr, tf2, tr2, R, inv_iw, cs, kx, kf, kr, cf, cr, lyf, lyr,
         vmin, weps, a00, a01, a02, a10, a11, a12, a20, a21, a22, cphi, inv_tau,
         frr_r, drag, eps_v, mf, mr) = self._k
        (cd, sd, tq_f, tq_r, tb_f, tb_r, mu, caf, car, fz0f, fz0r, mgsb, roll_k, roll_g, gsb, cb,
         fw, mw) = held
        vx, vy, r, phi, p, w1, w2, w3, w4, _, _, psi, axf, ayf = x

        # quasi-static loads (eqs 11-14 re-derived)
        dfx = kx * axf
        dff = kf * phi + cf * p + lyf * ayf
        dfr = kr * phi + cr * p + lyr * ayf
        fz1 = fz0f - dfx - dff
        fz2 = fz0f - dfx + dff
        fz3 = fz0r + dfx - dfr
        fz4 = fz0r + dfx + dfr
        fz1 = fz1 if fz1 > 0.0 else 0.0
        fz2 = fz2 if fz2 > 0.0 else 0.0
        fz3 = fz3 if fz3 > 0.0 else 0.0
        fz4 = fz4 if fz4 > 0.0 else 0.0

        # contact-point velocities in wheel axes (eqs 15-18) and theoretical slips
        vyf = vy + lf * r
        vyr = vy - lr * r
        vxl = vx - tf2 * r
        vxr = vx + tf2 * r
        vxt1 = vxl * cd + vyf * sd
        vyt1 = vyf * cd - vxl * sd
        vxt2 = vxr * cd + vyf * sd
        vyt2 = vyf * cd - vxr * sd
        vxt3 = vx - tr2 * r
        vxt4 = vx + tr2 * r
        rw1, rw2, rw3, rw4 = R * w1, R * w2, R * w3, R * w4
        d1 = rw1 if rw1 > vmin else (-rw1 if -rw1 > vmin else vmin)
        d2 = rw2 if rw2 > vmin else (-rw2 if -rw2 > vmin else vmin)
        d3 = rw3 if rw3 > vmin else (-rw3 if -rw3 > vmin else vmin)
        d4 = rw4 if rw4 > vmin else (-rw4 if -rw4 > vmin else vmin)
        if eps_v > 0.0:   # velocity effect of eq 7
            s1 = 1.0 - eps_v * sqrt((vxt1 - rw1) ** 2 + vyt1 * vyt1)
            s2 = 1.0 - eps_v * sqrt((vxt2 - rw2) ** 2 + vyt2 * vyt2)
            s3 = 1.0 - eps_v * sqrt((vxt3 - rw3) ** 2 + vyr * vyr)
            s4 = 1.0 - eps_v * sqrt((vxt4 - rw4) ** 2 + vyr * vyr)
            mu1, mu2, mu3, mu4 = (mu * (s if s > 0.1 else 0.1) for s in (s1, s2, s3, s4))
        else:
            mu1 = mu2 = mu3 = mu4 = mu
        fx1, fy1 = dugoff(mu1 * fz1, cs, caf, (vxt1 - rw1) / d1, vyt1 / d1)
        fx2, fy2 = dugoff(mu2 * fz2, cs, caf, (vxt2 - rw2) / d2, vyt2 / d2)
        fx3, fy3 = dugoff(mu3 * fz3, cs, car, (vxt3 - rw3) / d3, vyr / d3)
        fx4, fy4 = dugoff(mu4 * fz4, cs, car, (vxt4 - rw4) / d4, vyr / d4)

        # body-axis forces and moments
        bx1 = fx1 * cd - fy1 * sd
        by1 = fx1 * sd + fy1 * cd
        bx2 = fx2 * cd - fy2 * sd
        by2 = fx2 * sd + fy2 * cd
        fx_sum = bx1 + bx2 + fx3 + fx4 - drag * vx * abs(vx)
        fy_tires = by1 + by2 + fy3 + fy4 + fw
        fy_sum = fy_tires - mgsb - mshs * r * r * phi
        mz_sum = lf * (by1 + by2) - lr * (fy3 + fy4) + tf2 * (bx2 - bx1) + tr2 * (fx4 - fx3) + mw
        roll_rhs = roll_g + roll_k * phi - cphi * p

        # eqs 2-4 solved for (dvy + r vx, dr, dp) with the constant mass matrix
        a_lat = a00 * fy_sum + a01 * mz_sum + a02 * roll_rhs
        dr = a10 * fy_sum + a11 * mz_sum + a12 * roll_rhs
        dp = a20 * fy_sum + a21 * mz_sum + a22 * roll_rhs
        ax_spec = fx_sum / m - (mshs / m) * (dr * phi + 2.0 * r * p)          # eq 1
        ay_spec = a_lat + gsb                                                  # road axes

        # wheel spin (eq 6) with regularised brake and rolling resistance
        s1 = w1 / (abs(w1) + weps)
        s2 = w2 / (abs(w2) + weps)
        s3 = w3 / (abs(w3) + weps)
        s4 = w4 / (abs(w4) + weps)
        cpsi, spsi = cos(psi), sin(psi)
        if out is not None:
            out.extend((ax_spec, ay_spec, by1 + by2, fy3 + fy4, fz1, fz2, fz3, fz4,
                        atan2(vyt1, abs(vxt1)), atan2(vyt2, abs(vxt2)),
                        atan2(vyr, abs(vxt3)), atan2(vyr, abs(vxt4))))
        return (ax_spec + r * vy,
                a_lat - r * vx,
                dr,
                p,
                dp,
                (tq_f - mf * dT - R * fx1 - (tb_f + frr_r * fz1) * s1) * inv_iw,
                (tq_f + mf * dT - R * fx2 - (tb_f + frr_r * fz2) * s2) * inv_iw,
                (tq_r - mr * dT - R * fx3 - (tb_r + frr_r * fz3) * s3) * inv_iw,
                (tq_r + mr * dT - R * fx4 - (tb_r + frr_r * fz4) * s4) * inv_iw,
                vx * cpsi - vy * spsi,
                vx * spsi + vy * cpsi,
                r,
                (ax_spec - axf) * inv_tau,
                (ay_spec - ayf) * inv_tau)

    def _substeps(self, h: float, tb: float) -> int:
        """Number of RK4 sub-steps so that (stiffest wheel mode) x h_sub <= z_max."""
        radius, v_min, c_wheel, c_brake, inv_z, n_max = self._stiff
        x = self.x
        den = radius * min(abs(x[St.W_FL]), abs(x[St.W_FR]), abs(x[St.W_RL]), abs(x[St.W_RR]))
        stiff = c_wheel / (den if den > v_min else v_min) + c_brake * tb
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
        v = self.vehicle
        self._u = (delta_f, T_drive, T_brake, Mz_dyc, mu, bank_angle, F_wind_y, M_wind_z)
        held = self._held(delta_f, T_drive, T_brake, mu, bank_angle, F_wind_y, M_wind_z)
        # in-wheel motors: Mz = (t / R) dT, saturated, first-order lag (exact)
        dT_cmd = Mz_dyc / self._motor_arm
        lim = v.motor_T_max
        dT_cmd = lim if dT_cmd > lim else (-lim if dT_cmd < -lim else dT_cmd)

        n = self._substeps(h, held[4] if held[4] > held[5] else held[5])
        self.n_substeps = n
        hs = h / n
        half = 0.5 * hs
        h6 = hs / 6.0
        tau = v.motor_tau
        decay_half = math.exp(-half / tau) if tau > 0.0 else 0.0
        x = self.x
        dT = self.dT_motor
        deriv = self._deriv
        for _ in range(n):
            dT_mid = dT_cmd + (dT - dT_cmd) * decay_half
            dT_end = dT_cmd + (dT_mid - dT_cmd) * decay_half
            k1 = deriv(x, held, dT)
            k2 = deriv([a + half * b for a, b in zip(x, k1)], held, dT_mid)
            k3 = deriv([a + half * b for a, b in zip(x, k2)], held, dT_mid)
            k4 = deriv([a + hs * b for a, b in zip(x, k3)], held, dT_end)
            x = [a + h6 * (b1 + 2.0 * (b2 + b3) + b4) for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]
            dT = dT_end
        x[St.PSI] = _wrap(x[St.PSI])
        self.x = x
        self.dT_motor = dT
        self._out = self._outputs_at(x, held)

    # ------------------------------------------------------------------ outputs
    def _evaluate_outputs(self) -> tuple:
        """Outputs of the current state for the last held inputs (used after reset)."""
        delta_f, T_drive, T_brake, _, mu, bank, fw, mw = self._u
        return self._outputs_at(self.x, self._held(delta_f, T_drive, T_brake, mu, bank, fw, mw))

    def _outputs_at(self, x, held) -> tuple:
        """Plant outputs at state ``x`` for the held inputs ``held`` (see :meth:`_held`)."""
        extra: list = []
        self._deriv(x, held, self.dT_motor, extra)
        ax_spec, ay_road, fy_f, fy_r, fz1, fz2, fz3, fz4, a1, a2, a3, a4 = extra
        phi = x[St.PHI]
        gsb, cb = held[14], held[15]
        bank = atan2(gsb, GRAVITY * cb)
        # body-fixed accelerometer: road-axis specific force rotated by the suspension roll
        ay_body = cos(phi) * ay_road + sin(phi) * GRAVITY * cb
        vx, vy = x[St.VX], x[St.VY]
        return (vx, vy, x[St.R], atan2(vy, vx), x[St.PSI], bank + phi, x[St.P], ax_spec, ay_body,
                x[St.X], x[St.Y], x[St.W_FL], x[St.W_FR], x[St.W_RL], x[St.W_RR], fy_f, fy_r, fz1, fz2, fz3, fz4,
                0.5 * (a1 + a2), 0.5 * (a3 + a4), self._motor_arm * self.dT_motor)
