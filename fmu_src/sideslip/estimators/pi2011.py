"""Pi, Chen, Wang, Zhang (2011), "Design and evaluation of sideslip angle observer for vehicle stability
control": the sideslip observer with a fuzzy nonlinear factor.

Section 4 of the paper, every block:

1. **Side forces from the sensors** (eqs 23-24): ``F_yfs = (l_r m a_y + I_z dr/dt - M_z)/l``,
   ``F_yrs = (l_f m a_y - I_z dr/dt + M_z)/l`` with the low-pass-filtered yaw acceleration and
   the yaw moment of the stability controller ``M_z`` (input ``Mz_cmd``).
2. **Nonlinear factor** ``alpha`` (eqs 31-32, Tables 1-2): a Mamdani system
   (:mod:`sideslip.estimators.fuzzy`) on the yaw-rate deviation converted to the sideslip
   dimension and the lateral acceleration, with the rule base of Table 2.
3. **Cornering-stiffness identifier** (eqs 33-36) and the **adaptive linear tire model**
   (eqs 25-28); the **weighted side forces** ``F_y = alpha F_ys + (1 - alpha) F_ym`` (eqs 29-30).
4. **EKF** on ``[beta, F_yf, F_yr]`` with first-order tire relaxation (eq 37), inputs
   ``[delta_f, r, v_x]``, measurements ``[F_yf, F_yr, a_y]`` (eq 38), the paper's ``Q`` and ``R``
   as defaults (eqs 39-47, Joseph-form update of the shared core).

Re-derived or chosen where the paper is garbled or silent (each also marked at its line):

* Signs: with ``alpha_f = beta + l_f r/v_x - delta`` (eq 27) the lateral force is
  ``F = -C alpha``; eqs 25-26, 35-36 and ``F_yfss = C_f alpha_f`` of eq 37 drop the minus.
* Eq 37's front relaxation reads ``(-F_yf + F_yfs)``; the text defines ``F_yfss = C_f alpha_f``,
  used as for the rear axle.  The relaxation is integrated exactly (``exp(-T_s/tau)``).
* Eqs 33-34 as printed, ``C^ = alpha C + (1 - alpha) C_s``, would use the sensor secant
  stiffness ``F_ys/alpha`` in the linear region (where ``alpha`` -> 0 makes it ill-conditioned) and
  the high-friction value at the limit, contrary to the text ("tune the cornering stiffness
  according to the degree of the vehicle nonlinear state") and to eqs 29-30: we use
  ``C^ = (1 - alpha) C + alpha C_s``.  ``C_s`` is only formed for ``|alpha_axle| > alpha_min``
  and is bounded to ``[c_min, 1] C``.
* Eq 31: ``(1 + (v_x/v_c)^2)`` (the square is lost in print, cf. eq 32); ``v_c`` uses
  ``l_r/C_f - l_f/C_r``.
* The membership functions of Figs 4-6 are not in the text; ours (parameters ``dr_*``, ``ay_*``):
  yaw-rate deviation ZE flat for ``|dr| <= dr_ze`` and zero beyond ``dr_small``, PS/NS peaking
  at ``dr_small`` and vanishing at ``dr_big``, PB/NB rising from ``dr_small`` to 1 at ``dr_big``;
  lateral acceleration likewise with ``ay_ze``, ``ay_small``, ``ay_big``; output terms S, M,
  L, VL as triangles centred at 0, 0.4, 0.7, 1.0 on ``[-0.25, 1.25]`` (so that S alone gives
  exactly 0 and VL alone exactly 1), clipped to [0, 1].  With these, ``alpha = 0`` while
  ``|dr| <= dr_ze`` and ``|a_y| <= ay_small``.  The defaults were chosen on the three
  ``pi2011_*`` roads; the yaw rate in eq 31 is low-pass filtered (``dr_lpf``) so that its
  noise (0.005 rad/s, about 0.0015 rad of ``dr``) does not wake the nonlinear terms.
* The tire relaxation length ``RL_y`` is not given: 0.5 m (a passenger-car tire).
* Roll (addition, ``roll_compensation``): the SUV rolls about 9 deg/g, so a body-fixed
  accelerometer reads ``g sin(roll)`` (0.7 m/s2 at 0.45 g) on top of the CG acceleration that
  eqs 23-24 and the ``a_y`` measurement assume; it is removed with the vehicle's roll model
  (:mod:`sideslip.estimators.roll`).

Hardened profile (``profile = 1``, the default; ``profile = 0`` is the method above), additions for
vehicles and sensors other than the paper's, each with the failure it answers:

* **The nonlinear factor capped** at ``alpha_max``: at 1 the weighted forces are the sensors' alone
  and nothing ties the sideslip to the tire model; it then integrates ``a_y / v_x - r`` and drifts
  with every offset.  With a model stiffness 30 % off, the yaw-rate deviation of eq 31 reads a
  steady circle as the limit, the factor sits at 1 and the estimate ran away (-97 deg against
  -0.5 deg in a steady turn).
* **The stiffness identifier bounded and slowed**: the secant stiffness of eqs 35-36 is formed with
  the estimate's own slip angle, so a drifting estimate lowers it, which lets the estimate drift
  further; it is kept within ``[c_min_hardened, 1.3]`` of the nominal and low-pass filtered
  (``c_tau``).
* **The sideslip bounded** to ``beta_max`` (a car's sideslip at the limit), where ``valid`` goes false.
* **Noise from the sensors**: ``Q`` and ``R`` of the paper (``1e-13`` rad2 on the sideslip) make the
  filter certain of a model that is 30 % off (the reported std was 400-18,000 times smaller than the
  error); the hardened profile takes ``q_beta_hardened`` and ``r_force_hardened``, inflates the
  reported std by the consistency of the innovations and adds the linear tires' model error; beyond
  their range the sideslip's variance is raised (:class:`~sideslip.estimators.model_trust.ModelTrust`);
  ``valid`` is false while the std exceeds ``valid_std_max``.
* **The kinematics as a check** (:class:`~sideslip.estimators.model_checks.KinematicCheck`,
  ``kinematic_check``): the estimate's departure from ``d(beta)/dt = a_y / v_x - r`` enters the
  reported std, so a slide with both axles saturated, which the linearity test sees late, makes the
  estimate not valid.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ..bicycle import BicycleModel, axle_forces
from ..params import ParameterError, check, param
from ..signals import WHEEL_SPEEDS_M
from .base import input_enum
from .discrete import lowpass
from .fuzzy import Mamdani, Trapezoid
from .kalman import InnovationMonitor, KalmanFilter
from .model_trust import LinearTireConfig, ModelTrust
from .profiles import ProfiledEstimator
from .roll import RollCompensator

__all__ = ["Pi2011Config", "Pi2011FuzzyEKF", "St", "pi_f", "pi_F", "pi_h", "pi_H", "nonlinear_factor_system",
           "TABLE2"]

_INF = float("inf")


class St(IntEnum):
    """State of eq 38."""
    BETA, FYF, FYR = range(3)


# ------------------------------------------------------------------------------ the model
# p = (m, l_f, l_r); u = (delta_f, r, v_x, C_f^, C_r^, e) with e = exp(-T_s / tau)

def pi_f(x, u, p, ts) -> np.ndarray:
    """Eq 37, one sample: Euler for beta, exact first-order lag for the axle forces."""
    beta, fyf, fyr = x
    delta, r, vx, cf, cr, e = u
    m, lf, lr = p
    fss_f = -cf * (beta + lf * r / vx - delta)          # eqs 25, 27 (F = -C alpha)
    fss_r = -cr * (beta - lr * r / vx)                  # eqs 26, 28
    return np.array([beta + ts * ((fyf * math.cos(delta - beta) + fyr * math.cos(beta)) / (m * vx) - r),
                     fss_f + (fyf - fss_f) * e,
                     fss_r + (fyr - fss_r) * e])


def pi_F(x, u, p, ts) -> np.ndarray:
    """Eq 39: Jacobian of :func:`pi_f`."""
    beta, fyf, fyr = x
    delta, r, vx, cf, cr, e = u
    m, _, _ = p
    mv = m * vx
    return np.array([
        [1.0 + ts * (fyf * math.sin(delta - beta) - fyr * math.sin(beta)) / mv, ts * math.cos(delta - beta) / mv,
         ts * math.cos(beta) / mv],
        [-cf * (1.0 - e), e, 0.0],
        [-cr * (1.0 - e), 0.0, e]])


def pi_h(x, delta: float, m: float) -> np.ndarray:
    """Eq 38 measurements: ``[F_yf, F_yr, a_y]`` with ``a_y = (F_yf cos(delta) + F_yr) / m``."""
    _, fyf, fyr = x
    return np.array([fyf, fyr, (fyf * math.cos(delta) + fyr) / m])


def pi_H(delta: float, m: float) -> np.ndarray:
    """Eq 40: Jacobian of :func:`pi_h` (constant in the state)."""
    return np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, math.cos(delta) / m, 1.0 / m]])


TABLE2 = {
    "NB": ("VL", "L", "L", "L", "VL"),
    "NS": ("L", "L", "M", "L", "L"),
    "ZE": ("M", "S", "S", "S", "M"),
    "PS": ("L", "L", "M", "L", "L"),
    "PB": ("VL", "L", "L", "L", "VL"),
}
"""Table 2: yaw-rate deviation term -> output term for lateral acceleration NB, NS, ZE, PS, PB."""


def _terms(ze: float, small: float, big: float) -> dict:
    return {"NB": Trapezoid(-_INF, -_INF, -big, -small), "NS": Trapezoid(-big, -small, -small, -ze),
            "ZE": Trapezoid(-small, -ze, ze, small), "PS": Trapezoid(ze, small, small, big),
            "PB": Trapezoid(small, big, _INF, _INF)}


def nonlinear_factor_system(dr_ze, dr_small, dr_big, ay_ze, ay_small, ay_big) -> Mamdani:
    """The Mamdani system of Section 4.2 with the membership functions described in the module docstring."""
    out = {"S": Trapezoid(-0.25, 0.0, 0.0, 0.25), "M": Trapezoid(0.15, 0.4, 0.4, 0.65),
           "L": Trapezoid(0.45, 0.7, 0.7, 0.95), "VL": Trapezoid(0.75, 1.0, 1.0, 1.25)}
    ay_terms = ("NB", "NS", "ZE", "PS", "PB")
    rules = {(dr, ay): TABLE2[dr][j] for dr in TABLE2 for j, ay in enumerate(ay_terms)}
    # 601 points: a step of 0.0025 puts 0 and 1 on the grid, so S alone gives exactly 0 and VL exactly 1
    return Mamdani(_terms(dr_ze, dr_small, dr_big), _terms(ay_ze, ay_small, ay_big), out, rules, (-0.25, 1.25),
                   points=601)


# ------------------------------------------------------------------------------ configuration
@dataclass(frozen=True)
class Pi2011Config(LinearTireConfig):
    """Parameters of :class:`Pi2011FuzzyEKF` (paper values where it gives them)."""

    mu: float = param(1.0, "FrictionCoefficient", "Friction for which the nominal (high-friction) cornering "
                      "stiffness C_f, C_r of eqs 33-34 is taken", ge=0.05, le=1.5)
    relaxation_length: float = param(0.5, "Length", "Lateral tire relaxation length RL_y of eq 37", gt=0, le=5)
    yaw_acc_lpf: float = param(10.0, "Frequency", "Cut-off of the low-pass filter on dr/dt (eqs 23-24)", gt=0,
                               le=50)
    dr_lpf: float = param(5.0, "Frequency", "Cut-off of the low-pass filter on the yaw rate of eq 31", gt=0, le=50)
    q_beta: float = param(1e-13, "AngleVariance", "Q(1,1): process noise of beta per sample (paper)", gt=0, le=1)
    q_force: float = param(100.0, "ForceVariance", "Q(2,2) = Q(3,3): process noise of the axle forces per sample (paper)", gt=0, le=1e8)
    r_force: float = param(0.1, "ForceVariance", "R(1,1) = R(2,2): variance of the weighted axle forces (paper)", gt=0, le=1e8)
    r_ay: float = param(0.1, "AccelerationVariance", "R(3,3): variance of the lateral acceleration (paper)", gt=0, le=100)
    alpha_min: float = param(0.005, "Angle", "Smallest axle slip angle for the secant stiffness of eqs 35-36",
                             gt=0, le=0.2)
    c_min: float = param(0.05, "Dimensionless", "Lower bound of C_s as a fraction of C (eqs 35-36)", gt=0, le=1)
    roll_compensation: bool = param(True, "Dimensionless", "Remove g sin(roll) from a_y with the vehicle's roll "
                                    "model (an addition, see sideslip.estimators.roll)")
    dr_ze: float = param(0.001, "Angle", "Yaw-rate deviation: ZE is 1 up to here", ge=0, le=1)
    dr_small: float = param(0.003, "Angle", "Yaw-rate deviation: PS/NS peak, ZE reaches 0", gt=0, le=1)
    dr_big: float = param(0.008, "Angle", "Yaw-rate deviation: PB/NB reach 1, PS/NS reach 0", gt=0, le=2)
    ay_ze: float = param(0.5, "Acceleration", "Lateral acceleration: ZE is 1 up to here", ge=0, le=50)
    ay_small: float = param(1.5, "Acceleration", "Lateral acceleration: PS/NS peak, ZE reaches 0", gt=0, le=50)
    ay_big: float = param(3.0, "Acceleration", "Lateral acceleration: PB/NB reach 1", gt=0, le=50)
    # hardened profile (module docstring)
    alpha_max: float = param(0.7, "Dimensionless", "Hardened: largest nonlinear factor", gt=0, le=1)
    c_min_hardened: float = param(0.5, "Dimensionless", "Hardened: lower bound of the identified stiffness as a "
                                  "fraction of the nominal", gt=0, le=1)
    c_tau: float = param(1.0, "Time", "Hardened: time constant of the identified stiffness", gt=0, le=60)
    beta_max: float = param(0.35, "Angle", "Hardened: largest sideslip the estimate may reach", gt=0, le=1.5)
    q_beta_hardened: float = param(2e-7, "AngleVariance", "Hardened: process noise of beta per sample", gt=0, le=1)
    r_force_hardened: float = param(4e5, "ForceVariance", "Hardened: variance of the weighted axle forces", gt=0,
                                    le=1e10)
    r_ay_hardened: float = param(0.05, "AccelerationVariance", "Hardened: variance of the lateral acceleration",
                                 gt=0, le=100)

    def __post_init__(self):
        check(self)
        if not self.dr_ze < self.dr_small < self.dr_big:
            raise ParameterError("dr_small", self.dr_small, f"dr_ze < dr_small < dr_big (dr_ze = {self.dr_ze:g}, "
                                 f"dr_big = {self.dr_big:g})")
        if not self.ay_ze < self.ay_small < self.ay_big:
            raise ParameterError("ay_small", self.ay_small, f"ay_ze < ay_small < ay_big (ay_ze = {self.ay_ze:g}, "
                                 f"ay_big = {self.ay_big:g})")


# ------------------------------------------------------------------------------ the observer
class Pi2011FuzzyEKF(ProfiledEstimator):
    """Pi 2011 fuzzy-weighted EKF (see module docstring)."""

    config_class = Pi2011Config
    input_names = ("ay_m", "yaw_rate_m", "delta_m", *WHEEL_SPEEDS_M, "Mz_cmd")
    extra_outputs = ("nonlinear_factor", "Cf_hat", "Cr_hat", "Fyf_hat", "Fyr_hat")
    In = input_enum("In", input_names)

    def _init_filter(self):
        v, cfg = self.vehicle, self.config
        self._p = (v.m, v.l_f, v.l_r)
        model = BicycleModel.from_vehicle(v, cfg.mu, nominal=True)
        self._C = model.C_f, model.C_r                              # C_f, C_r of eqs 33-34 (axle)
        k_us = model.understeer_gradient                            # eq 32 (l_r/C_f - l_f/C_r)
        self._vc2 = v.l / k_us if k_us > 0 else _INF                # characteristic speed squared
        self.fuzzy = nonlinear_factor_system(cfg.dr_ze, cfg.dr_small, cfg.dr_big, cfg.ay_ze, cfg.ay_small,
                                             cfg.ay_big)
        self.kf = KalmanFilter([0.0, 0.0, 0.0], np.diag([1e-6, 1e4, 1e4]))
        if self.hardened:
            self._hardened_init()
        else:
            self._Q = np.diag([cfg.q_beta, cfg.q_force, cfg.q_force])
            self._R = np.diag([cfg.r_force, cfg.r_force, cfg.r_ay])
        self._r_prev = None
        self._r_dot = 0.0
        self._r_lp = 0.0
        self._roll = RollCompensator(v, self.Ts) if cfg.roll_compensation else None
        self.alpha = 0.0
        self.Cf, self.Cr = self._C
        self._cs = self._C                     # hardened: the low-passed secant stiffness
        self.Fyf = self.Fyr = 0.0

    def _extras(self) -> tuple:
        return (self.alpha, self.Cf, self.Cr, self.Fyf, self.Fyr)

    def _sample(self, u):
        I, cfg, v, ts = self.In, self.config, self.vehicle, self.Ts
        ay, r, delta, mz = u[I.AY_M], u[I.YAW_RATE_M], u[I.DELTA_M], u[I.MZ_CMD]
        if self._roll is not None:
            ay = self._roll(ay)
        vx = self.speed(u)
        if self._r_prev is not None:
            self._r_dot = lowpass(self._r_dot, (r - self._r_prev) / ts, ts, cfg.yaw_acc_lpf)
        self._r_prev = r
        self._r_lp = lowpass(self._r_lp, r, ts, cfg.dr_lpf)
        self.vx, self.yaw_rate = vx, r
        if vx < cfg.v_min:                      # eqs 27-28, 37 divide by v_x: hold
            self.valid = False
            return
        m, lf, lr = self._p
        l = lf + lr
        # 1. side forces from the sensors (eqs 23-24)
        fyf_s, fyr_s = axle_forces(m, v.I_zz, lf, lr, ay, self._r_dot, mz)
        # 2. nonlinear factor (eqs 31-32; Mamdani, Table 2)
        g = 1.0 + vx * vx / self._vc2
        r_ref = vx * delta / (l * g)                                         # eq 32
        r_lp = self._r_lp
        dr = g * (r_ref - r_lp) * l / vx * math.copysign(1.0, r_lp)          # eq 31
        a = min(max(self.fuzzy.evaluate(dr, ay), 0.0), 1.0)
        if self.hardened:
            a = self._hardened_factor(a, vx, r, delta, ay, mz)
        # 3. slip angles of the prior estimate (eqs 27-28), stiffness identifier (eqs 33-36, re-derived)
        beta = float(self.kf.x[St.BETA])
        alpha_f = beta + lf * r / vx - delta
        alpha_r = beta - lr * r / vx
        cf0, cr0 = self._C
        if self.hardened:
            cf_s, cr_s = self._hardened_stiffness(fyf_s, fyr_s, alpha_f, alpha_r)
        else:
            cf_s = min(max(-fyf_s / alpha_f, cfg.c_min * cf0), cf0) if abs(alpha_f) > cfg.alpha_min else cf0
            cr_s = min(max(-fyr_s / alpha_r, cfg.c_min * cr0), cr0) if abs(alpha_r) > cfg.alpha_min else cr0
        cf = (1.0 - a) * cf0 + a * cf_s
        cr = (1.0 - a) * cr0 + a * cr_s
        # adaptive linear tire model (eqs 25-26, F = -C alpha) and the weighted forces (eqs 29-30)
        fyf = a * fyf_s + (1.0 - a) * (-cf * alpha_f)
        fyr = a * fyr_s + (1.0 - a) * (-cr * alpha_r)
        # 4. EKF (eqs 37-47)
        kf, p = self.kf, self._p
        e = math.exp(-ts * vx / cfg.relaxation_length)                            # tau = RL_y / v_x
        if self.hardened:            # beyond the linear range the forces follow the sensors, not the tire model
            e += self._trust.kinematic_weight(cfg.kinematic_gap) * (1.0 - e)
        uk = (delta, r, vx, cf, cr, e)
        xk = kf.x.tolist()
        kf.predict(pi_f(xk, uk, p, ts), pi_F(xk, uk, p, ts), self._Q)
        H = pi_H(delta, m)
        nis = kf.update(np.array([fyf, fyr, ay]) - H.dot(kf.x), H, self._R)
        self.beta, self.Fyf, self.Fyr = kf.x.tolist()
        self.alpha, self.Cf, self.Cr = a, cf, cr
        self.beta_std = kf.std(St.BETA)
        self.valid = True
        if self.hardened:
            self._hardened_uncertainty(nis, vx, r, u[I.AY_M], ay)
        self.vy = vx * math.tan(self.beta)

    # ---------------------------------------------------------------- hardened profile (module docstring)
    def _hardened_init(self) -> None:
        cfg = self.config
        self._Q = np.diag([cfg.q_beta_hardened, cfg.q_force, cfg.q_force])
        self._R = np.diag([cfg.r_force_hardened, cfg.r_force_hardened, cfg.r_ay_hardened])
        self._nis = InnovationMonitor(max(1, int(round(1.0 / self.Ts))), cfg.nis_limit)
        self._trust = ModelTrust(self.vehicle, self.Ts, cfg)

    def _hardened_factor(self, a: float, vx: float, r: float, delta: float, ay: float, mz: float) -> float:
        """The nonlinear factor capped at ``alpha_max``, unless the tires are measured beyond their linear range."""
        cfg = self.config
        self._trust.linearity.update(vx, r, delta, ay, mz)
        return max(min(a, cfg.alpha_max), self._trust.kinematic_weight(cfg.kinematic_gap))

    def _hardened_stiffness(self, fyf_s: float, fyr_s: float, alpha_f: float, alpha_r: float) -> tuple:
        """The secant stiffness bounded to ``[c_min_hardened, 1.3]`` of the nominal and low-passed with ``c_tau``, so
        that a drifting estimate cannot take it along."""
        cfg, (cf0, cr0) = self.config, self._C
        lo, hi, k = cfg.c_min_hardened, 1.3, 1.0 - math.exp(-self.Ts / cfg.c_tau)
        cf_s = min(max(-fyf_s / alpha_f, lo * cf0), hi * cf0) if abs(alpha_f) > cfg.alpha_min else cf0
        cr_s = min(max(-fyr_s / alpha_r, lo * cr0), hi * cr0) if abs(alpha_r) > cfg.alpha_min else cr0
        self._cs = (self._cs[0] + k * (cf_s - self._cs[0]), self._cs[1] + k * (cr_s - self._cs[1]))
        return self._cs

    def _hardened_uncertainty(self, nis: float, vx: float, r: float, ay_m: float, ay: float) -> None:
        """The innovations' consistency and the linear-tire checks in the reported std; a sideslip beyond
        ``beta_max`` held at the bound and not valid."""
        cfg, kf = self.config, self.kf
        self._nis.add(nis, 3)
        self._trust.check_kinematics(self.beta, vx, r, ay_m)
        model_std = self._trust.model_std(ay) + self._trust.kinematic_sigma
        self.beta_std = math.hypot(kf.std(St.BETA) * self._nis.inflation(), model_std)
        if abs(self.beta) > cfg.beta_max:          # beyond a car's sideslip: held at the bound, not valid
            self.beta = kf.x[St.BETA] = math.copysign(cfg.beta_max, self.beta)
            self.valid = False
        self.valid = self.valid and self._nis.consistent
