"""The project's own estimator: GNSS, IMU, wheel speeds and steering fused with a self-calibrating tire model.

Built from the benchmark's failure cases (:mod:`sideslip.studies.benchmark`): the papers' methods
each trust one thing a user's car does not give them - an offset-free gyro (Nguyen 2012), a
calibrated magnetometer (Yoon 2014), the vehicle file's cornering stiffness and linear tires (Kim
2016, Pi 2011, the bicycle observer).  :class:`SideslipFusion` trusts none of them alone:

* **Kinematic model** (the time update, :func:`kinematic_step`): the body-frame velocity driven by
  the accelerometers, ``dvx/dt = a_x - b_ax + r v_y``, ``dvy/dt = a_y - b_ay - r v_x`` with
  ``r = r_m - b_r`` (the accelerometer's lateral reading roll-compensated with the vehicle's roll
  model, :class:`~sideslip.estimators.roll.RollCompensator`), and the heading ``dpsi/dt = r``.
  Exact for any tire and friction; it drifts with the offsets, which are states.  On a banked road
  the lateral accelerometer reads the tires' force per mass, the car's lateral acceleration plus
  ``g sin(bank)``: the bank's term ``g_y`` is a state of its own, ``dvy/dt = a_y - b_ay - g_y - r v_x``,
  because it moves the reading but is not a tire force (a single offset would put the bank into the
  tire forces below: 0.65 deg on the training set's banked circle, seed 0, against 0.11).  What
  tells it from the sensor's offset ``b_ay`` is the tire model at changing lateral forces; in a
  steady turn their priors split the sum (``bank_std0``, ``accel_offset_std0``).
* **GNSS velocity** (:func:`gnss_model`): ``v_e = v_x cos psi - v_y sin psi``,
  ``v_n = v_x sin psi + v_y cos psi`` at the fix's own time: the filter's samples of the last
  ``max_delay`` seconds are kept, the fix's innovation and gain are those of its own sample and
  the correction is carried to now through the filter's steps since (Larsen 1998,
  :class:`~sideslip.estimators.kalman.DelayedMeasurements`; re-running the filter from the fix's
  sample, as Yoon 2014 Fig. 7 does, costs 1.5 times as much for the same accuracy on the
  training set, ``docs/estimator.md``).  The delay ``D`` is a state (``delay_state``, prior
  ``gps_latency`` +- ``gps_latency_std``): the fix is compared with the sample ``round(D / Ts)`` ago and
  linearised in the rest, ``v(t - D) = v_s - (D - lag Ts) a_cross`` (:func:`gnss_delayed_model`), where only the
  acceleration across the track enters (along it a delay is a speed error that the rolling radius and the
  accelerometer's offset explain as well; the delay's error along the track is the fix's noise, ``a_along`` times
  the state's std).  While the course turns the filter finds the delay together with the heading and the sideslip;
  in a steady turn the three share what the fixes cannot tell apart, and the covariance says so.  Without
  ``delay_state`` the delay is identified apart from the filter from the course's changes
  (:class:`~sideslip.estimators.delay.GpsLatency`) and its uncertainty enters the fix's noise as the acceleration
  times the delay's std.  GNSS makes the heading, the gyro offset, the accelerometer offsets, the rolling radius
  and the tire parameters observable whenever the car accelerates or turns.
* **Magnetometer** (``use_magnetometer``, :meth:`SideslipFusion._magnetometer_update`): GNSS gives the course,
  heading plus sideslip; without a heading of its own the filter splits the two by the tire model, and in a long
  slide or a steady turn the tire model's error drifts the gyro offset and with it the heading (development set,
  J-turn on ice under the SUV: 1.6 deg of heading and 1.9 deg of sideslip off after 10 s).  Each new reading whose
  field norm is within ``mag_norm_gate`` of unity gives the heading of the tilt-compensated horizontal field
  (:func:`~sideslip.geomagnetic.tilt_compensated_heading`), the tilt being the roll model's roll plus the bank,
  ``asin(g_y / g)``.  Its noise is the reading's over the horizontal field plus the tilt's error (``mag_tilt_std``,
  ``mag_roll_error`` of the roll, the bank state's std) times ``d psi / d tilt`` (up to ``tan(inclination)``: the
  site's inclination itself is not needed), the latter counted once per ``mag_tilt_correlation_time``.  The
  readings are calibrated (hard and soft iron removed, ``mag_declination`` set); what heading offset remains is the
  state ``B_MAG`` (``mag_offset_std0``), which GNSS calibrates where the tire model fixes the sideslip.  Two guards
  keep a wrong magnetometer out: a reading whose heading innovation is more than ``mag_gate`` of its std off is not
  used (a disturbance whose field norm happens to be near unity; training set, disturbances over 40 % of the first
  30 s: 0.48 -> 0.10 deg), and while the mean normalised innovation of the last second's readings, each one's error
  counted once, is above ``mag_nis_limit`` (back below half of it) none is (a hard iron not removed, whose heading
  error turns with the heading and passes the gate reading by reading; training set 1.24 -> 0.12 deg, 0.106
  without the magnetometer).  On by default: training 0.106 -> 0.102 deg, development 0.206 -> 0.170
  (``docs/estimator.md``); a magnetometer not wired (a zero field) fails the norm gate and leaves the filter as
  without it.  It does not enter the IMM's likelihoods (it
  says nothing about grip or slide).
* **Wheel speeds** (:func:`wheel_model`): the undriven axle's mean speed is ``(1 + e_w) v_x``
  (``e_w`` the rolling-radius error, a state); its noise grows with the longitudinal friction
  utilisation squared and a Huber gate caps its weight (a braked wheel slips, a locked one slides).
* **Tire pseudo-measurements** (:func:`axle_pseudo`), one per axle, every sample: the axle's lateral
  force from the force and moment balances (:func:`~sideslip.bicycle.axle_forces`, from the measured
  lateral acceleration less the sensor's offset and the yaw acceleration) gives its slip angle
  through a brush (Fiala) tire,
  ``alpha = 3 mu F_z / C (1 - (1 - |F_y| / (mu F_z))^(1/3))``, whose cornering stiffness
  ``C = s C_nominal(mu)`` (the vehicle file's stiffness, softer on low friction, :func:`axle_stiffness`)
  and friction ``mu`` are states (log-scaled, bounded; the friction also from below by the measured
  acceleration, ``mu >= 0.9 |a| / g``).  A braked or driven axle has less friction left for its lateral
  force: ``mu F_z`` is replaced by ``sqrt((mu F_z)^2 - F_x^2)`` (friction ellipse, :func:`lateral_capacity`),
  ``F_x`` being ``m a_x`` by the vehicle file's drive or brake split (``combined_slip``; training set,
  brake in a turn on snow 0.306 -> 0.292 deg).  The slip angles tie
  the lateral velocity to the yaw rate and the steering:
  ``v_y - l_r r + v_x alpha_r = 0`` and ``v_y + l_f r - v_x (delta_m - d_delta - alpha_f) = 0``
  (``d_delta`` the steering offset, a state).  With GNSS they calibrate the tire model; without
  it they are what holds the lateral velocity.  Their noise is the tire's transient (relaxation)
  and the brush model's error, which grows with the friction utilisation ``|F_y| / F_max``,
  inflated by the error's correlation time, by covariance matching and by a Huber gate; beyond
  ``utilisation_max`` the slip is a lower bound (a state sliding further is not corrected).  Where the
  state's slip angle of an axle is beyond the brush tire's at ``utilisation_max``,
  ``3 F_max / C (1 - (1 - u_max)^(1/3))`` (the friction estimate too high for what the car does), the
  axle carries all its friction, ``|F_y| = F_max``: the brush model's sliding branch,
  ``ln(|F_y| / F_max) = 0``, measures the friction instead of pulling the slip back
  (``sliding_friction``; development set, friction drop under the small car 0.93 -> 0.31 deg, J-turn
  on ice 0.26 -> 0.14).  Where the tire is linear its slip hardly depends on the friction, so the friction's
  uncertainty does not reach the pseudo-measurements; ``friction_doubt`` (off by default: the training set does
  not ask for it) takes the model error's utilisation at a friction that many of its std below the estimate
  (development set, friction drop 0.28 -> 0.23 deg, the error 2.0 -> 1.6 times its std; ``docs/estimator.md``).
  A stiffness scale more than one prior std (``stiffness_std0``) below the vehicle file's, beyond the friction's
  own fall from ``mu0`` in its std (``mu_std0``), is a slide the stiffness absorbed rather than a file's error:
  each further std adds ``stiffness_doubt`` to the axle's relative slip error (development set, SUV J-turn on ice
  0.88 -> 0.58 deg, mean 0.351 -> 0.278; training flat; ``docs/estimator.md``).
  Linearised at its estimate the friction hardly moves a tire short of sliding, so a road slipperier than estimated
  shows only once an axle slides.  Each sample ``friction_test`` weighs the two residuals at a few lower frictions
  (:data:`_FRICTION_HYPOTHESES`: those more than two std below the estimate under which the more utilised axle
  would use 0.5-0.85 of its friction) against the estimate's, with one noise for all (the model error at
  utilisation 0.5: the fits are compared, not what each hypothesis claims to know); a CUSUM of the best one's
  log-likelihood ratio beyond ``friction_test`` re-initialises the friction there (development set, friction drop
  0.22 -> 0.04 deg, SUV J-turn on ice 0.58 -> 0.44, mean 0.251 -> 0.206; training 0.110 -> 0.106).

State: :class:`Fs` (14; the first 13 without the magnetometer, 12 without the delay state either).  Two
formulations (``formulation``),
compared on the benchmark (``docs/estimator.md``):

* ``0`` **EKF**: one extended Kalman filter on the model above;
* ``1`` **IMM**: an interacting multiple model of two such filters, one trusting the tire model
  (``grip``) and one with its pseudo-measurements ``slide_factor`` times less certain and
  more process noise on the lateral velocity (``slide``), mixed every sample by their likelihoods.

Without GNSS (``use_gnss`` false, or while ``gps_valid`` is false) the same filter runs on the
kinematic model, the wheel speeds and the tire pseudo-measurements (in-vehicle mode): the heading
and the GNSS-only observable states then random-walk with their process noise, so the reported std
grows honestly; at the return of GNSS after the heading has become uncertain (``heading_reset``)
the heading is re-initialised from the fix's course.

Bounded states: the stiffness scales ``s`` within ``[stiffness_min, stiffness_max]``, the friction
within ``[mu_min, mu_max]`` (clamped after each update); a parameter (offsets, tire parameters, rolling
radius) whose variance has reached its prior's gets no process noise, so that one nothing shows cannot
grow without bound.  The gyro offset is not bounded (a
clamped Kalman state leaves its covariance claiming a freedom it does not have).

Reported std and validity: ``beta_hat_std`` is the first-order std of ``atan2(v_y, v_x)`` from the
filter covariance, inflated by the GNSS innovations' consistency
(:class:`~sideslip.estimators.hardening.InnovationMonitor`); ``valid`` is false below ``v_min``,
before the heading is initialised in GNSS mode, while the GNSS innovations are inconsistent, and
above ``valid_std_max``, and waits ``valid_hold`` after any break
(:class:`~sideslip.estimators.hardening.ValidityGate`).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from .. import geomagnetic
from ..bicycle import axle_forces
from ..constants import GRAVITY
from ..geomagnetic import tilt_compensated_heading
from ..params import param
from ..signals import WHEEL_SPEEDS_M
from .base import Estimator, EstimatorConfig, beta_std, input_enum, lowpass
from .delay import DelayLine, GpsLatency
from .hardening import (GpsLatencyConfig, InnovationMonitor, ValidityGate, nis_limit_param, valid_hold_param,
                        valid_std_max_param)
from .kalman import DelayedMeasurements, KalmanFilter
from .roll import RollCompensator

__all__ = ["SideslipFusionConfig", "SideslipFusion", "Fs", "EKF", "IMM", "kinematic_step", "gnss_model",
           "wheel_model", "magnetometer_model", "track_acceleration",
           "gnss_delayed_model", "axle_pseudo", "axle_slip", "axle_stiffness", "fiala_slip", "lateral_capacity"]

EKF, IMM = 0, 1
"""Values of the ``formulation`` parameter."""

_FRICTION_HYPOTHESES = tuple(math.log(m) for m in (0.8, 0.65, 0.5, 0.4, 0.3, 0.25, 0.2, 0.15))
"""The log frictions ``friction_test`` weighs against the estimate."""
_TEST_MODEL_ERROR = 0.25
"""The tire model's relative error in ``friction_test``'s likelihoods: ``slip_model_error`` at utilisation 0.5."""


class Fs(IntEnum):
    """State of :class:`SideslipFusion`: ``G_Y`` is the road bank's gravity term ``g sin(bank)`` in the lateral
    accelerometer, which moves the car but is not a tire force (``B_AY``, the sensor's offset, is in both);
    ``D_GNSS`` the GNSS delay [s] (``delay_state``); ``B_MAG`` the magnetometer's heading offset (a declination or
    iron error).  The filter has the first 12, 13 with ``delay_state``, all 14 with ``use_magnetometer``."""
    VX, VY, PSI, B_R, B_AX, B_AY, D_DELTA, LN_CF, LN_CR, LN_MU, E_W, G_Y, D_GNSS, B_MAG = range(14)


# identities by state size: the filter leaves out the states of what it does not use, last the magnetometer's offset
# (they would only cost time: nothing observes them)
_EYES = {n: np.eye(n) for n in (len(Fs) - 2, len(Fs) - 1, len(Fs))}
# plain-int copies of the indices the per-sample functions use: indexing with an IntEnum member costs four times more
_VX, _VY, _PSI, _B_R, _B_AX, _B_AY, _D_DELTA, _LN_CF, _LN_CR, _LN_MU, _E_W, _G_Y, _D_GNSS, _B_MAG = (int(s) for s in Fs)


# ------------------------------------------------------------------------------ the models
def kinematic_step(x: np.ndarray, ax: float, ay: float, r_m: float, ts: float) -> tuple[np.ndarray, np.ndarray]:
    """One Euler step of the kinematic model (module docstring) and its Jacobian.

    Parameters
    ----------
    x : ndarray
        State (:class:`Fs`).
    ax, ay : float
        Measured longitudinal and roll-compensated lateral acceleration [m/s2].
    r_m : float
        Measured yaw rate [rad/s].
    ts : float
        Step [s].
    """
    vx, vy, psi, b_r, b_ax, b_ay = x[:6].tolist()
    r = r_m - b_r
    a_y = ay - b_ay - x.item(_G_Y)                   # the specific force minus the bank's gravity term
    xp = x.copy()
    xp[_VX] = vx + ts * (ax - b_ax + r * vy)
    xp[_VY] = vy + ts * (a_y - r * vx)
    xp[_PSI] = psi + ts * r
    F = _EYES[len(x)].copy()                        # np.eye costs three times a copy
    F[_VX, _VY], F[_VX, _B_R], F[_VX, _B_AX] = ts * r, -ts * vy, -ts
    F[_VY, _VX], F[_VY, _B_R], F[_VY, _B_AY], F[_VY, _G_Y] = -ts * r, ts * vx, -ts, -ts
    F[_PSI, _B_R] = -ts
    return xp, F


def gnss_model(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The GNSS velocity ``(v_e, v_n)`` of the state and its Jacobian."""
    vx, vy, psi = x[:3].tolist()
    c, s = math.cos(psi), math.sin(psi)
    H = np.zeros((2, len(x)))
    H[0, _VX], H[0, _VY], H[0, _PSI] = c, -s, -vx * s - vy * c
    H[1, _VX], H[1, _VY], H[1, _PSI] = s, c, vx * c - vy * s
    return np.array([vx * c - vy * s, vx * s + vy * c]), H


def track_acceleration(x: np.ndarray, ax: float, ay: float, v_ne) -> tuple[np.ndarray, np.ndarray, float]:
    """The state's horizontal acceleration ``R(psi) (a_x - b_ax, a_y - b_ay - g_y)`` (east, north) split along and
    across the track of the velocity ``v_ne`` (east, north).

    Returns
    -------
    tuple
        The acceleration across the track (east, north) [m/s2], the track's unit vector and the acceleration along
        it [m/s2].
    """
    c, s = math.cos(x.item(_PSI)), math.sin(x.item(_PSI))
    a_x = ax - x.item(_B_AX)
    a_y = ay - x.item(_B_AY) - x.item(_G_Y)
    a = np.array([a_x * c - a_y * s, a_x * s + a_y * c])
    track = np.asarray(v_ne, dtype=float) / max(math.hypot(v_ne[0], v_ne[1]), 0.1)
    along = float(a.dot(track))
    return a - along * track, track, along


def gnss_delayed_model(x: np.ndarray, ax: float, ay: float, age: float) -> tuple:
    """A fix of the delay state's ``D`` ago against the state of a sample ``age`` ago: ``v(t - D) = v_s - (D - age)
    a_cross`` and its Jacobian.

    Only the acceleration across the track (the course turning, :func:`track_acceleration`) enters: along the track
    a delay shows as a speed error, which the rolling radius and the accelerometer's offset explain as well; the
    delay's error along the track is the caller's noise.  (With the whole acceleration in the Jacobian, the delay of
    a drive that accelerates from its start ran to its 0.5 s bound within 1.7 s and the estimate diverged.)

    Parameters
    ----------
    x : ndarray
        State of the sample (:class:`Fs`, with ``D_GNSS``).
    ax, ay : float
        The sample's measured longitudinal and roll-compensated lateral acceleration [m/s2].
    age : float
        Age of the sample [s].

    Returns
    -------
    tuple
        ``h`` (east, north) [m/s], ``H`` (2, n), the track's unit vector and the acceleration along it [m/s2].
    """
    h, H = gnss_model(x)
    a_cross, track, along = track_acceleration(x, ax, ay, h)
    H[:, _D_GNSS] = -a_cross
    return h - (x.item(_D_GNSS) - age) * a_cross, H, track, along


def magnetometer_model(x: np.ndarray) -> tuple[float, np.ndarray]:
    """The magnetometer's heading ``psi + b_mag`` [rad] and its Jacobian row."""
    h = np.zeros(len(x))
    h[_PSI] = h[_B_MAG] = 1.0
    return x.item(_PSI) + x.item(_B_MAG), h


def wheel_model(x: np.ndarray) -> tuple[float, np.ndarray]:
    """The undriven axle's mean wheel speed ``(1 + e_w) v_x`` [m/s] and its Jacobian row."""
    vx, e_w = x.item(_VX), x.item(_E_W)
    h = np.zeros(len(x))
    h[_VX], h[_E_W] = 1.0 + e_w, vx
    return (1.0 + e_w) * vx, h


def fiala_slip(force: float, stiffness: float, f_max: float, u_max: float) -> tuple[float, float, float]:
    """Slip angle of a brush (Fiala) tire carrying ``force`` [N], and its derivatives.

    ``alpha = 3 F_max / C (1 - (1 - u)^(1/3))`` with ``u = |F| / F_max`` (clipped at ``u_max``: at
    saturation the slip angle is not defined by the force), the inverse of
    ``F = C alpha - C^2 alpha |alpha| / (3 F_max) + C^3 alpha^3 / (27 F_max^2)``; ``F / C`` for small
    forces.

    Returns
    -------
    tuple of float
        ``alpha`` [rad], ``d alpha / d ln C`` (``-alpha``), ``d alpha / d ln F_max`` [rad] and the
        utilisation ``u`` (unclipped).
    """
    u = abs(force) / f_max
    uc = u if u < u_max else u_max
    w = (1.0 - uc) ** (1.0 / 3.0)
    a = 3.0 * f_max / stiffness
    alpha = math.copysign(a * (1.0 - w), force)
    # beyond u_max the derivative of the clipped curve, not zero: a friction estimated too low must be able to
    # climb back out of saturation
    d_fmax = a * ((1.0 - w) - uc / (3.0 * w * w))                    # <= 0: more friction, less slip
    if force < 0.0:
        d_fmax = -d_fmax
    return alpha, -alpha, d_fmax, u


def axle_stiffness(c_hi: float, c_lo: float, mu_lo: float, mu: float) -> tuple[float, float]:
    """The vehicle file's axle cornering stiffness at friction ``mu`` (linear between ``mu_lo`` and 1, held
    outside: tires on snow are softer in their linear range too) [N/rad] and ``d ln C / d ln mu``."""
    w = (mu - mu_lo) / (1.0 - mu_lo)
    if w >= 1.0:
        return c_hi, 0.0
    if w <= 0.0:
        return c_lo, 0.0
    c = c_lo + w * (c_hi - c_lo)
    return c, mu * (c_hi - c_lo) / ((1.0 - mu_lo) * c)


CAPACITY_MIN = 0.3
"""Smallest share of an axle's friction :func:`lateral_capacity` leaves for its lateral force."""


def lateral_capacity(f_max: float, f_x: float) -> tuple[float, float]:
    """The lateral force an axle can carry beside its longitudinal force ``f_x`` [N] (friction ellipse, isotropic:
    ``sqrt(F_max^2 - F_x^2)``, at least ``CAPACITY_MIN F_max``) and its ``d ln / d ln F_max``.

    A braked or driven tire has used part of its friction, so it slides sideways earlier (the brush model at
    combined slip, Pacejka, *Tire and Vehicle Dynamics*, ch. 3: the slip's magnitude, whatever its direction,
    saturates the friction circle).
    """
    f2 = f_max * f_max
    lat2 = f2 - f_x * f_x
    if lat2 <= (CAPACITY_MIN * f_max) ** 2:        # more than the friction estimate allows: it is too low
        return CAPACITY_MIN * f_max, 1.0
    return math.sqrt(lat2), f2 / lat2


def axle_slip(force: float, f_z: float, f_x: float, c_hi: float, c_lo: float, mu_lo: float, ln_scale: float,
              mu: float, u_max: float) -> tuple:
    """Slip angle of an axle carrying the lateral ``force`` [N] on a load ``f_z`` [N] beside a longitudinal ``f_x``
    [N], at friction ``mu`` and the log stiffness scale ``ln_scale`` (:func:`axle_stiffness`,
    :func:`lateral_capacity`, :func:`fiala_slip`).

    Returns
    -------
    tuple
        ``(alpha, d alpha / d ln C, d alpha / d ln F_max, u, C, F_max, d ln C / d ln mu, d ln F_max / d ln mu)``.
    """
    c, k = axle_stiffness(c_hi, c_lo, mu_lo, mu)
    c *= math.exp(ln_scale)
    f_max, g = lateral_capacity(mu * f_z, f_x)
    alpha, d_c, d_m, u = fiala_slip(force, c, f_max, u_max)
    return alpha, d_c, d_m, u, c, f_max, k, g


def axle_pseudo(x: np.ndarray, inp: tuple, geometry: tuple, u_max: float) -> tuple:
    """The two tire pseudo-measurements (module docstring): for each axle the residual ``h(x)`` (measured 0),
    its Jacobian row and the axle's slip angle and utilisation.

    Parameters
    ----------
    x : ndarray
        State (:class:`Fs`).
    inp : tuple
        ``(r_m, delta_m, F_yf, F_yr, F_zf, F_zr, F_xf, F_xr)`` of the sample (the axles' longitudinal forces
        derate their lateral friction, :func:`lateral_capacity`; zero for the pure-slip tire).
    geometry : tuple
        ``(l_f, l_r, C_f, C_r, C_f_lo, C_r_lo, mu_lo, m_f, m_r)``: the vehicle file's axle stiffnesses at friction 1
        and ``mu_lo`` (:func:`axle_stiffness`; the states scale them) and the axles' shares of the mass
        ``m l_r / l``, ``m l_f / l`` [kg] (``d F_y / d a_y``: the accelerometer offset moves the forces).
    u_max : float
        Utilisation beyond which the slip angle is not defined by the force.

    Returns
    -------
    tuple
        Per axle (front, rear): the residual, its row, the slip angle [rad], the utilisation ``|F_y| / F_max``,
        the brush tire's slip angle at utilisation ``u_max``, ``3 F_max / C (1 - (1 - u_max)^(1/3))`` [rad], and
        ``d ln F_max / d ln mu``.
    """
    r_m, delta, fyf, fyr, fzf, fzr, fxf, fxr = inp
    l_f, l_r, c_f, c_r, c_f_lo, c_r_lo, mu_lo, m_f, m_r = geometry
    vx, vy, _, b_r, _, _, d_delta, ln_cf, ln_cr, ln_mu = x[:_E_W].tolist()          # Fs order
    mu = math.exp(ln_mu)
    r = r_m - b_r
    n = len(x)
    a_f, da_cf, da_mf, u_f, cf_s, fmf, kf, gf = axle_slip(fyf, fzf, fxf, c_f, c_f_lo, mu_lo, ln_cf, mu, u_max)
    a_r, da_cr, da_mr, u_r, cr_s, fmr, kr, gr = axle_slip(fyr, fzr, fxr, c_r, c_r_lo, mu_lo, ln_cr, mu, u_max)
    # the forces come from a_y - b_ay: the offset moves the slip by -m_axle / C per m/s2, taken in the linear range
    # where it is identified (the brush model's 1 / (C (1 - u)^(2/3)) would read its own error near saturation as
    # an accelerometer offset: training set, brake in a turn on snow 0.38 deg against 0.31)
    steer = delta - d_delta
    h_f = vy + l_f * r - vx * (steer - a_f)
    row_f = np.zeros(n)
    row_f[_VX], row_f[_VY], row_f[_B_R], row_f[_D_DELTA] = a_f - steer, 1.0, -l_f, vx
    row_f[_LN_CF], row_f[_LN_MU], row_f[_B_AY] = vx * da_cf, vx * (gf * da_mf + kf * da_cf), -vx * m_f / cf_s
    h_r = vy - l_r * r + vx * a_r
    row_r = np.zeros(n)
    row_r[_VX], row_r[_VY], row_r[_B_R] = a_r, 1.0, l_r
    row_r[_LN_CR], row_r[_LN_MU], row_r[_B_AY] = vx * da_cr, vx * (gr * da_mr + kr * da_cr), -vx * m_r / cr_s
    k_max = 1.0 - (1.0 - u_max) ** (1.0 / 3.0)                 # the slip at u_max over the full slide's 3 F_max / C
    return (h_f, row_f, a_f, u_f, 3.0 * k_max * fmf / cf_s, gf), (h_r, row_r, a_r, u_r, 3.0 * k_max * fmr / cr_s, gr)


# ------------------------------------------------------------------------------ configuration
@dataclass(frozen=True)
class SideslipFusionConfig(EstimatorConfig, GpsLatencyConfig):
    """Parameters of :class:`SideslipFusion`."""

    formulation: int = param(0, "Dimensionless", "0: one EKF; 1: IMM of a grip and a slide filter (module "
                             "docstring)", choices=(EKF, IMM))
    use_gnss: bool = param(True, "Dimensionless", "Use the GNSS velocity while gps_valid (false: in-vehicle sensors "
                           "only)")
    # kinematic model and offsets
    sigma_accel: float = param(0.1, "Acceleration", "Process noise of the kinematic model per filter sample as an "
                               "acceleration: the accelerometers' white noise at the sample and what the roll "
                               "compensation leaves (0.1: twice a 0.05 m/s2 automotive IMU's noise; slow errors are "
                               "the offset and bank states')", gt=0, le=10)
    sigma_gyro: float = param(0.002, "AngularVelocity", "Gyro noise for the heading's process noise", gt=0, le=1)
    gyro_offset_std0: float = param(0.015, "AngularVelocity", "Initial uncertainty of the gyro offset", gt=0, le=1)
    gyro_offset_walk: float = param(1.7e-4, "AngularVelocity", "Random walk of the gyro offset per sqrt(s) (1.7e-4: "
                                    "0.1 deg/s per 100 s, an automotive-grade gyro's drift)", gt=0, le=1)
    accel_offset_std0: float = param(0.2, "Acceleration", "Initial uncertainty of the accelerometer offsets",
                                     gt=0, le=10)
    accel_offset_walk: float = param(0.01, "Acceleration", "Random walk of the accelerometer offsets (the "
                                     "longitudinal one with the road grade) per sqrt(s)", gt=0, le=10)
    bank_std0: float = param(0.3, "Acceleration", "Initial uncertainty of the road bank's gravity term g sin(bank) in "
                             "the lateral accelerometer (0.3: about 1.8 degrees)", gt=0, le=10)
    bank_walk: float = param(0.003, "Acceleration", "Random walk of the road bank's gravity term per sqrt(s)",
                             gt=0, le=10)
    steer_offset_std0: float = param(0.005, "Angle", "Initial uncertainty of the steering offset", gt=0, le=0.5)
    radius_error_std0: float = param(0.02, "Dimensionless", "Initial uncertainty of the rolling-radius error",
                                     gt=0, le=0.5)
    # tire model
    stiffness_std0: float = param(0.35, "Dimensionless", "Initial uncertainty of the log cornering-stiffness scales "
                                  "(0.35: about 30 percent)", gt=0, le=3)
    stiffness_walk: float = param(0.003, "Dimensionless", "Random walk of the log stiffness scales per sqrt(s)",
                                  gt=0, le=1)
    stiffness_min: float = param(0.4, "Dimensionless", "Smallest stiffness scale", gt=0, le=1)
    stiffness_max: float = param(2.5, "Dimensionless", "Largest stiffness scale", ge=1, le=10)
    mu0: float = param(1.0, "FrictionCoefficient", "Friction assumed until it shows", ge=0.05, le=1.5)
    mu_std0: float = param(0.15, "Dimensionless", "Uncertainty of the log friction", gt=0, le=3)
    mu_walk: float = param(0.02, "Dimensionless", "Random walk of the log friction per sqrt(s) (the road changes)",
                           gt=0, le=10)
    mu_min: float = param(0.1, "FrictionCoefficient", "Smallest friction", gt=0, le=1)
    mu_max: float = param(1.3, "FrictionCoefficient", "Largest friction", ge=0.5, le=3)
    combined_slip: bool = param(True, "Dimensionless", "Derate each axle's lateral friction by its longitudinal "
                                "force, m a_x by the vehicle's drive or brake split (friction ellipse, "
                                "lateral_capacity); false: the pure-slip brush tire")
    sliding_friction: bool = param(True, "Dimensionless", "Where the state's slip angle of an axle is beyond the "
                                   "brush tire's at utilisation_max, take the axle's force as its friction (the "
                                   "sliding branch) instead of a slip angle from it; false: the slip from the force "
                                   "always")
    sliding_friction_std: float = param(0.2, "Dimensionless", "Uncertainty of the log friction a sliding axle's "
                                        "force gives", gt=0, le=10)
    utilisation_max: float = param(0.95, "Dimensionless", "Friction utilisation beyond which the tire model gives "
                                   "no slip angle", gt=0, lt=1)
    friction_doubt: float = param(0.0, "Dimensionless", "The tire model's error is taken at the utilisation of a "
                                  "friction this many of its std below the estimate (0: at the estimate)", ge=0, le=5)
    sigma_slip: float = param(0.004, "Angle", "Slip-angle noise of the tire pseudo-measurements (sensor noise, "
                              "unmodelled dynamics)", gt=0, le=1)
    stiffness_doubt: float = param(1.5, "Dimensionless", "Relative error of the brush model's slip angle per prior "
                                   "std (stiffness_std0) by which an axle's stiffness scale lies below the vehicle "
                                   "file's beyond one std and beyond the friction's fall from mu0 in its own std "
                                   "(mu_std0): a tire explained as softer than the file allows, a slide the "
                                   "stiffness absorbs (0: off)", ge=0, le=100)
    friction_test: float = param(1.0, "Dimensionless", "Threshold of the CUSUM of the tire pseudo-measurements' "
                                 "log-likelihood ratio, the best-fitting of a few lower frictions against the "
                                 "estimate, beyond which the friction is re-initialised at that one: a slipperier "
                                 "road found before an axle slides (0: off)", ge=0, le=1000)
    slip_model_error: float = param(1.0, "Dimensionless", "Relative error of the brush model's slip angle at full "
                                    "utilisation (grows with utilisation squared)", ge=0, le=10)
    relaxation_length: float = param(0.5, "Length", "Tire relaxation length: the transient slip error is the slip "
                                     "rate times relaxation_length / v_x", ge=0, le=10)
    slip_correlation_time: float = param(0.1, "Time", "Correlation time of the tire model's error: each sample's "
                                         "pseudo-measurement variance is multiplied by it over Ts (an error that "
                                         "lasts is not new information every sample)", ge=0, le=10)
    adapt_window: float = param(0.5, "Time", "Window over which the tire pseudo-measurements' noise is matched to "
                                "their innovations (covariance matching: a model that stops explaining the car is "
                                "trusted less)", gt=0, le=60)
    pseudo_gate: float = param(3.0, "Dimensionless", "Normalised residual beyond which a tire pseudo-measurement "
                               "or the wheel speed is down-weighted (Huber) so that a transient the model cannot "
                               "follow, or a locking wheel, does not drag the state", gt=0, le=100)
    yaw_acc_cutoff: float = param(3.0, "Frequency", "Low-pass cut-off of the yaw acceleration in the axle forces",
                                  gt=0, le=50)
    # GNSS
    sigma_gnss: float = param(0.1, "Velocity", "GNSS velocity noise per axis", gt=0, le=10)
    max_delay: float = param(0.5, "Time", "Largest GNSS delay handled (length of the history)", gt=0, le=2)
    fix_extrapolation: bool = param(True, "Dimensionless", "Apply a delayed GNSS fix by carrying its correction "
                                    "from its sample to now through the filter's steps (Larsen 1998, two thirds "
                                    "of the cost); false: re-run the filter from the fix's sample (measurement "
                                    "shifting)")
    delay_state: bool = param(True, "Dimensionless", "Estimate the GNSS delay as a state of the filter from the "
                              "fixes' course while it turns (gps_latency +- gps_latency_std its prior); false: "
                              "identify it apart from the filter from the course's changes (identify_delay)")
    delay_walk: float = param(1e-4, "Time", "Random walk of the GNSS delay state per sqrt(s)", gt=0, le=1)
    # magnetometer
    use_magnetometer: bool = param(True, "Dimensionless", "Update the heading with the magnetometer's (mag_x, "
                                   "mag_y, mag_z, calibrated: hard and soft iron removed, normalised to the "
                                   "undisturbed field) whenever the GNSS has initialised it; false: ignore the "
                                   "magnetometer")
    sigma_mag: float = param(0.02, "MagneticFluxRatio", "Magnetometer noise per axis (normalised field)", gt=0, le=1)
    mag_declination: float = param(geomagnetic.DECLINATION, "Angle", "Declination: magnetic north east of true "
                                   "north", ge=-math.pi, le=math.pi)
    mag_offset_std0: float = param(0.05, "Angle", "Initial uncertainty of the magnetometer's heading offset (a "
                                   "declination or iron error), calibrated with GNSS", gt=0, le=3.2)
    mag_offset_walk: float = param(1e-4, "Angle", "Random walk of the magnetometer's heading offset per sqrt(s) "
                                   "(iron that changes with the load)", gt=0, le=1)
    mag_norm_gate: float = param(0.1, "MagneticFluxRatio", "Field-norm deviation from unity beyond which a reading "
                                 "is taken as disturbed and not used", gt=0, le=10)
    mag_tilt_std: float = param(0.003, "Angle", "Tilt error of the magnetometer's tilt compensation besides the "
                                "roll model's (pitch, the bank estimate)", ge=0, le=0.5)
    mag_roll_error: float = param(0.2, "Dimensionless", "Relative error of the roll model's roll in the tilt "
                                  "compensation", ge=0, le=10)
    mag_tilt_correlation_time: float = param(1.0, "Time", "Correlation time of the tilt error: its heading "
                                             "variance is multiplied by it over the readings' interval", ge=0,
                                             le=100)
    mag_gate: float = param(3.0, "Dimensionless", "Heading innovation, in its std, beyond which a magnetometer "
                            "reading is not used: a disturbance whose field norm is near unity (0: every reading "
                            "within mag_norm_gate is used)", ge=0, le=100)
    mag_nis_limit: float = param(2.0, "Dimensionless", "Mean normalised heading innovation of the magnetometer's "
                                 "last 1 / Ts readings (1 s at a reading per filter sample; each reading's error "
                                 "counted once) above which none is used until it falls below half of it: a "
                                 "heading error that lasts, as of a hard iron not removed (0: no check)",
                                 ge=0, le=1e6)
    heading_reset: float = param(0.2, "Angle", "Heading std above which the heading is re-initialised from the "
                                 "course at the next fix", gt=0, le=3.2)
    course_speed: float = param(3.0, "Velocity", "Speed below which a fix does not initialise the heading",
                                gt=0, le=50)
    # IMM
    slide_factor: float = param(10.0, "Dimensionless", "IMM: how much less certain the slide filter's tire "
                                "pseudo-measurements are", ge=1, le=1e4)
    slide_accel: float = param(1.0, "Acceleration", "IMM: extra process noise of the slide filter's lateral "
                               "velocity, as an acceleration", ge=0, le=20)
    mode_switch: float = param(0.01, "Dimensionless", "IMM: probability per sample of switching filter", gt=0, lt=0.5)
    # validity
    valid_std_max: float = valid_std_max_param(0.03)
    valid_hold: float = valid_hold_param(0.5)
    nis_limit: float = nis_limit_param(25.0)

    def __post_init__(self):
        super().__post_init__()
        if self.mu_min >= self.mu_max:
            raise ValueError(f"mu_min must be below mu_max (got {self.mu_min} >= {self.mu_max})")


# ------------------------------------------------------------------------------ one filter
class _Mode:
    """One extended Kalman filter on the model (module docstring), with its pseudo-measurement scale and extra
    lateral process noise (the IMM's modes; the EKF has one)."""

    __slots__ = ("kf", "r_scale", "q_vy", "monitors", "delayed", "slip", "utilisation", "friction_llr")

    def __init__(self, kf: KalmanFilter, r_scale: float, q_vy: float, window: int, history: int):
        self.kf, self.r_scale, self.q_vy = kf, r_scale, q_vy
        self.monitors = (InnovationMonitor(window), InnovationMonitor(window))   # per axle: covariance matching
        self.delayed = DelayedMeasurements(kf, history) if history else None    # fix extrapolation
        self.slip = (0.0, 0.0)               # the axles' slip angles of the last sample [rad] (their rate)
        self.utilisation = 0.0               # the larger axle's friction utilisation
        self.friction_llr = 0.0              # CUSUM of the low-friction hypothesis (friction_test)


class SideslipFusion(Estimator):
    """GNSS / IMU / wheel-speed / steering fusion with a self-calibrating tire model (module docstring)."""

    config_class = SideslipFusionConfig
    input_names = ("ax_m", "ay_m", "yaw_rate_m", "delta_m", *WHEEL_SPEEDS_M, "gps_ve", "gps_vn", "gps_fresh",
                   "gps_valid", "mag_x", "mag_y", "mag_z")
    extra_outputs = ("yaw_hat", "bias_yaw_rate_hat", "bias_ax_hat", "bias_ay_hat", "steer_offset_hat", "Cf_hat",
                     "Cr_hat", "mu_hat", "friction_utilisation", "gps_delay_hat", "slide_probability")
    needs = ("the vehicle's geometry and mass roughly right; GNSS velocity for the best accuracy (without it the "
             "tire model, calibrated while GNSS was there, carries the estimate)")
    In = input_enum("In", input_names)

    def _init_filter(self) -> None:
        cfg, ts, v = self.config, self.Ts, self.vehicle
        self._geometry = (v.l_f, v.l_r, v.C_f_nominal, v.C_r_nominal, v.C_f_nominal_lo, v.C_r_nominal_lo, v.mu_lo,
                          v.m * v.l_r / v.l, v.m * v.l_f / v.l)
        self._fz_static = (v.m * GRAVITY * v.l_r / v.l, v.m * GRAVITY * v.l_f / v.l)
        self._front_undriven = v.drive_split_front <= 0.0
        self._roll = RollCompensator(v, ts)
        n = len(Fs) if cfg.use_magnetometer else _B_MAG if cfg.delay_state else _D_GNSS
        x0 = np.zeros(n)
        if cfg.delay_state:
            x0[_D_GNSS] = cfg.gps_latency
        x0[Fs.LN_MU] = math.log(cfg.mu0)
        p0 = np.array([1.0, 1.0, 10.0, cfg.gyro_offset_std0, cfg.accel_offset_std0, cfg.accel_offset_std0,
                       cfg.steer_offset_std0, cfg.stiffness_std0, cfg.stiffness_std0, cfg.mu_std0,
                       cfg.radius_error_std0, cfg.bank_std0, cfg.gps_latency_std, cfg.mag_offset_std0][:n]) ** 2
        self._p_cap = p0.copy()
        self._p_cap[:3] = np.inf                               # velocity and heading: no cap
        q = np.array([cfg.sigma_accel * ts, cfg.sigma_accel * ts, cfg.sigma_gyro * ts,
                      cfg.gyro_offset_walk * math.sqrt(ts), cfg.accel_offset_walk * math.sqrt(ts),
                      cfg.accel_offset_walk * math.sqrt(ts), 1e-6 * math.sqrt(ts), cfg.stiffness_walk * math.sqrt(ts),
                      cfg.stiffness_walk * math.sqrt(ts), cfg.mu_walk * math.sqrt(ts), 1e-5 * math.sqrt(ts),
                      cfg.bank_walk * math.sqrt(ts), cfg.delay_walk * math.sqrt(ts) if cfg.delay_state else 0.0,
                      cfg.mag_offset_walk * math.sqrt(ts)][:n]) ** 2
        self._q = q
        self._robust = cfg.formulation == EKF
        # the EKF's robustness: correlated model error, covariance matching, Huber; the IMM's is its slide filter,
        # whose likelihoods need the per-sample (white) noise
        self._corr = max(cfg.slip_correlation_time / ts, 1.0) if self._robust else 1.0
        self._bounds = ((_LN_CF, math.log(cfg.stiffness_min), math.log(cfg.stiffness_max)),
                        (_LN_CR, math.log(cfg.stiffness_min), math.log(cfg.stiffness_max)),
                        (_LN_MU, math.log(cfg.mu_min), math.log(cfg.mu_max)))
        window = max(int(round(cfg.adapt_window / ts)), 1)
        history = int(math.ceil(cfg.max_delay / ts)) + 2
        self._max_lag = history - 2
        # the delay state: bounded by the history, and the body's accelerations of its samples for its Jacobian
        self._acc_line = DelayLine(history, 2) if cfg.delay_state else None
        if cfg.delay_state:
            self._bounds += ((_D_GNSS, 0.0, self._max_lag * ts),)
        # the samples a delayed fix needs: the filters' own (extrapolation) or the inputs and snapshots (re-run)
        self._history = None if cfg.fix_extrapolation else deque(maxlen=history)
        per_filter = history if cfg.fix_extrapolation else 0
        modes = [_Mode(KalmanFilter(x0, np.diag(p0)), 1.0, 0.0, window, per_filter)]
        if cfg.formulation == IMM:
            modes.append(_Mode(KalmanFilter(x0, np.diag(p0)), cfg.slide_factor, (cfg.slide_accel * ts) ** 2,
                               window, per_filter))
            self._prob = np.array([0.9, 0.1])
            p = cfg.mode_switch
            self._trans = np.array([[1.0 - p, p], [p, 1.0 - p]])
        else:
            self._prob = np.array([1.0])
        self._modes = modes
        self._x, self._P = x0.copy(), np.diag(p0)              # the combined estimate
        self._heading_known = False
        self._latency = GpsLatency(ts, cfg.gps_latency, cfg.gps_latency_std, cfg.identify_delay and not cfg.delay_state,
                                   min(cfg.max_delay, 0.5))
        self._gps_nis = InnovationMonitor(10, cfg.nis_limit)
        self._gate = ValidityGate(cfg.valid_std_max, cfg.valid_hold)
        self._r_prev = None
        self._r_dot = self._accel = 0.0
        self._ln_mu_floor = math.log(cfg.mu_min)
        self._ln_mu0, self._inv_mu_std, self._inv_c_std = math.log(cfg.mu0), 1.0 / cfg.mu_std0, 1.0 / cfg.stiffness_std0
        self._x_rate = 0.0
        self._row_mu = _EYES[n][_LN_MU]
        self._mag_last, self._mag_age = None, 0
        self._mag_window = max(int(round(1.0 / ts)), 1)
        self._mag_nis = InnovationMonitor(self._mag_window, cfg.mag_nis_limit)
        self._mag_off = False
        self._started = False
        self._extra_values = self._compute_extras()

    # ---------------------------------------------------------------- one sample of the model
    def _inputs(self, u: list, vw: float) -> tuple:
        """The sample's model inputs from the sensors: ``(a_x, a_y, r_m, delta_m, v_wheel, F_yf, F_yr, F_zf, F_zr)``
        (``a_y`` roll-compensated, the axle forces from the balances, the axle loads with the longitudinal load
        transfer)."""
        I, cfg, ts, v = self.In, self.config, self.Ts, self.vehicle
        r_m, ax = u[I.YAW_RATE_M], u[I.AX_M]
        ay = self._roll(u[I.AY_M])
        if self._r_prev is not None:
            self._r_dot = lowpass(self._r_dot, (r_m - self._r_prev) / ts, ts, cfg.yaw_acc_cutoff)
        self._r_prev = r_m
        b_ay = self._x[_B_AY]
        # friction floor: the measured horizontal acceleration (offsets removed, low-passed against noise)
        a = math.hypot(ax - self._x[_B_AX], ay - b_ay)
        self._accel = lowpass(self._accel, a, ts, 1.0)
        self._ln_mu_floor = math.log(max(cfg.mu_min, min(0.9 * self._accel / GRAVITY, cfg.mu_max)))
        fyf, fyr = axle_forces(v.m, v.I_zz, v.l_f, v.l_r, ay - b_ay, self._r_dot)
        fx = v.m * (ax - self._x[_B_AX])
        shift = fx * v.h_cg / v.l                                    # longitudinal load transfer
        fzf, fzr = max(self._fz_static[0] - shift, 0.2 * self._fz_static[0]), \
            max(self._fz_static[1] + shift, 0.2 * self._fz_static[1])
        # the axles' longitudinal forces by the drive or brake split (drag and rolling resistance neglected)
        if cfg.combined_slip:
            front = v.drive_split_front if fx > 0.0 else v.brake_split_front
            fxf, fxr = front * fx, (1.0 - front) * fx
        else:
            fxf = fxr = 0.0
        return (ax, ay, r_m, u[I.DELTA_M], vw, fyf, fyr, fzf, fzr, fxf, fxr)

    def _advance(self, mode: _Mode, inp: tuple, vx_ref: float) -> float:
        """Time update and the wheel-speed and tire updates of one filter for one sample; returns the log-likelihood
        of the tire pseudo-measurements."""
        cfg, ts = self.config, self.Ts
        ax, ay, r_m, delta, vw, fyf, fyr, fzf, fzr, fxf, fxr = inp
        kf = mode.kf
        xp, F = kinematic_step(kf.x, ax, ay, r_m, ts)
        # a parameter whose variance has reached its prior's gets no more process noise (nothing shows it)
        q = self._q * (kf.P.ravel()[::len(kf.x) + 1] < self._p_cap)      # (the diagonal's view)
        q[_VY] += mode.q_vy
        kf.predict(xp, F, q)
        # the undriven wheels: their slip grows with the longitudinal acceleration
        h, row = wheel_model(kf.x)
        if self._front_undriven:                    # front wheels turn with the steering
            h, row = h * math.cos(delta), row * math.cos(delta)
        # braked or driven wheels slip by up to the friction utilisation of the longitudinal acceleration squared
        grip = abs(ax) / (math.exp(kf.x.item(_LN_MU)) * GRAVITY)
        sigma_w = 0.03 + 0.01 * abs(vw) + 0.05 * abs(ax) + 0.2 * abs(vw) * grip * grip
        rw = sigma_w * sigma_w
        Ph = kf.P.dot(row)
        var = float(row.dot(Ph)) + rw
        y = vw - h
        if y * y > cfg.pseudo_gate ** 2 * var:     # Huber: a locking or spinning wheel is weighed as if at the gate
            rw += y * y / cfg.pseudo_gate ** 2 - var
        kf.update_scalar(y, row, rw, Ph)
        loglik = 0.0
        if vx_ref > self.config.v_min:
            x0 = kf.x
            axles = axle_pseudo(x0, (r_m, delta, fyf, fyr, fzf, fzr, fxf, fxr), self._geometry, cfg.utilisation_max)
            if cfg.friction_test > 0.0 and self._friction_test(mode, x0, axles, inp, vx_ref):
                x0 = kf.x
                axles = axle_pseudo(x0, (r_m, delta, fyf, fyr, fzf, fzr, fxf, fxr), self._geometry,
                                    cfg.utilisation_max)
            rates = ((axles[0][2] - mode.slip[0]) / ts, (axles[1][2] - mode.slip[1]) / ts)
            mode.slip = (axles[0][2], axles[1][2])
            mode.utilisation = max(axles[0][3], axles[1][3])
            # the friction's uncertainty is not in the rows where the tire is linear (d alpha / d ln mu ~ 0): a road
            # slipperier than estimated would make the brush model wrong by more than its own utilisation says
            doubt = math.exp(cfg.friction_doubt * math.sqrt(kf.P.item(_LN_MU, _LN_MU)))
            # how far each axle's stiffness lies below the file beyond its prior std and the friction's fall
            mu_fall = abs(x0.item(_LN_MU) - self._ln_mu0) * self._inv_mu_std
            softness = (-x0.item(_LN_CF) * self._inv_c_std - 1.0 - mu_fall,
                        -x0.item(_LN_CR) * self._inv_c_std - 1.0 - mu_fall)
            for (h, row, alpha, util, alpha_max, g), rate, monitor, soft in zip(axles, rates, mode.monitors,
                                                                                 softness):
                slip_state = alpha - h / vx_ref if alpha >= 0.0 else h / vx_ref - alpha     # along the force
                if cfg.sliding_friction and util > 0.05 and slip_state > alpha_max:     # (a force to take the log of)
                    # the state's slip is beyond the brush tire's at utilisation_max (where its inverse has no
                    # answer): the axle slides, |F_y| = F_max, which measures the friction and says nothing of the slip
                    y = -math.log(util) + g * (kf.x.item(_LN_MU) - x0.item(_LN_MU))
                    rs = cfg.sliding_friction_std ** 2 * self._corr
                    row_s = self._row_mu * -g
                    Ph = kf.P.dot(row_s)
                    var = float(row_s.dot(Ph)) + rs
                    nis = kf.update_scalar(y, row_s, rs, Ph)
                    loglik -= 0.5 * (nis + math.log(2.0 * math.pi * var))
                    continue
                h += float(row.dot(kf.x - x0))      # the residual after the other axle's update (linearised)
                if util >= cfg.utilisation_max and h * alpha <= 0.0:
                    continue                        # saturated: the clipped slip is a lower bound, and the state's
                    #                                 slip exceeds it the same way (a slide): nothing to correct
                util *= doubt
                util = util if util < 1.0 else 1.0
                rel = cfg.slip_model_error * util * util
                if soft > 0.0:
                    rel += cfg.stiffness_doubt * soft
                s = (cfg.sigma_slip + rel * abs(alpha)
                     + cfg.relaxation_length / vx_ref * abs(rate)) * vx_ref * mode.r_scale
                rr = s * s * self._corr
                Ph = kf.P.dot(row)
                prior = float(row.dot(Ph))
                monitor.add(h * h / (prior + rr))
                if self._robust:                    # covariance matching (EKF only, see _init_filter)
                    rr *= monitor.inflation() ** 2
                var = prior + rr
                if self._robust and h * h > cfg.pseudo_gate ** 2 * var:   # Huber: weighed as if at the gate
                    rr += h * h / cfg.pseudo_gate ** 2 - var
                    var = h * h / cfg.pseudo_gate ** 2
                nis = kf.update_scalar(-h, row, rr, Ph)
                loglik -= 0.5 * (nis + math.log(2.0 * math.pi * var))
        self._bound(kf)
        return loglik

    def _friction_test(self, mode: _Mode, x0: np.ndarray, axles: tuple, inp: tuple, vx_ref: float) -> bool:
        """CUSUM of the tire pseudo-measurements' log-likelihood ratio, the best of a few lower frictions against the
        estimate (module docstring); beyond ``friction_test`` the friction is re-initialised at that hypothesis with
        its prior's std and no correlation.  Returns True if it was."""
        cfg, kf = self.config, mode.kf
        ln_mu = x0.item(_LN_MU)
        top = ln_mu - 2.0 * math.sqrt(kf.P.item(_LN_MU, _LN_MU))
        util = max(axles[0][3], axles[1][3])
        best, best_ln, weights = 0.0, 0.0, None
        fyf, fyr, fzf, fzr, fxf, fxr = inp[5:]
        g, vx, u_max = self._geometry, x0.item(_VX), cfg.utilisation_max
        ln_cf, ln_cr = x0.item(_LN_CF), x0.item(_LN_CR)
        for ln_c in _FRICTION_HYPOTHESES:
            # apart from the estimate only where its tire is nonlinear, and informative only short of saturation
            if ln_c > top or not 0.5 <= util * math.exp(ln_mu - ln_c) <= 0.85:
                continue
            if weights is None:
                # one noise for every hypothesis: the fits are compared, not how much each model claims to know
                weights = []
                for _, row, alpha, *_ in axles:
                    s = (cfg.sigma_slip + _TEST_MODEL_ERROR * cfg.slip_model_error * abs(alpha)) * vx_ref
                    weights.append(0.5 / (float(row.dot(kf.P.dot(row))) + s * s * self._corr))
            # a residual moves with its axle's slip angle times v_x (axle_pseudo)
            mu_c, llr = math.exp(ln_c), 0.0
            for (h, _, alpha, *_), w, force, f_z, f_x, c_hi, c_lo, ln_s in zip(
                    axles, weights, (fyf, fyr), (fzf, fzr), (fxf, fxr), g[2:4], g[4:6], (ln_cf, ln_cr)):
                h_c = h + vx * (axle_slip(force, f_z, f_x, c_hi, c_lo, g[6], ln_s, mu_c, u_max)[0] - alpha)
                llr += w * (h * h - h_c * h_c)
            if llr > best:
                best, best_ln = llr, ln_c
        if best <= 0.0:
            mode.friction_llr = 0.0
            return False
        mode.friction_llr += best
        if mode.friction_llr < cfg.friction_test:
            return False
        mode.friction_llr = 0.0
        kf.x[_LN_MU] = best_ln
        kf.P[_LN_MU, :] = 0.0
        kf.P[:, _LN_MU] = 0.0
        kf.P[_LN_MU, _LN_MU] = cfg.mu_std0 ** 2
        return True

    def _bound(self, kf: KalmanFilter) -> None:
        """Clamp the bounded states (module docstring)."""
        x = kf.x
        for i, lo, hi in self._bounds:
            if x[i] < lo:
                x[i] = lo
            elif x[i] > hi:
                x[i] = hi
        if x[_LN_MU] < self._ln_mu_floor:        # the road carries at least what the car is measured to do
            x[_LN_MU] = self._ln_mu_floor


    def _sample_all(self, inp: tuple, vx_ref: float) -> None:
        """One sample of every filter and, for the IMM, the mixing before and the mode probabilities after."""
        modes = self._modes
        if len(modes) == 1:
            self._advance(modes[0], inp, vx_ref)
            return
        # IMM mixing (interaction) with the mode probabilities of the last sample
        trans, prob = self._trans, self._prob
        c = trans.T.dot(prob)                            # predicted mode probabilities
        w = trans * prob[:, None] / c[None, :]           # w[i, j]: weight of filter i in the mixed prior of j
        xs = [m.kf.x for m in modes]
        Ps = [m.kf.P for m in modes]
        mixed = []
        for j in range(len(modes)):
            x0 = w[0, j] * xs[0] + w[1, j] * xs[1]
            P0 = np.zeros_like(Ps[0])
            for i in range(len(modes)):
                d = xs[i] - x0
                P0 += w[i, j] * (Ps[i] + np.outer(d, d))
            mixed.append((x0, P0))
        for m, (x0, P0) in zip(modes, mixed):
            m.kf.x, m.kf.P = x0, P0
        logs = np.array([self._advance(m, inp, vx_ref) for m in modes])
        like = np.exp(logs - logs.max()) * c
        self._prob = np.maximum(like / like.sum(), 1e-6)
        self._prob /= self._prob.sum()

    def _combine(self) -> None:
        """The combined estimate ``self._x``, ``self._P`` (the IMM's moment-matched mixture)."""
        modes = self._modes
        if len(modes) == 1:
            self._x, self._P = modes[0].kf.x, modes[0].kf.P
            return
        p = self._prob
        x = p[0] * modes[0].kf.x + p[1] * modes[1].kf.x
        P = np.zeros_like(modes[0].kf.P)
        for pi, m in zip(p, modes):
            d = m.kf.x - x
            P += pi * (m.kf.P + np.outer(d, d))
        self._x, self._P = x, P

    # ---------------------------------------------------------------- GNSS
    def _gnss_update(self, ve: float, vn: float, accel: float, lag: int = 0, acc=None,
                     at: float = 0.0) -> float | None:
        """Apply a fix taken ``lag`` samples ago to every filter (extrapolated to now, :class:`DelayedMeasurements`;
        at the current sample without them); returns the (probability-weighted) NIS, None if the fix was skipped.
        With the delay state, ``acc`` is the body's measured ``(a_x, a_y)`` of the sample the fix is compared with
        and ``at`` its age [s]."""
        cfg = self.config
        # the delay's uncertainty: noise of the acceleration's size, or (delay state) the state's
        noise = cfg.sigma_gnss ** 2 + (0.0 if acc is not None else (accel * self._latency.std) ** 2)
        R = np.eye(2) * noise
        z = np.array([ve, vn])
        models = []
        for m in self._modes:
            x_s, P_s = (m.kf.x, m.kf.P) if m.delayed is None else m.delayed.past(lag)
            try:
                # the IMM's mixing moves its filters without their stored samples, whose covariance the corrections
                # of later fixes can then leave indefinite: such a fix is skipped, not applied with a negative NIS
                np.linalg.cholesky(P_s)
            except np.linalg.LinAlgError:
                return None
            if acc is None:
                h, H = gnss_model(x_s)
                r_m = R
            else:                                   # the delay's error along the track is noise (gnss_delayed_model)
                h, H, track, along = gnss_delayed_model(x_s, acc[0], acc[1], at)
                r_m = R + (along * along * P_s.item(_D_GNSS, _D_GNSS)) * np.outer(track, track)
            models.append((h, H, r_m, H.dot(P_s).dot(H.T) + r_m))
        nis_sum, logs = 0.0, []
        for m, (h, H, r_m, S) in zip(self._modes, models):
            nis = m.kf.update(z - h, H, r_m) if m.delayed is None else m.delayed.update(lag, z - h, H, r_m)
            self._bound(m.kf)
            nis_sum += nis
            logs.append(-0.5 * (nis + math.log(max(np.linalg.det(S), 1e-300))))
        if len(self._modes) > 1:
            logs = np.array(logs)
            like = np.exp(logs - logs.max()) * self._prob
            self._prob = np.maximum(like / like.sum(), 1e-6)
            self._prob /= self._prob.sum()
        return nis_sum / len(self._modes)

    def _snapshot(self) -> list:
        return [(m.kf.x.copy(), m.kf.P.copy(), m.slip) for m in self._modes] + [self._prob.copy()]

    def _restore(self, snap: list) -> None:
        for m, (x, P, slip) in zip(self._modes, snap):
            m.kf.x, m.kf.P, m.slip = x.copy(), P.copy(), slip
        self._prob = snap[-1].copy()

    def _apply_fix(self, ve: float, vn: float, accel: float) -> float | None:
        """A fix taken ``delay`` ago, at its own sample (module docstring): extrapolated to now, or applied there
        and the filter re-run to now from the stored inputs."""
        hist = self._history
        if self._acc_line is not None:
            lag = min(max(int(round(float(self._x[_D_GNSS]) / self.Ts)), 0), self._max_lag)
            # the sample compared is the oldest kept while fewer are (after the heading's initialisation): the
            # linearisation's age must be that sample's
            kept = len(self._modes[0].delayed) if hist is None else len(hist)
            lag = min(lag, max(kept - 1, 0))
            acc = self._acc_line.delayed(lag)
        else:
            lag, acc = self._latency.lag(self.Ts), None
        if hist is None:
            return self._gnss_update(ve, vn, accel, lag, acc, lag * self.Ts)
        if lag <= 0 or lag >= len(hist):
            nis = self._gnss_update(ve, vn, accel, 0, acc)
            hist[-1][2] = self._snapshot()
            return nis
        s = len(hist) - 1 - lag
        self._restore(hist[s][2])
        nis = self._gnss_update(ve, vn, accel, 0, acc, lag * self.Ts)
        hist[s][2] = self._snapshot()
        for j in range(s + 1, len(hist)):
            inp, vx_ref, _, heading = hist[j]
            self._sample_all(inp, vx_ref)
            if heading is not None:                     # the magnetometer's update of that sample, again
                self._heading_update(*heading)
            hist[j][2] = self._snapshot()
        return nis

    def _init_heading(self, ve: float, vn: float) -> None:
        """The heading from a fix's course minus the current sideslip; its cross-covariances dropped."""
        course = math.atan2(vn, ve)
        for m in self._modes:
            x, P = m.kf.x, m.kf.P
            beta = math.atan2(x[Fs.VY], max(x[Fs.VX], 0.1))
            # the course of the fix's time: the heading has turned by the yaw rate times the delay since
            x[Fs.PSI] = math.remainder(course - beta + self._x_rate * self._delay(), 2.0 * math.pi)
            P[Fs.PSI, :] = 0.0
            P[:, Fs.PSI] = 0.0
            P[Fs.PSI, Fs.PSI] = 0.05 ** 2 + P[Fs.VY, Fs.VY] / max(x[Fs.VX] ** 2, 1.0)
        self._heading_known = True

    # ---------------------------------------------------------------- magnetometer
    def _magnetometer_update(self, mag: tuple) -> tuple | None:
        """The heading from a new, undisturbed magnetometer reading (module docstring), to every filter; returns
        the heading measurement ``(psi_m, variance)`` used, or None."""
        cfg = self.config
        self._mag_age += 1
        if mag == self._mag_last:                       # a held sample is not a new reading
            return None
        self._mag_last = mag
        age, self._mag_age = self._mag_age, 0
        if not abs(math.sqrt(mag[0] ** 2 + mag[1] ** 2 + mag[2] ** 2) - 1.0) <= cfg.mag_norm_gate:
            return None                                 # disturbed (or not a number)
        # the body's tilt: the roll model's roll on the road plus the road's bank (the state's gravity term)
        phi = self._roll.phi
        bank = math.asin(max(-0.5, min(float(self._x[_G_Y]) / GRAVITY, 0.5)))
        psi_m, dpsi_dtilt, h2 = tilt_compensated_heading(mag, phi + bank, cfg.mag_declination)
        if h2 < 1e-4:                                   # no horizontal field to point with
            return None
        # the tilt's error: the roll model's, the bank estimate's (its state's std) and the rest (pitch)
        tilt_var = (cfg.mag_tilt_std + cfg.mag_roll_error * abs(phi)) ** 2 + self._P.item(_G_Y, _G_Y) / GRAVITY ** 2
        # it lasts (a roll model wrong in a turn, a bank): its share counts once per correlation time
        r = cfg.sigma_mag ** 2 / h2 + dpsi_dtilt ** 2 * tilt_var * max(cfg.mag_tilt_correlation_time
                                                                        / (age * self.Ts), 1.0)
        P = self._P
        prior = P.item(_PSI, _PSI) + P.item(_B_MAG, _B_MAG) + 2.0 * P.item(_PSI, _B_MAG)
        y = math.remainder(psi_m - magnetometer_model(self._x)[0], 2.0 * math.pi)
        # the readings' consistency, each one's error counted once: a heading error that lasts (a hard iron not
        # removed, turning with the heading) shows in the window where each reading alone passes the gate
        self._mag_nis.add(y * y / (prior + cfg.sigma_mag ** 2 / h2 + dpsi_dtilt ** 2 * tilt_var))
        if cfg.mag_gate > 0.0 and y * y > cfg.mag_gate ** 2 * (prior + r):
            return None                                 # a disturbance whose norm is near unity: not the heading
        if cfg.mag_nis_limit > 0.0:
            # found inconsistent, the magnetometer is used again only once the window is half the limit
            ratio = self._mag_nis.ratio if self._mag_nis.count >= self._mag_window else 0.0
            self._mag_off = ratio > (0.5 if self._mag_off else 1.0) * cfg.mag_nis_limit
            if self._mag_off:
                return None
        self._heading_update(psi_m, r)
        return psi_m, r

    def _heading_update(self, psi_m: float, r: float) -> None:
        """A magnetometer's heading ``psi_m`` of variance ``r`` [rad2], to every filter."""
        for m in self._modes:
            h, row = magnetometer_model(m.kf.x)
            m.kf.update_scalar(math.remainder(psi_m - h, 2.0 * math.pi), row, r)
        self._combine()

    # ---------------------------------------------------------------- the sample
    def _sample(self, u):
        I, cfg = self.In, self.config
        vw = self.speed(u)
        if not self._started:                          # start at the wheels' speed, straight ahead
            if vw < 0.5 * cfg.v_min:
                self.vx, self.yaw_rate, self.valid = vw, u[I.YAW_RATE_M], False
                return
            for m in self._modes:
                m.kf.x[Fs.VX] = vw
                m.kf.P[Fs.VX, Fs.VX] = 0.1 ** 2
                m.kf.P[Fs.VY, Fs.VY] = (0.05 * vw) ** 2
            self._started = True
        inp = self._inputs(u, vw)
        if self._acc_line is not None:
            self._acc_line.push(inp[:2])
        vx_ref = float(self._x[_VX])
        self._sample_all(inp, vx_ref)
        if self._history is None:
            for m in self._modes:
                m.delayed.push()
        else:
            self._history.append([inp, vx_ref, self._snapshot(), None])
        self._combine()
        x = self._x
        r = inp[2] - x[_B_R]
        self._x_rate = r
        self._latency.push(r, self.beta)
        gnss = cfg.use_gnss and u[I.GPS_VALID] != 0.0
        fresh = gnss and u[I.GPS_FRESH] != 0.0
        if fresh:
            ve, vn = u[I.GPS_VE], u[I.GPS_VN]
            speed = math.hypot(ve, vn)
            if speed > cfg.course_speed:
                self._latency.add_fix(math.atan2(vn, ve), r)
            if not self._heading_known or self._P[_PSI, _PSI] > cfg.heading_reset ** 2:
                if speed > cfg.course_speed:
                    self._init_heading(ve, vn)
                    if self._history is None:
                        for m in self._modes:
                            m.delayed.clear()
                    else:
                        self._history.clear()
                        self._history.append([inp, vx_ref, self._snapshot(), None])
            else:
                nis = self._apply_fix(ve, vn, math.hypot(inp[0], inp[1]))
                if nis is not None:
                    self._gps_nis.add(nis, 2)
            self._combine()
            x = self._x
        if cfg.use_magnetometer and self._heading_known:
            heading = self._magnetometer_update((u[I.MAG_X], u[I.MAG_Y], u[I.MAG_Z]))
            if heading is not None and self._history is not None:     # a fix's re-run repeats it
                self._history[-1][2:] = [self._snapshot(), heading]
            x = self._x
        x[_PSI] = math.remainder(x[_PSI], 2.0 * math.pi)
        for m in self._modes:
            m.kf.x[_PSI] = math.remainder(m.kf.x[_PSI], 2.0 * math.pi)
        P = self._P
        vx, vy = float(x[_VX]), float(x[_VY])
        self.vx, self.vy, self.yaw_rate = vx, vy, float(inp[2] - x[_B_R])
        self.beta = math.atan2(vy, vx) if vx > 0.1 else 0.0
        std = beta_std(vx, vy, P[_VX, _VX], P[_VY, _VY], P[_VX, _VY])
        if gnss and self._heading_known:
            std *= self._gps_nis.inflation()
        self.beta_std = std
        self.valid = (vx > cfg.v_min and vw > cfg.v_min and (self._heading_known or not gnss)
                      and (not gnss or self._gps_nis.consistent))
        self._extra_values = self._compute_extras()

    def _delay(self) -> float:
        """The GNSS delay in use [s]."""
        return float(self._x[_D_GNSS]) if self.config.delay_state else self._latency.value

    def _extras(self) -> tuple:
        return self._extra_values

    def _compute_extras(self) -> tuple:
        """The extra outputs of the current estimate (once per sample: the outputs read them every step)."""
        x, g = self._x, self._geometry
        mu = math.exp(x[_LN_MU])
        c_f = axle_stiffness(g[2], g[4], g[6], mu)[0] * math.exp(x[_LN_CF])
        c_r = axle_stiffness(g[3], g[5], g[6], mu)[0] * math.exp(x[_LN_CR])
        utilisation = sum(p * m.utilisation for p, m in zip(self._prob, self._modes))
        return (math.remainder(float(x[_PSI]), 2.0 * math.pi), float(x[_B_R]), float(x[_B_AX]),
                float(x[_B_AY]), float(x[_D_DELTA]), c_f, c_r, mu, min(float(utilisation), 1.0),
                self._delay(), float(self._prob[1]) if len(self._prob) > 1 else 0.0)

    def _pack(self) -> tuple:
        return self._gate(self, super()._pack())

    def kalman_filters(self) -> list:
        return [m.kf for m in self._modes]
