"""Park, Choi, Hyun, Lee (2018), "Integrated observer approach using in-vehicle sensors and GPS for vehicle
state estimation".

The whole method of the paper (Fig. 1), every block fed forward:

1. **Sensor offset compensator** (eqs 2-7): while driving straight (steering angle and rate
   below thresholds, eq 2) the offsets of yaw rate, lateral acceleration, longitudinal
   acceleration (against the low-pass-filtered derivative of GPS speed) and rolling radius
   (against GPS speed, only at steady speed) converge; all are held during spin-out
   ``|acos(v_w / v_s)| > beta_th``.
2. **Bicycle-model EKF** (eqs 8-22) on ``[beta, r, dCf_n, dCr_n]`` with cornering stiffness
   normalised by the axle loads from ``a_x`` (eqs 14-15) and measurements ``[Fyf, Fyr, r]``
   computed from ``a_y`` and the low-pass-filtered yaw acceleration (eq 19).
3. **Kinematic-model EKF** (eqs 25-29) on ``[vx, vy, psi]`` with the undriven-wheel speed and
   the GPS east/north velocity.
4. **Weighting factor** ``K`` (eqs 30-32) from the cornering-stiffness changes and the
   normalised axle forces, divided by the friction ``mu``.
5. **Integrated observer** (eqs 33-36): an EKF on ``[vx, vy, r]`` whose model is the
   ``(1-K)``/``K`` blend of the bicycle and kinematic models and whose pseudo-measurements are
   the ``K``-weighted outputs of the two EKFs.
6. **Roll compensation** (addition, ``roll_compensation``): the paper's ``a_y`` is the lateral
   acceleration of the CG; a body-fixed accelerometer also reads ``g sin(roll)``.  Left in, it
   biases both sub-filters by about 1 deg in steady turns (case 4); the vehicle's roll model
   (:mod:`sideslip.estimators.roll`) removes it.  Off, the method is exactly the paper's.
7. **GPS outage**: while ``gps_valid`` is false the kinematic EKF runs without GPS updates
   (open-loop integration from its last corrected state) and the GPS-based offsets are held;
   it re-converges when fixes return.  The always open-loop estimator of the paper's figures
   (kinematic model integrated from the start, no GPS) is output as ``beta_hat_openloop``.

Re-derived where the text is garbled (each marked at its line): eqs 18/20 drop the minus
signs of ``-(C_f + C_r)/(m v_x)`` and ``-(C_f l_f^2 + C_r l_r^2)/(I_z v_x)`` that follow from
eqs 8-13; eq 14 and eq 32 swap ``l_f`` and ``l_r`` in the static axle loads; eq 35 lacks the
``I + T_s (...)`` of a discrete Jacobian.  The paper leaves the kinematic and integrated EKFs'
covariances, the compensator gains and thresholds and the weighting constants unspecified:
they are parameters with the defaults below, chosen on the scenarios and stated in the docs (modelling choices).

Hardened profile (``profile = 1``, the default; ``profile = 0`` is the method above), additions for
sensors and drives other than the paper's, each with the failure it answers:

* **A bounded, slower offset compensator**: the offsets are held within ``offset_ax_max``,
  ``offset_ay_max``, ``offset_r_max`` (what an automotive sensor's offset can be) and learnt with
  the gain ``k_hardened`` after ``straight_hold`` seconds of straight driving, judged by the yaw rate
  alone (a steering-sensor offset can keep eq 2's steering test from ever holding, or hold it in a
  turn, and the noise of a differentiated steering angle breaks any hold).  Spin-out is judged on
  the low-passed ratio of the radius-compensated wheel speed to the GPS speed with a 2 % margin:
  ``acos(v_w / v_s) > beta_th`` is a 0.5 % speed ratio that GPS noise or a 1 % radius error trips.
  On a real drive the paper's gains swung the offsets over +-1 m/s2.
* **GPS delay**: a fix is compared with the kinematic EKF's velocity of ``gps_delay`` earlier (a
  :class:`~sideslip.estimators.delay.DelayLine` of the sample period), the delay identified while turning
  (:class:`~sideslip.estimators.delay.CourseDelay`): 0.1 s of latency at 4 m/s2 of lateral
  acceleration is 0.4 m/s of lateral velocity.
* **Truthful uncertainty and validity**: the integrated observer's covariance rests on fixed
  pseudo-measurement noise; the hardened std is the weighting of the sub-filters' own,
  ``(1 - K)^2 sigma_bic^2 + K^2 sigma_kin^2``, the bicycle sub-filter's covering its stiffness states
  (its sideslip variance raised beyond the tires' linear range,
  :class:`~sideslip.estimators.model_trust.ModelTrust`) and the kinematic one's inflated by the
  consistency of the GPS innovations, plus the output's departure from the kinematics
  ``d(beta)/dt = a_y / v_x - r`` (:class:`~sideslip.estimators.model_checks.KinematicCheck`,
  ``kinematic_check``); ``valid`` is false while the GPS is out longer than ``gps_coast``, while
  those innovations are inconsistent and while the std exceeds ``valid_std_max``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ..bicycle import axle_forces
from ..constants import GRAVITY
from ..params import param
from ..signals import WHEEL_SPEEDS_M
from ..units import wrap_angle
from .base import beta_std, input_enum
from .discrete import lowpass
from .delay import CourseDelay, DelayLine
from .kalman import InnovationMonitor, KalmanFilter
from .model_trust import LinearTireConfig, ModelTrust
from .profiles import ProfiledEstimator
from .roll import RollCompensator

__all__ = ["Park2018Config", "Park2018Observer", "Bic", "Kin", "Intg", "bicycle_f", "bicycle_F", "bicycle_h", "bicycle_H",
           "kinematic_f", "kinematic_F", "kinematic_h", "kinematic_H", "integrated_f", "integrated_F",
           "weighting_factor"]



class Bic(IntEnum):
    """State of the bicycle-model EKF (eq 16)."""
    BETA, R, DCF, DCR = range(4)


class Kin(IntEnum):
    """State of the kinematic-model EKF (eq 25)."""
    VX, VY, PSI = range(3)


class Intg(IntEnum):
    """State of the integrated observer (eq 33)."""
    VX, VY, R = range(3)


# ------------------------------------------------------------------------------ the models
# p = (m, I_z, l_f, l_r); bicycle input u = (F_zf, F_zr, delta_f, v_x, C_f0n, C_r0n)

def bicycle_f(x, u, p, ts) -> np.ndarray:
    """Bicycle-model prediction, Park 2018 eq 18 (re-derived signs, see module docstring)."""
    beta, r, dcf, dcr = x
    fzf, fzr, delta, vx, cf0, cr0 = u
    m, iz, lf, lr = p
    cf, cr = (cf0 + dcf) * fzf, (cr0 + dcr) * fzr          # eqs 14-15: C = (C_0n + dC_n) F_z
    alpha_f = beta + lf * r / vx - delta                      # eq 10
    alpha_r = beta - lr * r / vx                              # eq 11
    dbeta = (-cf * alpha_f - cr * alpha_r) / (m * vx) - r     # eqs 8, 12, 13
    dr = (-cf * alpha_f * lf + cr * alpha_r * lr) / iz        # eqs 9, 12, 13
    return np.array([beta + ts * dbeta, r + ts * dr, dcf, dcr])


def bicycle_F(x, u, p, ts) -> np.ndarray:
    """Jacobian of :func:`bicycle_f` (eq 20 re-derived)."""
    beta, r, dcf, dcr = x
    fzf, fzr, delta, vx, cf0, cr0 = u
    m, iz, lf, lr = p
    cf, cr = (cf0 + dcf) * fzf, (cr0 + dcr) * fzr
    alpha_f = beta + lf * r / vx - delta
    alpha_r = beta - lr * r / vx
    return np.array([
        [1 - ts * (cf + cr) / (m * vx), ts * ((cr * lr - cf * lf) / (m * vx * vx) - 1),
         -ts * fzf * alpha_f / (m * vx), -ts * fzr * alpha_r / (m * vx)],
        [ts * (cr * lr - cf * lf) / iz, 1 - ts * (cf * lf * lf + cr * lr * lr) / (iz * vx),
         -ts * fzf * lf * alpha_f / iz, ts * fzr * lr * alpha_r / iz],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0]])


def bicycle_h(x, u, p) -> np.ndarray:
    """Measurement model, eq 19: ``[-C_f alpha_f, -C_r alpha_r, r]``."""
    beta, r, dcf, dcr = x
    fzf, fzr, delta, vx, cf0, cr0 = u
    _, _, lf, lr = p
    return np.array([-(cf0 + dcf) * fzf * (beta + lf * r / vx - delta),
                     -(cr0 + dcr) * fzr * (beta - lr * r / vx), r])


def bicycle_H(x, u, p) -> np.ndarray:
    """Jacobian of :func:`bicycle_h` (eq 21)."""
    beta, r, dcf, dcr = x
    fzf, fzr, delta, vx, cf0, cr0 = u
    _, _, lf, lr = p
    cf, cr = (cf0 + dcf) * fzf, (cr0 + dcr) * fzr
    return np.array([[-cf, -cf * lf / vx, -fzf * (beta + lf * r / vx - delta), 0.0],
                     [-cr, cr * lr / vx, 0.0, -fzr * (beta - lr * r / vx)],
                     [0.0, 1.0, 0.0, 0.0]])


def kinematic_f(x, u, ts) -> np.ndarray:
    """Kinematic prediction, eq 26; ``u = (a_x, a_y, r)``."""
    vx, vy, psi = x
    ax, ay, r = u
    return np.array([vx + ts * (r * vy + ax), vy + ts * (-r * vx + ay), psi + ts * r])


def kinematic_F(x, u, ts) -> np.ndarray:
    """Jacobian of :func:`kinematic_f`, eq 28."""
    r = u[2]
    return np.array([[1.0, ts * r, 0.0], [-ts * r, 1.0, 0.0], [0.0, 0.0, 1.0]])


def kinematic_h(x) -> np.ndarray:
    """Measurement model, eq 27: ``[v_w, v_e, v_n]`` (yaw counter-clockwise from east)."""
    vx, vy, psi = x
    c, s = math.cos(psi), math.sin(psi)
    return np.array([vx, vx * c - vy * s, vx * s + vy * c])


def kinematic_H(x) -> np.ndarray:
    """Jacobian of :func:`kinematic_h`, eq 29."""
    vx, vy, psi = x
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[1.0, 0.0, 0.0], [c, -s, -vx * s - vy * c], [s, c, vx * c - vy * s]])


def integrated_f(x, u, p, ts) -> np.ndarray:
    """Integrated-observer prediction, eq 33; ``u = (a_x, a_y, delta_f, C_f, C_r, K)``."""
    vx, vy, r = x
    ax, ay, delta, cf, cr, k = u
    m, iz, lf, lr = p
    b = 1.0 - k
    dvy_bic = -(cf + cr) / (m * vx) * vy + ((cr * lr - cf * lf) / (m * vx) - vx) * r + cf / m * delta
    dr_bic = (cr * lr - cf * lf) / (iz * vx) * vy - (cf * lf * lf + cr * lr * lr) / (iz * vx) * r + cf * lf / iz * delta
    return np.array([vx + ts * k * (r * vy + ax),
                     vy + ts * (b * dvy_bic + k * (-r * vx + ay)),
                     r + ts * b * dr_bic])


def integrated_F(x, u, p, ts) -> np.ndarray:
    """Jacobian of :func:`integrated_f` (eq 35 re-derived as ``I + T_s df/dx``)."""
    vx, vy, r = x
    ax, ay, delta, cf, cr, k = u
    m, iz, lf, lr = p
    b = 1.0 - k
    e, g = cr * lr - cf * lf, cf * lf * lf + cr * lr * lr
    return np.array([
        [1.0, ts * k * r, ts * k * vy],
        [ts * (b * ((cf + cr) * vy / (m * vx * vx) - (e / (m * vx * vx) + 1.0) * r) - k * r),
         1.0 - ts * b * (cf + cr) / (m * vx), ts * (b * (e / (m * vx) - vx) - k * vx)],
        [ts * b * (-e * vy + g * r) / (iz * vx * vx), ts * b * e / (iz * vx), 1.0 - ts * b * g / (iz * vx)]])


def weighting_factor(dcf, dcr, nf, nr, mu, tau_f, eps_f, tau_r, eps_r) -> float:
    """Eqs 30-31: ``K = max(|Fyf/Fzf| K_f, |Fyr/Fzr| K_r) / mu`` in [0, 1], with
    ``K_i = sat((|dC_i,n| - tau_i + eps_i) / (2 eps_i))``.

    ``dcf``, ``dcr`` are passed relative to the nominal ``C_0n`` and ``tau``, ``eps`` are
    fractions of it: the paper predetermines ``C_0n`` per friction level (19.5 /rad on dry
    asphalt, 2.4 /rad on snow for the Sonata), so absolute thresholds would make ``K``
    unreachable on snow; relative ones keep its sensitivity, the intent of dividing by mu.
    """
    kf = min(max((abs(dcf) - tau_f + eps_f) / (2.0 * eps_f), 0.0), 1.0)
    kr = min(max((abs(dcr) - tau_r + eps_r) / (2.0 * eps_r), 0.0), 1.0)
    return min(max(max(abs(nf) * kf, abs(nr) * kr) / mu, 0.0), 1.0)


# ------------------------------------------------------------------------------ configuration
@dataclass(frozen=True)
class Park2018Config(LinearTireConfig):
    """Parameters of :class:`Park2018Observer` (paper values where it gives them)."""

    vehicle: str = param("park2018_sonata", "Dimensionless", "Vehicle parameter set: bundled name or TOML path")
    mu_fixed: float = param(1.0, "FrictionCoefficient", "Friction used when use_mu_input is false", ge=0.05, le=1.5)
    use_mu_input: bool = param(True, "Dimensionless", "Take the friction from the input 'mu' (the paper assumes "
                               "an upstream friction estimator)")
    # offset compensator (eqs 2-7)
    delta_th: float = param(0.004, "Angle", "Straight-driving threshold on the road-wheel angle (eq 2)", gt=0, le=0.2)
    delta_rate_th: float = param(0.02, "AngularVelocity", "Straight-driving threshold on the steering rate (eq 2)",
                                 gt=0, le=2)
    vs_rate_th: float = param(0.5, "Acceleration", "Steady-speed threshold of the radius compensator (eq 7)",
                              gt=0, le=5)
    beta_th: float = param(0.1, "Angle", "Spin-out threshold: offsets held while |acos(v_w/v_s)| exceeds it",
                           gt=0, le=1.5)
    k_r: float = param(1.5, "InverseTime", "Gain of the yaw-rate offset compensator (eq 3)", gt=0, le=50)
    k_y: float = param(1.5, "InverseTime", "Gain of the lateral-acceleration offset compensator (eq 4)", gt=0, le=50)
    k_x: float = param(1.5, "InverseTime", "Gain of the longitudinal-acceleration offset compensator (eq 5)",
                       gt=0, le=50)
    k_w: float = param(1.5, "InverseTime", "Gain of the rolling-radius compensator (eq 7)", gt=0, le=50)
    vs_lpf: float = param(0.5, "Frequency", "Cut-off of the low-pass filter on d(v_s)/dt (eq 5)", gt=0, le=50)
    settle_time: float = param(2.0, "Time", "The kinematic EKF starts once the compensator has run this long "
                               "(or after 2.5 x this time)", ge=0, le=60)
    # bicycle-model EKF (eqs 16-22): the paper's Q_bic and R_bic
    q_bic_beta: float = param(3.5e-6, "AngleVariance", "Q_bic(1,1): process noise of beta per sample (paper)", gt=0, le=1)
    q_bic_r: float = param(8e-5, "AngularVelocityVariance", "Q_bic(2,2): process noise of the yaw rate per sample (paper)", gt=0, le=1)
    q_bic_dc: float = param(3.0, "NormalisedStiffnessVariance", "Q_bic(3,3) = Q_bic(4,4): process noise of dCf_n, dCr_n per sample (paper)", gt=0, le=100)
    r_bic_fyf: float = param(3.2e4, "ForceVariance", "R_bic(1,1): variance of the front axle force measurement (paper)", gt=0, le=1e9)
    r_bic_fyr: float = param(6.94e4, "ForceVariance", "R_bic(2,2): variance of the rear axle force measurement (paper)", gt=0, le=1e9)
    r_bic_r: float = param(5.8e-6, "AngularVelocityVariance", "R_bic(3,3): variance of the yaw-rate measurement (paper)", gt=0, le=1)
    dc_max: float = param(0.0, "Dimensionless", "Upper bound of dC_n as a fraction of C_0n (the slope only "
                          "drops beyond the linear range, Fig. 3)", ge=0, le=2)
    yaw_acc_lpf: float = param(15.0, "Frequency", "Cut-off of the low-pass filter on the yaw acceleration (eq 19)",
                               gt=0, le=50)
    # kinematic-model EKF (eqs 25-29): not given in the paper
    q_kin_v: float = param(4e-6, "VelocityVariance", "Process noise of vx and vy per sample", gt=0, le=1)
    q_kin_psi: float = param(1e-7, "AngleVariance", "Process noise of the heading per sample", gt=0, le=1)
    r_kin_vw: float = param(4e-3, "VelocityVariance", "Wheel-speed measurement variance", gt=0, le=10)
    r_kin_gps: float = param(3e-3, "VelocityVariance", "GPS velocity measurement variance", gt=0, le=10)
    # weighting factor (eqs 30-31): not given in the paper; relative to C_0n (see weighting_factor)
    tau_f: float = param(0.06, "Dimensionless", "tau_f of eq 30, as a fraction of C_f0n", gt=0, le=1)
    eps_f: float = param(0.04, "Dimensionless", "epsilon_f of eq 30, as a fraction of C_f0n", gt=0, le=1)
    tau_r: float = param(0.06, "Dimensionless", "tau_r of eq 30, as a fraction of C_r0n", gt=0, le=1)
    eps_r: float = param(0.04, "Dimensionless", "epsilon_r of eq 30, as a fraction of C_r0n", gt=0, le=1)
    # integrated observer (eqs 33-36): not given in the paper
    q_int_v: float = param(2e-4, "VelocityVariance", "Process noise of vx and vy per sample", gt=0, le=1)
    q_int_r: float = param(1e-5, "AngularVelocityVariance", "Process noise of the yaw rate per sample", gt=0, le=1)
    r_int_vx: float = param(4e-3, "VelocityVariance", "Variance of the vx pseudo-measurement", gt=0, le=10)
    r_int_vy: float = param(2e-3, "VelocityVariance", "Variance of the vy pseudo-measurement", gt=0, le=10)
    r_int_r: float = param(5.8e-6, "AngularVelocityVariance", "Variance of the yaw-rate measurement", gt=0, le=1)
    heading_speed: float = param(2.0, "Velocity", "GPS speed above which the heading is initialised from the course",
                                 gt=0.5, le=30)
    heading_std0: float = param(0.02, "Angle", "Initial heading uncertainty besides the course noise", gt=0, le=1)
    roll_compensation: bool = param(True, "Dimensionless", "Remove g sin(roll) from a_y with the vehicle's roll model "
                                    "(an addition to the paper, see module docstring)")
    # hardened profile (module docstring)
    k_hardened: float = param(0.3, "InverseTime", "Hardened: gain of the offset compensator", gt=0, le=50)
    straight_hold: float = param(1.0, "Time", "Hardened: straight driving needed before the offsets adapt", ge=0,
                                 le=60)
    r_straight: float = param(0.02, "AngularVelocity", "Hardened: yaw rate below which the car drives straight",
                              gt=0, le=1)
    offset_ax_max: float = param(0.5, "Acceleration", "Hardened: largest a_x offset", gt=0, le=10)
    offset_ay_max: float = param(0.6, "Acceleration", "Hardened: largest a_y offset (a bank's gravity included)", gt=0,
                                 le=10)
    offset_r_max: float = param(0.035, "AngularVelocity", "Hardened: largest yaw-rate offset", gt=0, le=1)
    gps_delay: float = param(0.0, "Time", "Hardened: GPS delay used until one is identified", ge=0, le=0.5)
    identify_delay: bool = param(True, "Dimensionless", "Hardened: identify the GPS delay while turning")
    gps_coast: float = param(10.0, "Time", "Hardened: GPS outage after which the estimate is not valid", gt=0, le=600)


# ------------------------------------------------------------------------------ the observer
class Park2018Observer(ProfiledEstimator):
    """Park 2018 integrated observer (see module docstring)."""

    config_class = Park2018Config
    input_names = ("ax_m", "ay_m", "yaw_rate_m", "delta_m", *WHEEL_SPEEDS_M, "gps_ve", "gps_vn", "gps_speed",
                   "gps_fresh", "gps_valid", "mu")
    extra_outputs = ("yaw_hat", "Cf_hat", "Cr_hat", "weight_K", "offset_ax", "offset_ay", "offset_yaw_rate",
                     "offset_radius", "beta_hat_bicycle", "beta_hat_kinematic", "beta_hat_openloop")
    In = input_enum("In", input_names)

    def _init_filter(self):
        v, cfg = self.vehicle, self.config
        self._p = (v.m, v.I_zz, v.l_f, v.l_r)
        self._fz_static = (v.m * GRAVITY * v.l_r / v.l, v.m * GRAVITY * v.l_f / v.l)
        # offsets (eqs 3-7): corrections added to the raw signals
        self.b_r = self.b_y = self.b_x = self.b_R = 0.0
        self._delta_prev = None
        self._delta_rate = 0.0
        self._vs_prev = None              # (t, v_s) of the last fix
        self._vs_rate = 0.0
        self._ax_lp = 0.0                 # a_x,m through the same low-pass as d(v_s)/dt
        self._r_prev = None
        self._r_dot = 0.0
        self.bic = KalmanFilter([0.0, 0.0, 0.0, 0.0], np.diag([1e-4, 1e-4, 1.0, 1.0]))
        self._Q_bic = np.diag([cfg.q_bic_beta, cfg.q_bic_r, cfg.q_bic_dc, cfg.q_bic_dc])
        self._R_bic = np.diag([cfg.r_bic_fyf, cfg.r_bic_fyr, cfg.r_bic_r])
        self.kin = None                   # created at the first GPS fix fast enough for a heading
        self._Q_kin = np.diag([cfg.q_kin_v, cfg.q_kin_v, cfg.q_kin_psi])
        self._R_gps = np.diag([cfg.r_kin_gps, cfg.r_kin_gps])
        self._h_vw = np.array([1.0, 0.0, 0.0])          # eq 27: v_w measures v_x
        self.intg = None                  # created at the first valid sample
        self._Q_int = np.diag([cfg.q_int_v, cfg.q_int_v, cfg.q_int_r])
        self._R_int = np.diag([cfg.r_int_vx, cfg.r_int_vy, cfg.r_int_r])
        self._H_int = np.eye(3)
        self._vy_ol = 0.0
        self._settled = 0.0                   # time the compensator has been active [s]
        self._roll = RollCompensator(v, self.Ts)
        self.K = 0.0
        self.Cf = self.Cr = 0.0
        self.yaw = 0.0
        self.beta_bic = self.beta_kin = self.beta_ol = 0.0
        self.delay = cfg.gps_delay
        if self.hardened:
            self._hardened_init()

    def _extras(self) -> tuple:
        return (wrap_angle(self.yaw), self.Cf, self.Cr, self.K, self.b_x, self.b_y, self.b_r, self.b_R,
                self.beta_bic, self.beta_kin, self.beta_ol)

    # ---------------------------------------------------------------- one sample
    def _sample(self, u):
        I, cfg, v, ts = self.In, self.config, self.vehicle, self.Ts
        ax_m, ay_m, r_m, delta = u[I.AX_M], u[I.AY_M], u[I.YAW_RATE_M], u[I.DELTA_M]
        vw_m = self.speed(u)
        gps_ok = u[I.GPS_VALID] != 0.0
        fresh = gps_ok and u[I.GPS_FRESH] != 0.0
        vs = u[I.GPS_SPEED]
        mu = u[I.MU] if cfg.use_mu_input else cfg.mu_fixed
        mu = min(max(mu, 0.05), 1.5)
        self._condition(delta, ax_m, vs, gps_ok, fresh)
        steady = self._compensate_offsets(ay_m, r_m, delta, vw_m, vs, gps_ok)
        r = r_m + self.b_r
        ay = ay_m + self.b_y
        if cfg.roll_compensation:
            ay = self._roll(ay)
        ax = ax_m + self.b_x
        vw = vw_m + vw_m / v.R_w * self.b_R                                                    # eq 6
        self.yaw_rate = r

        # yaw acceleration for the axle forces (eq 19), low-pass filtered
        if self._r_prev is not None:
            self._r_dot = lowpass(self._r_dot, (r - self._r_prev) / ts, ts, cfg.yaw_acc_lpf)
        self._r_prev = r

        if vw < cfg.v_min:                     # bicycle model singular at v_x -> 0: hold everything
            self.valid = False
            self.vx = vw
            return

        # axle loads (eqs 14-15 re-derived: front static load m g l_r / l) and forces (eq 19)
        m, iz, lf, lr = self._p
        l = lf + lr
        fzf = m * (GRAVITY * lr - v.h_cg * ax) / l
        fzr = m * (GRAVITY * lf + v.h_cg * ax) / l
        fyf, fyr = axle_forces(m, iz, lf, lr, ay, self._r_dot)
        cf0_axle, cr0_axle = v.nominal_cornering_stiffness(mu)
        cf0, cr0 = cf0_axle / self._fz_static[0], cr0_axle / self._fz_static[1]   # C_0n for this mu

        dcf, dcr = self._bicycle_ekf((fzf, fzr, delta, vw, cf0, cr0), fyf, fyr, r, ay, steady)
        vy_bic = vw * math.tan(self.beta_bic)
        kin = self._kinematic_ekf(u, fresh, vs, (ax, ay, r), vw, vy_bic)
        vx_kin, vy_kin = kin.x.tolist()[:2] if kin is not None else (vw, vy_bic)

        # open-loop estimator of the figures: kinematic model, no GPS, v_x from the wheels
        self._vy_ol += ts * (-r * vw + ay)
        self.beta_ol = math.atan2(self._vy_ol, vw)

        # weighting factor (eqs 30-32; eq 32 re-derived like eqs 14 and 19)
        nf, nr = fyf / fzf, fyr / fzr
        self.K = weighting_factor(dcf / cf0, dcr / cr0, nf, nr, mu, cfg.tau_f, cfg.eps_f, cfg.tau_r,
                                  cfg.eps_r) if kin is not None else 0.0
        self._integrated_observer((ax, ay, delta, self.Cf, self.Cr, self.K), vw, vx_kin, vy_bic, vy_kin, r)
        if self.hardened:
            self._hardened_uncertainty(kin, gps_ok, vx_kin, vy_kin, r, ay_m)

    def _condition(self, delta: float, ax_m: float, vs: float, gps_ok: bool, fresh: bool) -> None:
        """Signal conditioning: the steering rate and the GPS acceleration ``d(v_s)/dt`` (eq 5), and ``a_x,m``
        through the same low-pass."""
        cfg, ts, t = self.config, self.Ts, self.t
        if self._delta_prev is not None:
            self._delta_rate = lowpass(self._delta_rate, (delta - self._delta_prev) / ts, ts, 5.0)
        self._delta_prev = delta
        if fresh:
            if self._vs_prev is not None and t > self._vs_prev[0]:
                dt = t - self._vs_prev[0]
                self._vs_rate = lowpass(self._vs_rate, (vs - self._vs_prev[1]) / dt, dt, cfg.vs_lpf)
            self._vs_prev = (t, vs)
        elif not gps_ok:
            self._vs_prev = None
        self._ax_lp = lowpass(self._ax_lp, ax_m, ts, cfg.vs_lpf)

    def _compensate_offsets(self, ay_m: float, r_m: float, delta: float, vw_m: float, vs: float,
                            gps_ok: bool) -> bool:
        """The sensor offset compensator (eqs 2-7); returns whether the car drives straight and does not spin
        (the offsets adapted)."""
        cfg, v, ts = self.config, self.vehicle, self.Ts
        if self.hardened:
            straight, spin = self._hardened_straight(r_m, vw_m, vs, gps_ok)
            gains = (cfg.k_hardened,) * 4
        else:
            straight = abs(delta) <= cfg.delta_th and abs(self._delta_rate) <= cfg.delta_rate_th      # eq 2
            spin = gps_ok and vs > cfg.v_min and abs(math.acos(min(max(vw_m / vs, -1.0), 1.0))) > cfg.beta_th
            gains = (cfg.k_r, cfg.k_y, cfg.k_x, cfg.k_w)
        if not straight or spin:
            return False
        k_r, k_y, k_x, k_w = gains
        self._settled += ts
        self.b_r += ts * (-k_r * (self.b_r + r_m))                                         # eq 3
        self.b_y += ts * (-k_y * (self.b_y + ay_m))                                        # eq 4
        if gps_ok:
            # eq 5, with a_x,m through the same low-pass as d(v_s)/dt so that their lags cancel
            self.b_x += ts * (-k_x * (self.b_x - (self._vs_rate - self._ax_lp)))
            if abs(self._vs_rate) <= cfg.vs_rate_th and vw_m > cfg.v_min:                  # eps_w of eq 7
                self.b_R += ts * (-k_w * (self.b_R - (vs / vw_m - 1.0) * v.R_w))           # eq 7
        if self.hardened:
            self._hardened_bound_offsets()
        return True

    def _bicycle_ekf(self, ub: tuple, fyf: float, fyr: float, r: float, ay: float, steady: bool) -> tuple:
        """The bicycle-model EKF (eqs 16-22) with the inputs ``ub = (F_zf, F_zr, delta_f, v_x, C_f0n, C_r0n)`` and
        the measurements ``[F_yf, F_yr, r]``; returns the bounded ``dC_f,n``, ``dC_r,n``."""
        cfg, ts, bic, p = self.config, self.Ts, self.bic, self._p
        fzf, fzr, delta, vw, cf0, cr0 = ub
        xb = bic.x.tolist()                    # the models compute on Python floats (cheaper than numpy scalars)
        bic.predict(bicycle_f(xb, ub, p, ts), bicycle_F(xb, ub, p, ts), self._Q_bic)
        xb = bic.x.tolist()
        bic.update(np.array([fyf, fyr, r]) - bicycle_h(xb, ub, p), bicycle_H(xb, ub, p), self._R_bic)
        if self.hardened:
            self._trust.apply(bic.P, Bic.BETA, vw, r, delta, ay)     # its stiffness states carry the rest
        beta_bic, _, dcf, dcr = bic.x.tolist()
        if steady and abs(ay) < 0.5:           # steady straight driving: dC_n reset (Section 6.2.2)
            dcf = dcr = 0.0
        # dC_n is the drop of the slope as a tire leaves its linear range (Fig. 3): bounded to
        # [-(1 - c_min) C_0n, dc_max C_0n]; the upper bound also stops the drift along the direction
        # that [beta, dCf, dCr] leave unobservable in a steady turn
        dcf = min(max(dcf, -0.9 * cf0), cfg.dc_max * cf0)
        dcr = min(max(dcr, -0.9 * cr0), cfg.dc_max * cr0)
        bic.x[Bic.DCF], bic.x[Bic.DCR] = dcf, dcr
        self.beta_bic = beta_bic
        self.Cf, self.Cr = (cf0 + dcf) * fzf, (cr0 + dcr) * fzr
        return dcf, dcr

    def _kinematic_ekf(self, u, fresh: bool, vs: float, uk: tuple, vw: float, vy_bic: float) -> KalmanFilter | None:
        """The kinematic-model EKF (eqs 25-29) with ``uk = (a_x, a_y, r)``, started at the first GPS fix fast enough
        for a heading; open loop while the GPS is out.  Returns the filter (None before it starts)."""
        I, cfg, ts = self.In, self.config, self.Ts
        kin = self.kin
        settled = self._settled >= cfg.settle_time or self.t >= 2.5 * cfg.settle_time
        if kin is None and fresh and vs > cfg.heading_speed and settled:
            # heading from the GPS course minus the bicycle sideslip; its uncertainty is the course
            # noise sigma_v / v_s plus heading_std0 (sideslip error, gyro offset not yet converged)
            course = math.atan2(u[I.GPS_VN], u[I.GPS_VE])
            var_psi = cfg.r_kin_gps / (vs * vs) + cfg.heading_std0 ** 2
            kin = self.kin = KalmanFilter([vw, vy_bic, course - self.beta_bic],
                                          np.diag([cfg.r_kin_vw, cfg.r_kin_gps, var_psi]))
        if kin is None:
            return None
        r = uk[2]
        xk = kin.x.tolist()
        kin.predict(kinematic_f(xk, uk, ts), kinematic_F(xk, uk, ts), self._Q_kin)
        kin.update_scalar(vw - kin.x[Kin.VX], self._h_vw, cfg.r_kin_vw)
        if self.hardened:
            self._kin_hist.push(kinematic_h(kin.x.tolist())[1:])
            self._course_delay.push(r)
        if fresh:
            z = np.array([u[I.GPS_VE], u[I.GPS_VN]])
            if self.hardened:
                self._hardened_fix(kin, z, r, vs)
            else:
                xk = kin.x.tolist()
                kin.update(z - kinematic_h(xk)[1:], kinematic_H(xk)[1:], self._R_gps)
        kin.x[Kin.PSI] = math.remainder(kin.x[Kin.PSI], 2.0 * math.pi)
        vx_kin, vy_kin, self.yaw = kin.x.tolist()
        self.beta_kin = math.atan2(vy_kin, vx_kin)
        return kin

    def _integrated_observer(self, ui: tuple, vw: float, vx_kin: float, vy_bic: float, vy_kin: float,
                             r: float) -> None:
        """The integrated observer (eqs 33-36), fed forward only, with ``ui = (a_x, a_y, delta_f, C_f, C_r, K)``."""
        ts, p, k = self.Ts, self._p, ui[5]
        intg = self.intg
        if intg is None:
            intg = self.intg = KalmanFilter([vw, vy_bic, r], np.diag([0.01, 0.01, 1e-4]))
        xi = intg.x.tolist()
        intg.predict(integrated_f(xi, ui, p, ts), integrated_F(xi, ui, p, ts), self._Q_int)
        z = np.array([(1 - k) * vw + k * vx_kin, (1 - k) * vy_bic + k * vy_kin, r])      # eq 34
        intg.update(z - intg.x, self._H_int, self._R_int)                                    # eq 36: H = I
        vx_i, vy_i, r_i = intg.x.tolist()
        self.vx, self.vy, self.yaw_rate = vx_i, vy_i, r_i
        self.beta = math.atan2(vy_i, vx_i)
        P = intg.P.tolist()
        self.beta_std = beta_std(vx_i, vy_i, P[Intg.VX][Intg.VX], P[Intg.VY][Intg.VY], P[Intg.VX][Intg.VY])
        self.valid = True

    # ---------------------------------------------------------------- hardened profile (module docstring)
    def _hardened_init(self) -> None:
        cfg = self.config
        self._straight_for = 0.0
        self._speed_ratio = 1.0
        self._kin_hist = DelayLine(int(round(0.5 / self.Ts)) + 2, 2)       # predicted (v_e, v_n)
        self._course_delay = CourseDelay(self.Ts, 0.5)
        self._gps_nis = InnovationMonitor(10, cfg.nis_limit)
        self._trust = ModelTrust(self.vehicle, self.Ts, cfg)
        self._outage = 0.0

    def _hardened_straight(self, r_m: float, vw_m: float, vs: float, gps_ok: bool) -> tuple[bool, bool]:
        """Straight driving by the yaw rate alone, held for ``straight_hold``; spin-out from the filtered ratio of
        the radius-compensated wheel speed to the GPS speed (``acos(v_w / v_s) > 0.1 rad`` is a 0.5 % ratio,
        tripped by GPS speed noise or a radius error); returns ``(straight, spin)``."""
        cfg, ts = self.config, self.Ts
        if gps_ok and vs > cfg.v_min:
            ratio = vw_m * (1.0 + self.b_R / self.vehicle.R_w) / vs
            self._speed_ratio = lowpass(self._speed_ratio, ratio, ts, 1.0)
        spin = abs(1.0 - self._speed_ratio) > 1.0 - math.cos(cfg.beta_th) + 0.02
        straight = abs(r_m + self.b_r) < cfg.r_straight      # not the steering rate: its noise breaks the hold
        self._straight_for = self._straight_for + ts if straight and not spin else 0.0
        return self._straight_for >= cfg.straight_hold, spin

    def _hardened_bound_offsets(self) -> None:
        """The offsets within what an automotive sensor's offset can be."""
        cfg, R_w = self.config, self.vehicle.R_w
        self.b_r = min(max(self.b_r, -cfg.offset_r_max), cfg.offset_r_max)
        self.b_y = min(max(self.b_y, -cfg.offset_ay_max), cfg.offset_ay_max)
        self.b_x = min(max(self.b_x, -cfg.offset_ax_max), cfg.offset_ax_max)
        self.b_R = min(max(self.b_R, -0.05 * R_w), 0.05 * R_w)

    def _hardened_fix(self, kin: KalmanFilter, z: np.ndarray, r: float, vs: float) -> None:
        """The fix against the kinematic EKF's velocity of ``delay`` ago, the delay identified while turning."""
        cfg, ts = self.config, self.Ts
        xk = kin.x.tolist()
        if cfg.identify_delay and vs > cfg.heading_speed:
            self._course_delay.add_fix(math.atan2(z[1], z[0]), r)
            d = self._course_delay.estimate()
            if d is not None:
                self.delay = d
        before = kinematic_h(xk)[1:]
        self._gps_nis.add(kin.update(z - self._kin_hist.delayed(int(round(self.delay / ts))),
                                     kinematic_H(xk)[1:], self._R_gps), 2)
        self._kin_hist.correct(kinematic_h(kin.x.tolist())[1:] - before)

    def _hardened_uncertainty(self, kin, gps_ok: bool, vx_kin: float, vy_kin: float, r: float, ay_m: float) -> None:
        """The sub-filters' own uncertainty, weighted like their estimates, the kinematic check, and the validity."""
        cfg, k = self.config, self.K
        self._outage = 0.0 if gps_ok else self._outage + self.Ts
        var_bic = self.bic.P.item(Bic.BETA, Bic.BETA)
        if kin is not None:
            Pk = kin.P
            var_kin = beta_std(vx_kin, vy_kin, Pk.item(0, 0), Pk.item(1, 1), Pk.item(0, 1)) ** 2 * \
                self._gps_nis.inflation() ** 2
        else:
            var_kin = var_bic
        self._trust.check_kinematics(self.beta, self.vx, r, ay_m)
        self.beta_std = math.hypot(math.sqrt((1 - k) ** 2 * var_bic + k * k * var_kin), self._trust.kinematic_sigma)
        self.valid = kin is not None and self._outage <= cfg.gps_coast and self._gps_nis.consistent
