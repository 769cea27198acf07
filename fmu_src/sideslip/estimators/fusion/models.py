"""The fusion filter's models: the kinematic time update and one pure function per measurement.

Each function takes the state (:class:`~sideslip.estimators.fusion.state.Fs`) and the sample's
inputs and returns a named result: the predicted value and its Jacobian row or matrix, and, for a
whole measurement, its innovation and noise.  What to do with a measurement (gate it, down-weight
it, skip it) is the filter's (:mod:`~sideslip.estimators.fusion.mode`).

* :func:`kinematic_step` - the body-frame velocity driven by the accelerometers,
  ``dvx/dt = a_x - b_ax + r v_y``, ``dvy/dt = (1 - k_ay) a_y - b_ay - g_y - r v_x`` with ``r = r_m - b_r``, and
  the heading ``dpsi/dt = r``: exact for any tire and friction, drifting with the offsets, which are states
  (``k_ay a_y`` is the roll's gravity the vehicle file's roll model misses).
* :func:`wheel_measurement` - the undriven axle's mean wheel speed ``(1 + e_w) v_x``, noisier the more
  the axle is braked or driven.
* :func:`axle_pseudo` - one tire pseudo-measurement per axle: the slip angle the brush tire gives the
  axle's measured force (:mod:`~sideslip.estimators.fusion.tire_model`) ties the lateral velocity to
  the yaw rate and the steering, ``v_y - l_r r + v_x alpha_r = 0`` and
  ``v_y + l_f r - v_x (delta_m - d_delta - alpha_f) = 0``.
* :func:`sliding_friction_measurement` - a sliding axle carries all its friction,
  ``ln(|F_y| / F_max) = 0``: a measurement of the friction, not of the slip.
* :func:`gnss_measurement` - the GNSS velocity ``v_e = v_x cos psi - v_y sin psi``,
  ``v_n = v_x sin psi + v_y cos psi`` of a past sample, with the delay state ``D`` linearised by the
  acceleration across the track (:func:`gnss_delayed_model`).
* :func:`magnetometer_model` - the heading ``psi + b_mag``.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ...constants import GRAVITY
from ...vehicles import VehicleParams
from .state import Fs
from .tire_model import axle_slip_values

__all__ = ["Geometry", "SampleInputs", "Prediction", "Observation", "ScalarMeasurement", "VectorMeasurement",
           "AxlePseudo", "kinematic_step", "gnss_model", "track_acceleration", "gnss_delayed_model",
           "gnss_measurement", "magnetometer_model", "wheel_model", "wheel_measurement", "axle_pseudo",
           "sliding_friction_measurement"]

# identities by state size (np.eye costs three times a copy) and plain-int copies of the indices: indexing with an
# IntEnum member costs four times more
_EYES = {n: np.eye(n) for n in (len(Fs) - 2, len(Fs) - 1, len(Fs))}
_VX, _VY, _PSI, _B_R, _B_AX, _B_AY, _D_DELTA, _LN_CF, _LN_CR, _LN_MU, _E_W, _G_Y, _K_AY, _D_GNSS, _B_MAG = (
    int(s) for s in Fs)


class Geometry(NamedTuple):
    """The vehicle file's axles as the tire pseudo-measurements need them."""

    l_f: float                  #: CG to front axle [m]
    l_r: float                  #: CG to rear axle [m]
    c_f: float                  #: front axle cornering stiffness at friction 1 [N/rad]
    c_r: float                  #: rear axle cornering stiffness at friction 1 [N/rad]
    c_f_lo: float               #: front axle cornering stiffness at friction ``mu_lo`` [N/rad]
    c_r_lo: float               #: rear axle cornering stiffness at friction ``mu_lo`` [N/rad]
    mu_lo: float                #: the low friction of the vehicle file's stiffness
    m_f: float                  #: the front axle's share of the mass, ``m l_r / l`` [kg] (``d F_yf / d a_y``)
    m_r: float                  #: the rear axle's share, ``m l_f / l`` [kg]

    @classmethod
    def from_vehicle(cls, v: VehicleParams) -> "Geometry":
        return cls(v.l_f, v.l_r, v.C_f_nominal, v.C_r_nominal, v.C_f_nominal_lo, v.C_r_nominal_lo, v.mu_lo,
                   v.m * v.l_r / v.l, v.m * v.l_f / v.l)


class SampleInputs(NamedTuple):
    """A sample's model inputs from the sensors (:class:`~sideslip.estimators.fusion.inputs.InputConditioner`)."""

    ax: float                   #: measured longitudinal acceleration [m/s2]
    ay: float                   #: measured lateral acceleration, roll-compensated with the vehicle file [m/s2]
    r_m: float                  #: measured yaw rate [rad/s]
    delta: float                #: measured road-wheel angle [rad]
    v_wheel: float              #: the undriven wheels' speed [m/s]
    fy_f: float                 #: front axle lateral force from the balances [N]
    fy_r: float                 #: rear axle lateral force [N]
    fz_f: float                 #: front axle load with the longitudinal load transfer [N]
    fz_r: float                 #: rear axle load [N]
    fx_f: float                 #: front axle longitudinal force by the drive or brake split [N]
    fx_r: float                 #: rear axle longitudinal force [N]


class Prediction(NamedTuple):
    """A time update: the predicted state and the step's Jacobian."""

    x: np.ndarray
    F: np.ndarray


class Observation(NamedTuple):
    """A model's predicted measurement and its Jacobian row."""

    h: float
    row: np.ndarray


class ScalarMeasurement(NamedTuple):
    """A scalar measurement: innovation ``z - h(x)``, Jacobian row and noise variance."""

    innovation: float
    row: np.ndarray
    variance: float


class VectorMeasurement(NamedTuple):
    """A vector measurement: innovation ``z - h(x)``, Jacobian and noise covariance."""

    innovation: np.ndarray
    H: np.ndarray
    R: np.ndarray


class AxlePseudo(NamedTuple):
    """One axle's tire pseudo-measurement (:func:`axle_pseudo`), measured zero."""

    residual: float             #: h(x) [m/s]
    row: np.ndarray             #: its Jacobian row
    slip: float                 #: the brush tire's slip angle of the measured force [rad]
    utilisation: float          #: |F_y| / F_max
    slip_at_max: float          #: the brush tire's slip angle at utilisation u_max [rad]
    capacity_slope: float       #: d ln F_max / d ln mu


def kinematic_step(x: np.ndarray, ax: float, ay: float, r_m: float, ts: float) -> Prediction:
    """One Euler step of the kinematic model (module docstring) and its Jacobian.

    On a banked road the lateral accelerometer reads the tires' force per mass, the car's lateral
    acceleration plus ``g sin(bank)``: the bank's term ``g_y`` is a state of its own, because it moves the
    reading but is not a tire force.  The roll's gravity that the roll compensation leaves, ``k_ay a_y``, is
    neither: it is taken off like the sensor's offset.

    Parameters
    ----------
    x : ndarray
        State (:class:`~sideslip.estimators.fusion.state.Fs`).
    ax, ay : float
        Measured longitudinal and roll-compensated lateral acceleration [m/s2].
    r_m : float
        Measured yaw rate [rad/s].
    ts : float
        Step [s].
    """
    vx, vy, psi, b_r, b_ax, b_ay = x[:6].tolist()
    r = r_m - b_r
    a_y = ay - b_ay - x.item(_K_AY) * ay - x.item(_G_Y)   # the specific force minus the bank's gravity term
    xp = x.copy()
    xp[_VX] = vx + ts * (ax - b_ax + r * vy)
    xp[_VY] = vy + ts * (a_y - r * vx)
    xp[_PSI] = psi + ts * r
    F = _EYES[len(x)].copy()
    F[_VX, _VY], F[_VX, _B_R], F[_VX, _B_AX] = ts * r, -ts * vy, -ts
    F[_VY, _VX], F[_VY, _B_R], F[_VY, _B_AY], F[_VY, _G_Y], F[_VY, _K_AY] = -ts * r, ts * vx, -ts, -ts, -ts * ay
    F[_PSI, _B_R] = -ts
    return Prediction(xp, F)


def gnss_model(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The GNSS velocity ``(v_e, v_n)`` [m/s] of the state and its Jacobian (2, n)."""
    vx, vy, psi = x[:3].tolist()
    c, s = math.cos(psi), math.sin(psi)
    H = np.zeros((2, len(x)))
    H[0, _VX], H[0, _VY], H[0, _PSI] = c, -s, -vx * s - vy * c
    H[1, _VX], H[1, _VY], H[1, _PSI] = s, c, vx * c - vy * s
    return np.array([vx * c - vy * s, vx * s + vy * c]), H


def track_acceleration(x: np.ndarray, ax: float, ay: float, v_ne) -> tuple[np.ndarray, np.ndarray, float]:
    """The state's horizontal acceleration ``R(psi) (a_x - b_ax, (1 - k_ay) a_y - b_ay - g_y)`` (east, north) split along and
    across the track of the velocity ``v_ne`` (east, north).

    Returns
    -------
    tuple
        The acceleration across the track (east, north) [m/s2], the track's unit vector and the acceleration along
        it [m/s2].
    """
    c, s = math.cos(x.item(_PSI)), math.sin(x.item(_PSI))
    a_x = ax - x.item(_B_AX)
    a_y = ay - x.item(_B_AY) - x.item(_K_AY) * ay - x.item(_G_Y)
    a = np.array([a_x * c - a_y * s, a_x * s + a_y * c])
    track = np.asarray(v_ne, dtype=float) / max(math.hypot(v_ne[0], v_ne[1]), 0.1)
    along = float(a.dot(track))
    return a - along * track, track, along


def gnss_delayed_model(x: np.ndarray, ax: float, ay: float, age: float) -> tuple:
    """A fix of the delay state's ``D`` ago against the state of a sample ``age`` ago: ``v(t - D) = v_s - (D - age)
    a_cross`` and its Jacobian.

    Only the acceleration across the track (the course turning, :func:`track_acceleration`) enters: along the track
    a delay shows as a speed error, which the rolling radius and the accelerometer's offset explain as well; the
    delay's error along the track is the caller's noise.  (With the whole acceleration in the Jacobian, a drive that
    accelerates from its start drives the delay to its bound and the estimate diverges.)

    Parameters
    ----------
    x : ndarray
        State of the sample (with ``D_GNSS``).
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


def gnss_measurement(z: np.ndarray, x: np.ndarray, P: np.ndarray, variance: float, acc=None,
                     age: float = 0.0) -> VectorMeasurement:
    """A GNSS velocity fix ``z`` (east, north) [m/s] against the state ``x`` (covariance ``P``) of the sample it is
    compared with.

    Parameters
    ----------
    variance : float
        The fix's noise per axis [m2/s2].
    acc : tuple of float, optional
        With the delay state: the body's measured ``(a_x, a_y)`` of that sample (:func:`gnss_delayed_model`), and
        ``age`` its age [s]; the delay's error along the track (the acceleration along it times the delay state's
        std) is added to the noise along the track.
    """
    R = np.eye(2) * variance
    if acc is None:
        h, H = gnss_model(x)
        return VectorMeasurement(z - h, H, R)
    h, H, track, along = gnss_delayed_model(x, acc[0], acc[1], age)
    return VectorMeasurement(z - h, H, R + (along * along * P.item(_D_GNSS, _D_GNSS)) * np.outer(track, track))


def magnetometer_model(x: np.ndarray) -> Observation:
    """The magnetometer's heading ``psi + b_mag`` [rad] and its Jacobian row."""
    h = np.zeros(len(x))
    h[_PSI] = h[_B_MAG] = 1.0
    return Observation(x.item(_PSI) + x.item(_B_MAG), h)


def wheel_model(x: np.ndarray) -> Observation:
    """The undriven axle's mean wheel speed ``(1 + e_w) v_x`` [m/s] and its Jacobian row."""
    vx, e_w = x.item(_VX), x.item(_E_W)
    h = np.zeros(len(x))
    h[_VX], h[_E_W] = 1.0 + e_w, vx
    return Observation((1.0 + e_w) * vx, h)


def wheel_measurement(x: np.ndarray, inp: SampleInputs, front_undriven: bool) -> ScalarMeasurement:
    """The undriven wheels' speed against :func:`wheel_model` (times ``cos(delta)`` for front wheels, which turn
    with the steering); its noise grows with the speed and with the longitudinal friction utilisation squared (a
    braked or driven wheel slips)."""
    h, row = wheel_model(x)
    if front_undriven:
        h, row = h * math.cos(inp.delta), row * math.cos(inp.delta)
    vw, ax = inp.v_wheel, inp.ax
    grip = abs(ax) / (math.exp(x.item(_LN_MU)) * GRAVITY)
    sigma_w = 0.03 + 0.01 * abs(vw) + 0.05 * abs(ax) + 0.2 * abs(vw) * grip * grip
    return ScalarMeasurement(vw - h, row, sigma_w * sigma_w)


def axle_pseudo(x: np.ndarray, inp: SampleInputs, geometry: Geometry, u_max: float) -> tuple[AxlePseudo, AxlePseudo]:
    """The two tire pseudo-measurements (module docstring), front and rear, each measured zero.

    The axles' forces come from ``(1 - k_ay) a_y - b_ay`` (the inputs carry the filter's offset and roll gain): the
    offset moves each slip angle by ``-m_axle / C`` per m/s2, taken in the linear range where it is identified (the
    brush model's ``1 / (C (1 - u)^(2/3))`` would read its own error near saturation as an accelerometer offset).
    The roll gain has no column: it is learnt from the kinematics (GNSS against the integrated accelerometer), which
    hold in a slide, where the tire model would lend it its own error (measured on the training set's brake in a
    turn on snow with GNSS 0.2 s late: 0.16 deg without the state, 0.32 with a column here, 0.23 without one).

    Parameters
    ----------
    x : ndarray
        State.
    inp : SampleInputs
        The sample's yaw rate, steering, axle forces and loads (the longitudinal forces derate the lateral
        friction; zero for the pure-slip tire).
    geometry : Geometry
        The vehicle file's axles (the states scale their stiffness).
    u_max : float
        Utilisation beyond which the slip angle is not defined by the force.
    """
    l_f, l_r, c_f, c_r, c_f_lo, c_r_lo, mu_lo, m_f, m_r = geometry
    vx, vy, _, b_r, _, _, d_delta, ln_cf, ln_cr, ln_mu = x[:_E_W].tolist()          # Fs order
    mu = math.exp(ln_mu)
    r = inp.r_m - b_r
    n = len(x)
    a_f, da_cf, da_mf, u_f, cf_s, fmf, kf, gf = axle_slip_values(inp.fy_f, inp.fz_f, inp.fx_f, c_f, c_f_lo, mu_lo,
                                                                 ln_cf, mu, u_max)
    a_r, da_cr, da_mr, u_r, cr_s, fmr, kr, gr = axle_slip_values(inp.fy_r, inp.fz_r, inp.fx_r, c_r, c_r_lo, mu_lo,
                                                                 ln_cr, mu, u_max)
    steer = inp.delta - d_delta
    h_f = vy + l_f * r - vx * (steer - a_f)
    row_f = np.zeros(n)
    row_f[_VX], row_f[_VY], row_f[_B_R], row_f[_D_DELTA] = a_f - steer, 1.0, -l_f, vx
    row_f[_LN_CF], row_f[_LN_MU], row_f[_B_AY] = vx * da_cf, vx * (gf * da_mf + kf * da_cf), -vx * m_f / cf_s
    h_r = vy - l_r * r + vx * a_r
    row_r = np.zeros(n)
    row_r[_VX], row_r[_VY], row_r[_B_R] = a_r, 1.0, l_r
    row_r[_LN_CR], row_r[_LN_MU], row_r[_B_AY] = vx * da_cr, vx * (gr * da_mr + kr * da_cr), -vx * m_r / cr_s
    k_max = 1.0 - (1.0 - u_max) ** (1.0 / 3.0)                 # the slip at u_max over the full slide's 3 F_max / C
    return (AxlePseudo(h_f, row_f, a_f, u_f, 3.0 * k_max * fmf / cf_s, gf),
            AxlePseudo(h_r, row_r, a_r, u_r, 3.0 * k_max * fmr / cr_s, gr))


def sliding_friction_measurement(axle: AxlePseudo, x: np.ndarray, x0: np.ndarray, variance: float
                                 ) -> ScalarMeasurement:
    """A sliding axle's force as its friction: ``ln(|F_y| / F_max) = 0``, linearised at ``x0`` (where ``axle`` was
    computed) and taken at ``x``; ``variance`` that of the log friction it gives."""
    g = axle.capacity_slope
    return ScalarMeasurement(-math.log(axle.utilisation) + g * (x.item(_LN_MU) - x0.item(_LN_MU)),
                             _EYES[len(x)][_LN_MU] * -g, variance)
