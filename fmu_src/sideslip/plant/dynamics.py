"""The 8-DOF vehicle dynamics as a pure function ``dx/dt = f(x, u, p)``.

Degrees of freedom: longitudinal ``vx``, lateral ``vy``, yaw ``r``, roll ``phi``/``p`` and
the four wheel spins, plus global position/yaw and two lag states for load transfer
(:class:`St`).  :class:`PlantModel` holds the constants of one vehicle and plant
configuration; :meth:`PlantModel.f` is the right-hand side for raw inputs
(:class:`PlantInputs`), :meth:`PlantModel.derivative` the same for inputs prepared once per
communication step (:class:`HeldInputs`), which is what the integrator of
:class:`~sideslip.plant.vehicle.VehiclePlant` calls.  The tire forces come from
:mod:`sideslip.plant.tires` (slip kinematics, friction, Dugoff).

Re-derivation (Pi, Chen, Wang, Zhang 2011, "Design and evaluation of sideslip angle observer
for vehicle stability control", eqs 1-19; the printed eqs 1-4 and 11-14 are garbled)
--------------------------------------------------------------------------------------
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

with ``I_roll = I_xx + m_s h_s^2`` (Table 3 gives I_xx about the sprung CG; about the roll
axis its 750 kg m2 would leave a negative CG inertia).  Eq 2 as printed adds longitudinal
rear forces and eq 4 uses the opposite roll sign of eq 2; eq 1 keeps only one of the two
Coriolis terms.  Eqs 2-4 share the unknowns ``dvy, dr, dp``: their constant 3x3 mass matrix
is inverted once.

Quasi-static load transfer (eqs 11-14, re-derived: the printed signs and subscripts are
inconsistent): per axle, the lateral transfer is the spring/damper roll moment plus the
roll-centre and unsprung contributions,

    dFz_f = (K_f phi + C_f p + (m_s l_rs/l h_ra + m_uf h_uf) ay_f) / t_f,
    Fz_fl/fr = m g cos(theta) l_r/(2 l) - m h_cg ax_f/(2 l) -/+ dFz_f   (rear: + and l_fs, t_r),

where ``ax_f, ay_f`` are the road-frame specific forces (kinematic acceleration minus
gravity) passed through a first-order lag ``tau_load`` (states AXF, AYF).  The lag breaks
the algebraic loop loads -> tire forces -> accelerations -> loads and stands in for the
unmodelled pitch/heave dynamics; with 10 ms it does not change steady-state gains.

Tires: Dugoff (the model of Pi 2011, the default and the papers' tables) or Pacejka's Magic
Formula 5.2 with combined slip (``tire_model``; :mod:`sideslip.plant.tires`), both with the
vehicle's cornering stiffness on the road's friction at the static wheel load.

Low speed: slips use ``max(|R w|, v_min)`` (:func:`~sideslip.plant.tires.theoretical_slip`),
and brake / rolling-resistance torques use ``sat(w) = w / (|w| + omega_eps)`` so that a braked
car comes to rest without the sign of ``w`` chattering.

The in-wheel motors' torque difference ``dT`` (``+-dT`` on the two wheels of their axle) is
an argument: it follows its command through a first-order lag that the integrator solves
exactly.

Wheel-slip control (``slip_max > 0``; off by default, the papers' plant): the brakes' ABS and the in-wheel motors'
inverters take torque off a wheel whose longitudinal slip ``lambda = (R w - v_x) / max(|v_x|, SLIP_CONTROL_SPEED)``
(``v_x`` the wheel's ground speed along its heading) passes ``slip_max`` in the torque's direction, all of it at
twice that (:func:`slip_share`): an idealised, continuous ABS (a real one cycles the pressure around the same slip;
this one acts in forward travel) and the slip limit of a motor drive (in either direction).  Without it the driver's brake locks the wheels on a slippery road and a motor
spins its wheel up or backwards, which no car with stability control allows: a locked or spinning wheel has lost
its side force, and what a yaw-moment controller achieves is then decided by which wheel locks when.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum
from math import atan2, cos, sin, sqrt
from typing import NamedTuple

import numpy as np

from ..constants import GRAVITY
from ..vehicles import VehicleParams
from .tires import dugoff, friction, magic_formula, practical_slip, theoretical_slip

__all__ = ["St", "N_STATES", "PlantInputs", "HeldInputs", "Constants", "Aux", "PlantModel", "DUGOFF", "MAGIC_FORMULA",
           "SLIP_CONTROL_SPEED", "slip_share"]

DUGOFF, MAGIC_FORMULA = 0, 1
"""Values of the plant's ``tire_model`` parameter."""
SLIP_CONTROL_SPEED = 3.0
"""[m/s] the slip control's slip is taken on at least this ground speed: below it the same slip speed ``R w - v_x``
is a smaller slip, so that the control fades out as the car stops (a real ABS switches off at walking speed) and
the wheel mode it adds stays within the sub-step rule's bound."""


def slip_share(v_x: float, omega: float, radius: float, slip_max: float, driving: bool) -> float:
    """Share [0, 1] of a torque that a wheel's slip control lets through (module docstring).

    Parameters
    ----------
    v_x : float
        The wheel's ground speed along its heading [m/s].
    omega, radius : float
        Its spin [rad/s] and rolling radius [m].
    slip_max : float
        Slip beyond which the torque is cut, all of it at twice this (> 0).
    driving : bool
        The torque drives the wheel (else it brakes it).
    """
    den = v_x if v_x > SLIP_CONTROL_SPEED else (-v_x if -v_x > SLIP_CONTROL_SPEED else SLIP_CONTROL_SPEED)
    lam = (radius * omega - v_x) / den
    x = (2.0 * slip_max - lam) / slip_max if driving else (lam + 2.0 * slip_max) / slip_max
    return 0.0 if x <= 0.0 else (1.0 if x >= 1.0 else x)


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


class PlantInputs(NamedTuple):
    """The plant's physical inputs (those of :data:`sideslip.signals.PLANT_INPUTS` but ``Mz_dyc``,
    which reaches the dynamics as the motors' torque difference)."""

    delta_f: float = 0.0     #: front road-wheel angle [rad]
    T_drive: float = 0.0     #: total drive torque [N m]
    T_brake: float = 0.0     #: total brake torque [N m] (negative values count as 0)
    mu: float = 1.0          #: tire-road friction [-]
    bank_angle: float = 0.0  #: road bank angle [rad]
    F_wind_y: float = 0.0    #: external lateral force [N]
    M_wind_z: float = 0.0    #: external yaw moment [N m]


class HeldInputs(NamedTuple):
    """Inputs prepared for the derivative, constant while the inputs are held over a step."""

    cos_delta: float
    sin_delta: float
    drive_front: float       #: drive torque per front wheel [N m]
    drive_rear: float        #: drive torque per rear wheel [N m]
    brake_front: float       #: brake torque per front wheel [N m]
    brake_rear: float        #: brake torque per rear wheel [N m]
    mu: float
    c_alpha_front: float     #: cornering stiffness of a front tire on this friction [N/rad]
    c_alpha_rear: float      #: cornering stiffness of a rear tire [N/rad]
    fz_front: float          #: static load of a front wheel on the bank [N]
    fz_rear: float           #: static load of a rear wheel [N]
    bank_force: float        #: m g sin(theta) [N]
    roll_stiffness: float    #: m_s g h_s cos(theta) - K_f - K_r [N m/rad]
    roll_gravity: float      #: m_s h_s g sin(theta) [N m]
    g_sin_bank: float        #: g sin(theta) [m/s2]
    cos_bank: float
    F_wind_y: float
    M_wind_z: float


class Constants(NamedTuple):
    """Vehicle and configuration constants of the derivative (derived once per plant)."""

    m: float                 #: mass [kg]
    mshs: float              #: m_s h_s [kg m]
    g: float                 #: gravity [m/s2]
    lf: float                #: CG to front axle [m]
    lr: float                #: CG to rear axle [m]
    tf2: float               #: half front track [m]
    tr2: float               #: half rear track [m]
    R: float                 #: rolling radius [m]
    inv_iw: float            #: 1 / wheel spin inertia [1/(kg m2)]
    c_sigma: float           #: longitudinal slip stiffness [N]
    kx: float                #: longitudinal load transfer per specific force, m h_cg / (2 l) [kg]
    kf: float                #: front roll stiffness / track [N/rad / m]
    kr: float                #: rear roll stiffness / track
    cf: float                #: front roll damping / track
    cr: float                #: rear roll damping / track
    lyf: float               #: front lateral transfer per specific force (roll centre + unsprung) [kg]
    lyr: float               #: rear lateral transfer per specific force [kg]
    v_min: float             #: slip regularisation speed [m/s]
    omega_eps: float         #: brake / rolling-resistance regularisation [rad/s]
    a00: float               #: inverse of the (dvy, dr, dp) mass matrix, row-major
    a01: float
    a02: float
    a10: float
    a11: float
    a12: float
    a20: float
    a21: float
    a22: float
    c_phi: float             #: total roll damping [N m s/rad]
    inv_tau: float           #: 1 / load-transfer lag [1/s]
    frr_r: float             #: rolling-resistance coefficient x radius [m]
    drag: float              #: rho / 2 C_d A [kg/m]
    eps_v: float             #: Dugoff velocity effect [s/m]
    motor_front: float       #: 1 when the in-wheel motors sit on the front axle, else 0
    motor_rear: float        #: 1 when they sit on the rear axle, else 0
    slip_max: float          #: wheel-slip control's slip (0: none)


class Aux(NamedTuple):
    """Intermediate quantities of one derivative evaluation (for the plant's outputs)."""

    ax: float                #: longitudinal specific force [m/s2]
    ay_road: float           #: lateral specific force in road axes [m/s2]
    Fy_f: float              #: front-axle lateral force in vehicle axes [N]
    Fy_r: float              #: rear-axle lateral force [N]
    Fz_fl: float
    Fz_fr: float
    Fz_rl: float
    Fz_rr: float
    alpha_fl: float          #: slip angle of each wheel [rad]
    alpha_fr: float
    alpha_rl: float
    alpha_rr: float
    motor_share: float       #: share of the motors' torque difference the slip control lets through [-]


@dataclass(frozen=True, eq=False)
class PlantModel:
    """The dynamics of one vehicle: ``dx/dt = f(x, u, p)`` with ``p`` this object.

    Parameters
    ----------
    vehicle : VehicleParams
    v_min, omega_eps, tau_load : float
        Regularisation speed [m/s], brake regularisation [rad/s] and load-transfer lag [s]
        (:class:`~sideslip.plant.vehicle.PlantConfig`).
    tire_model : int
        :data:`DUGOFF` or :data:`MAGIC_FORMULA` (:mod:`sideslip.plant.tires`).
    slip_max : float
        Wheel-slip control's slip [-] (module docstring; 0: none).
    """

    vehicle: VehicleParams
    v_min: float = 1.0
    omega_eps: float = 0.5
    tau_load: float = 0.01
    tire_model: int = 0
    slip_max: float = 0.0
    k: Constants = field(init=False, repr=False)
    """Constants of :meth:`derivative`."""
    splits: tuple = field(init=False, repr=False)
    """Drive and brake torque shares per wheel: front drive, rear drive, front brake, rear brake."""
    static: tuple = field(init=False, repr=False)
    """Static front and rear wheel loads, m g, m_s h_s g and K_f + K_r (scaled by the bank in :meth:`held`)."""
    mf: tuple | None = field(init=False, repr=False)
    """Magic Formula coefficients of a front and a rear tire (None with Dugoff tires)."""

    def __post_init__(self):
        v, g = self.vehicle, GRAVITY
        l, mshs = v.l, v.m_s * v.h_s
        mass = np.array([[v.m, 0.0, -mshs],
                         [0.0, v.I_zz, -v.I_xz],
                         [-mshs, -v.I_xz, v.I_roll]])
        minv = np.linalg.inv(mass).tolist()
        h_ra = v.h_roll_axis
        front = v.motor_axle == "front"
        k = Constants(
            v.m, mshs, g, v.l_f, v.l_r, 0.5 * v.t_f, 0.5 * v.t_r, v.R_w, 1.0 / v.I_w, v.C_sigma,
            v.m * v.h_cg / (2 * l),
            v.K_phi_f / v.t_f, v.K_phi_r / v.t_r, v.C_phi_f / v.t_f, v.C_phi_r / v.t_r,
            (v.m_s * v.l_rs / l * h_ra + v.m_uf * v.h_uf) / v.t_f,
            (v.m_s * v.l_fs / l * h_ra + v.m_ur * v.h_ur) / v.t_r,
            self.v_min, self.omega_eps, *minv[0], *minv[1], *minv[2],
            v.C_phi_f + v.C_phi_r, 1.0 / self.tau_load,
            v.f_rr * v.R_w, 0.5 * v.rho_air * v.CdA, v.eps_v,
            1.0 if front else 0.0, 0.0 if front else 1.0, self.slip_max)
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "splits", (0.5 * v.drive_split_front, 0.5 * (1.0 - v.drive_split_front),
                                            0.5 * v.brake_split_front, 0.5 * (1.0 - v.brake_split_front)))
        # static wheel loads on a flat road, gravity-roll and roll-stiffness terms (scaled by the bank)
        object.__setattr__(self, "static", (v.m * g * v.l_r / (2 * l), v.m * g * v.l_f / (2 * l), v.m * g,
                                            mshs * g, v.K_phi_f + v.K_phi_r))
        if self.tire_model not in (DUGOFF, MAGIC_FORMULA):
            raise ValueError(f"tire_model must be {DUGOFF} (Dugoff) or {MAGIC_FORMULA} (Magic Formula), got "
                             f"{self.tire_model!r}")
        object.__setattr__(self, "mf", (v.magic_formula("front"), v.magic_formula("rear"))
                           if self.tire_model == MAGIC_FORMULA else None)

    # ------------------------------------------------------------------ inputs
    def held(self, u: PlantInputs, stiffness: tuple[float, float] | None = None) -> HeldInputs:
        """Inputs prepared for :meth:`derivative`.

        Parameters
        ----------
        u : PlantInputs or tuple
            The inputs in :class:`PlantInputs` order.
        stiffness : (float, float), optional
            Per-tire cornering stiffness (front, rear) on ``u.mu`` [N/rad], if the caller
            already has it (default: :meth:`VehicleParams.cornering_stiffness`).
        """
        delta_f, T_drive, T_brake, mu, bank_angle, F_wind_y, M_wind_z = u
        caf, car = stiffness if stiffness is not None else self.vehicle.cornering_stiffness(mu)
        d_f, d_r, b_f, b_r = self.splits
        tb = T_brake if T_brake > 0.0 else 0.0
        fz0f, fz0r, mg, mshs_g, kphi = self.static
        cb, sb = cos(bank_angle), sin(bank_angle)
        # tuple.__new__: the named tuple without its Python-level constructor (this runs every step)
        return tuple.__new__(HeldInputs, (cos(delta_f), sin(delta_f), d_f * T_drive, d_r * T_drive, b_f * tb,
                                          b_r * tb, mu, caf, car, fz0f * cb, fz0r * cb, mg * sb, mshs_g * cb - kphi,
                                          mshs_g * sb, GRAVITY * sb, cb, F_wind_y, M_wind_z))

    # ------------------------------------------------------------------ dynamics
    def f(self, x, u: PlantInputs, motor_dT: float = 0.0) -> tuple:
        """State derivative for the raw inputs ``u`` and the motors' torque difference ``motor_dT`` [N m]."""
        return self.derivative(x, self.held(u), motor_dT)

    def derivative(self, x, held: HeldInputs, motor_dT: float, aux: list | None = None) -> tuple:
        """State derivative (eqs 1-6 re-derived, 7-14) at state ``x`` (:class:`St` order).

        Parameters
        ----------
        x : sequence of float
            State.
        held : HeldInputs
            From :meth:`held`.
        motor_dT : float
            Torque difference of the in-wheel motors [N m].
        aux : list, optional
            When given, the :class:`Aux` values are appended to it.
        """
        (m, mshs, g, lf, lr, tf2, tr2, R, inv_iw, cs, kx, kf, kr, cf, cr, lyf, lyr,
         vmin, weps, a00, a01, a02, a10, a11, a12, a20, a21, a22, cphi, inv_tau,
         frr_r, drag, eps_v, mf, mr, slip_max) = self.k
        (cd, sd, tq_f, tq_r, tb_f, tb_r, mu, caf, car, fz0f, fz0r, mgsb, roll_k, roll_g, gsb, cb,
         fw, mw) = held
        vx, vy, r, phi, p, w1, w2, w3, w4, _, _, psi, axf, ayf = x
        dT = motor_dT

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

        # contact-point velocities in wheel axes (eqs 15-18)
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
        # friction with the velocity effect of eq 7
        if eps_v > 0.0:         # squares as products: libm's pow(x, 2) is not always the rounded x * x
            sl1, sl2, sl3, sl4 = vxt1 - R * w1, vxt2 - R * w2, vxt3 - R * w3, vxt4 - R * w4
            mu1 = friction(mu, eps_v, sqrt(sl1 * sl1 + vyt1 * vyt1))
            mu2 = friction(mu, eps_v, sqrt(sl2 * sl2 + vyt2 * vyt2))
            mu3 = friction(mu, eps_v, sqrt(sl3 * sl3 + vyr * vyr))
            mu4 = friction(mu, eps_v, sqrt(sl4 * sl4 + vyr * vyr))
        else:
            mu1 = mu2 = mu3 = mu4 = mu
        formula = self.mf
        if formula is None:     # Dugoff forces on theoretical slips (eqs 7-10)
            sx1, sy1 = theoretical_slip(vxt1, vyt1, w1, R, vmin)
            sx2, sy2 = theoretical_slip(vxt2, vyt2, w2, R, vmin)
            sx3, sy3 = theoretical_slip(vxt3, vyr, w3, R, vmin)
            sx4, sy4 = theoretical_slip(vxt4, vyr, w4, R, vmin)
            fx1, fy1 = dugoff(mu1 * fz1, cs, caf, sx1, sy1)
            fx2, fy2 = dugoff(mu2 * fz2, cs, caf, sx2, sy2)
            fx3, fy3 = dugoff(mu3 * fz3, cs, car, sx3, sy3)
            fx4, fy4 = dugoff(mu4 * fz4, cs, car, sx4, sy4)
        else:                   # Magic Formula on practical slips
            mf_f, mf_r = formula
            fx1, fy1 = magic_formula(fz1, mu1, cs, caf, *practical_slip(vxt1, vyt1, w1, R, vmin), mf_f)
            fx2, fy2 = magic_formula(fz2, mu2, cs, caf, *practical_slip(vxt2, vyt2, w2, R, vmin), mf_f)
            fx3, fy3 = magic_formula(fz3, mu3, cs, car, *practical_slip(vxt3, vyr, w3, R, vmin), mf_r)
            fx4, fy4 = magic_formula(fz4, mu4, cs, car, *practical_slip(vxt4, vyr, w4, R, vmin), mf_r)

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

        # wheel spin (eq 6) with regularised brake and rolling resistance, sat(w) = w / (|w| + omega_eps)
        # (|w| as a conditional: the builtin abs() call costs more than the rest of the line)
        s1 = w1 / ((w1 if w1 > 0.0 else -w1) + weps)
        s2 = w2 / ((w2 if w2 > 0.0 else -w2) + weps)
        s3 = w3 / ((w3 if w3 > 0.0 else -w3) + weps)
        s4 = w4 / ((w4 if w4 > 0.0 else -w4) + weps)
        # motor torque (+-dT on its axle's right and left wheel) and brake torque per wheel
        m1, m2, m3, m4 = mf * dT, mf * dT, mr * dT, mr * dT
        b1, b2, b3, b4 = tb_f, tb_f, tb_r, tb_r
        share = 1.0
        if slip_max > 0.0:      # wheel-slip control (module docstring): ABS and the motors' slip limit
            b1 *= slip_share(vxt1, w1, R, slip_max, False)
            b2 *= slip_share(vxt2, w2, R, slip_max, False)
            b3 *= slip_share(vxt3, w3, R, slip_max, False)
            b4 *= slip_share(vxt4, w4, R, slip_max, False)
            if dT != 0.0:
                m1 *= slip_share(vxt1, w1, R, slip_max, dT < 0.0)
                m2 *= slip_share(vxt2, w2, R, slip_max, dT > 0.0)
                m3 *= slip_share(vxt3, w3, R, slip_max, dT < 0.0)
                m4 *= slip_share(vxt4, w4, R, slip_max, dT > 0.0)
                share = 0.5 * ((m1 + m2) / (mf * dT) if mf else (m3 + m4) / (mr * dT))
        cpsi, spsi = cos(psi), sin(psi)
        if aux is not None:
            aux.extend((ax_spec, ay_spec, by1 + by2, fy3 + fy4, fz1, fz2, fz3, fz4,
                        atan2(vyt1, abs(vxt1)), atan2(vyt2, abs(vxt2)),
                        atan2(vyr, abs(vxt3)), atan2(vyr, abs(vxt4)), share))
        return (ax_spec + r * vy,
                a_lat - r * vx,
                dr,
                p,
                dp,
                (tq_f - m1 - R * fx1 - (b1 + frr_r * fz1) * s1) * inv_iw,
                (tq_f + m2 - R * fx2 - (b2 + frr_r * fz2) * s2) * inv_iw,
                (tq_r - m3 - R * fx3 - (b3 + frr_r * fz3) * s3) * inv_iw,
                (tq_r + m4 - R * fx4 - (b4 + frr_r * fz4) * s4) * inv_iw,
                vx * cpsi - vy * spsi,
                vx * spsi + vy * cpsi,
                r,
                (ax_spec - axf) * inv_tau,
                (ay_spec - ayf) * inv_tau)
