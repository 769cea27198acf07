"""Yoon & Peng (2014), "Robust vehicle sideslip angle estimation through a disturbance rejection filter
that integrates a magnetometer with GPS": dual Kalman filters.

Fig. 6 of the paper, every block:

1. **Heading EKF** on ``[psi, phi]`` (yaw, roll; eqs 22-23): time update with the gyro yaw and
   roll rates minus their biases, which are averaged while the car stands still; measurement
   update with the 3-axis magnetometer (zero pitch).
2. **Magnetic-disturbance rejection** (eqs 20-21): a disturbance is declared while the field
   norm deviates from unity by more than ``mag_threshold``; the measurement covariance is then
   ``R M`` with ``M = eta^2 I`` (the truncated-normal stand-in for a uniform disturbance).
3. **Sideslip KF** on ``[U, b_x, V, b_y]`` (eqs 24-25) driven by the accelerometers with the
   roll-gravity term ``g sin(phi)`` removed and the bias-corrected yaw rate; measurement: the GPS
   velocity rotated into the vehicle frame with the heading and roll (eqs 26-27);
   ``beta = atan(V/U)`` (eq 28).
4. **Measurement shifting** (Fig. 7): a GPS fix delayed by ``D`` updates the filter at the sample
   it belongs to - the state, covariance, inputs and attitude of the last ``max_delay`` seconds
   are kept in a fixed-length ring buffer - and the filter is re-propagated to now.
5. **GPS delay identification**: during straight acceleration the GPS speed is compared with
   the undriven-wheel speed shifted by each candidate delay (least squares with a free scale,
   so a rolling-radius error does not bias it); the delay with the smallest residual is used
   once enough speed change has been seen.
6. **Bicycle model during straight driving** (eq 32, Section IV): while the bias-corrected yaw
   rate is below ``r_straight`` the sideslip is the bicycle model's (a linear bicycle observer on
   the vehicle's nominal stiffness) and enters the sideslip KF as the pseudo-measurement
   ``V = U tan(beta_bicycle)`` - the observability the GPS/heading pair lacks when not turning.

Choices: the magnetometer's ``R`` uses ``sigma_mag = 0.1``, five times the sensor noise of Table II:
with the gyro biases averaged at standstill the heading drifts by less than 0.1 deg in a run, so
the magnetometer only has to hold that drift, and a smaller weight limits the harm of the
disturbances the norm test cannot see (a disturbance that rotates the field without changing
its norm).  For the same reason the norm threshold is low (0.04, twice the norm's noise: a
false alarm only costs a few samples of magnetometer weight) and the roll's process noise is
small (the roll-rate gyro's bias is known from standstill): a disturbance the test misses
otherwise tilts the roll estimate, and ``g sin(roll)`` goes straight into the lateral
acceleration.  The heading EKF starts at the first undisturbed magnetometer sample.

Frames and re-derivations: the project's axes are ISO 8855 with the yaw counter-clockwise from
east (the paper's G-frame is North-West-Up), so eq 22 becomes ``m = R_x(phi)^T R_z(psi)^T F``
with the Earth field ``F`` in ENU from the known inclination and declination (the paper's
calibrated offsets), and eq 26's rotation reads ``U = cos(psi) v_e + sin(psi) v_n``,
``V = cos(phi) (-sin(psi) v_e + cos(psi) v_n)`` (no vertical GPS velocity).  Standstill: the
gyro biases are averaged while the undriven wheels are still, after ``standstill_settle``
seconds (a car put on a banked road first settles in roll, which the roll gyro sees).

Hardened profile (``profile = 1``, the default; ``profile = 0`` is the method above), additions for
sensors, sites and drives other than the paper's, each with the failure it answers:

* **Gyro offsets as states** of the heading filter (``[psi, phi, b_r, b_p]``, slow random walks),
  corrected at a standstill (zero rate) and by the heading references below: the paper learns them
  at a standstill only, and a car that drives off at once keeps its 0.5 deg/s offset, which tilts
  the heading and the sideslip with it in every turn.  Their random walk (``q_bias``) is an
  automotive gyro's offset drift, 0.1 deg/s per 100 s at 100 Hz: a walk 17 times smaller let the
  heading drift by 1 deg over a 70 s circle.
* **The site's inclination as a state** of the heading filter (from ``mag_inclination``, uncertainty
  ``inclination_std0``): with a default 8 deg off the site's, the paper's 3-axis model reads the
  difference as roll and ``g sin(roll)`` as lateral acceleration (3.4 deg of sideslip on a real
  drive).  The roll model below makes roll and inclination separable.
* **The GPS course while driving straight**: with the yaw rate below ``r_straight`` the course minus
  the bicycle model's sideslip is the heading (Section IV's straight-driving observability, applied
  to the heading filter too), delay-compensated through a heading history.
* **Roll from the vehicle's roll model**: ``phi = m_s h_s a_y / (K_phi - m_s g h_s)`` as a
  pseudo-measurement of the roll (``sigma_roll``), instead of the magnetometer's vertical field.
* **GPS delay while turning** (:class:`~sideslip.estimators.delay.CourseDelay`) besides the
  paper's straight accelerations, which a drive at constant speed never offers.
* **Truthful uncertainty and validity**: ``beta_hat_std`` inflated by the consistency of the GPS
  velocity innovations; ``valid`` false while the GPS is out longer than ``gps_coast`` and while
  those innovations are inconsistent.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from .. import geomagnetic
from ..geomagnetic import earth_field
from ..constants import GRAVITY
from ..params import param
from ..signals import WHEEL_SPEEDS_M
from ..units import wrap_angle
from .base import beta_std, input_enum
from .baselines import BicycleObserverConfig, LinearBicycleObserver
from .delay import DelayIdentifier, GpsLatency, HardenedGpsLatencyConfig
from .kalman import InnovationMonitor, KalmanFilter
from .profiles import ProfiledConfig, ProfiledEstimator

__all__ = ["Yoon2014Config", "Yoon2014DualKF", "Hd", "Sd", "magnetometer_h", "magnetometer_H",
           "sideslip_F", "DelayIdentifier"]



class Hd(IntEnum):
    """State of the heading EKF (eq 23) and, in the hardened profile, the gyro offsets and the inclination."""
    PSI, PHI, BR, BP, INCL = range(5)


class Sd(IntEnum):
    """State of the sideslip KF (eq 25)."""
    U, BX, V, BY = range(4)


# ------------------------------------------------------------------------------ the models
def magnetometer_h(psi: float, phi: float, field) -> np.ndarray:
    """Eq 22 in ENU/ISO axes, zero pitch: ``R_x(phi)^T R_z(psi)^T F``."""
    fe, fn, fu = field
    c, s = math.cos(psi), math.sin(psi)
    bx, by = c * fe + s * fn, -s * fe + c * fn
    cp, sp = math.cos(phi), math.sin(phi)
    return np.array([bx, cp * by + sp * fu, -sp * by + cp * fu])


def magnetometer_H(psi: float, phi: float, field) -> np.ndarray:
    """Jacobian of :func:`magnetometer_h` with respect to ``[psi, phi]``."""
    fe, fn, fu = field
    c, s = math.cos(psi), math.sin(psi)
    bx, by = c * fe + s * fn, -s * fe + c * fn
    cp, sp = math.cos(phi), math.sin(phi)
    return np.array([[by, 0.0], [-cp * bx, -sp * by + cp * fu], [sp * bx, -cp * by - sp * fu]])


def sideslip_F(yaw_rate: float, ts: float) -> np.ndarray:
    """Eq 25 discretised (Euler): ``I + T_s A(dpsi/dt)`` on ``[U, b_x, V, b_y]``."""
    return np.array([[1.0, -ts, ts * yaw_rate, 0.0],
                     [0.0, 1.0, 0.0, 0.0],
                     [-ts * yaw_rate, 0.0, 1.0, -ts],
                     [0.0, 0.0, 0.0, 1.0]])


# ------------------------------------------------------------------------------ configuration
@dataclass(frozen=True)
class Yoon2014Config(ProfiledConfig, HardenedGpsLatencyConfig):
    """Parameters of :class:`Yoon2014DualKF`."""

    vehicle: str = param("kim2016_asm", "Dimensionless", "Vehicle parameter set: bundled name or TOML path")
    mu: float = param(1.0, "FrictionCoefficient", "Friction for the bicycle model's nominal stiffness (eq 32)",
                      ge=0.05, le=1.5)
    mag_inclination: float = param(geomagnetic.INCLINATION, "Angle", "Inclination of the Earth field (calibrated)",
                                   ge=-math.pi / 2, le=math.pi / 2)
    mag_declination: float = param(geomagnetic.DECLINATION, "Angle",
                                   "Declination of the Earth field (calibrated yaw offset)",
                                   ge=-math.pi, le=math.pi)
    # heading EKF
    q_psi: float = param(1e-8, "AngleVariance", "Process noise of the yaw angle per sample", gt=0, le=1)
    q_phi: float = param(1e-9, "AngleVariance", "Process noise of the roll angle per sample", gt=0, le=1)
    sigma_mag: float = param(0.1, "MagneticFluxRatio", "Magnetometer noise per axis in R (undisturbed); five times "
                             "the sensor's 0.02 by default, see the module docstring", gt=0, le=1)
    disturbance_rejection: bool = param(True, "Dimensionless", "Inflate R by eta^2 while the field norm is off "
                                        "unity (eqs 20-21)")
    mag_threshold: float = param(0.04, "MagneticFluxRatio", "Field-norm deviation from unity that declares a "
                                 "disturbance", gt=0, le=10)
    eta: float = param(30.0, "Dimensionless", "sigma_z / sigma_noise of a disturbed measurement (eq 20)", ge=1,
                       le=1e6)
    standstill_settle: float = param(1.5, "Time", "Standstill time before the gyro biases are averaged (the body "
                                     "settles on its springs first)", ge=0, le=60)
    standstill_speed: float = param(0.05, "Velocity", "Wheel speed below which the car stands still (gyro biases)",
                                    gt=0, le=1)
    # sideslip KF
    q_u: float = param(1e-6, "VelocityVariance", "Process noise of U and V per sample", gt=0, le=1)
    q_b: float = param(1e-8, "AccelerationVariance", "Process noise of b_x and b_y per sample", gt=0, le=1)
    sigma_gps: float = param(0.02, "Velocity", "GPS velocity noise per axis", gt=0, le=10)
    measurement_shifting: bool = param(True, "Dimensionless", "Apply a delayed fix at its own sample and "
                                       "re-propagate (Fig. 7); false: apply it when it arrives")
    gps_delay: float = param(0.0, "Time", "GPS delay used until it is identified", ge=0, le=2)
    identify_delay: bool = param(True, "Dimensionless", "Identify the GPS delay during straight accelerations")
    max_delay: float = param(1.0, "Time", "Largest GPS delay handled (ring-buffer length)", gt=0, le=2)
    delay_min_fixes: int = param(15, "Dimensionless", "Fixes needed before the delay is identified", ge=3, le=1000)
    delay_min_speed_change: float = param(3.0, "Velocity", "Speed change needed before the delay is identified",
                                          gt=0, le=100)
    accel_min: float = param(0.5, "Acceleration", "Longitudinal acceleration that qualifies for delay "
                             "identification", gt=0, le=20)
    # straight driving (eq 32)
    r_straight: float = param(0.03, "AngularVelocity", "Yaw rate below which the car drives straight", gt=0, le=1)
    r_bicycle: float = param(1e-3, "VelocityVariance", "Variance of the V = U tan(beta_bicycle) "
                             "pseudo-measurement", gt=0, le=100)
    # hardened profile (module docstring)
    q_bias: float = param(3e-10, "AngularVelocityVariance", "Hardened: random-walk variance of each gyro offset per "
                          "sample", gt=0, le=1)
    bias_std0: float = param(0.012, "AngularVelocity", "Hardened: initial uncertainty of the gyro offsets", gt=0, le=1)
    inclination_std0: float = param(0.2, "Angle", "Hardened: uncertainty of the site's inclination (estimated)", gt=0,
                                    le=1.6)
    q_inclination: float = param(1e-12, "AngleVariance", "Hardened: random-walk variance of the inclination per sample",
                                 gt=0, le=1)
    sigma_course: float = param(0.01, "Angle", "Hardened: noise of the straight-driving course as a heading, besides "
                                "sigma_gps / v", gt=0, le=1)
    course_speed: float = param(5.0, "Velocity", "Hardened: speed below which the course is not used", gt=0, le=50)
    sigma_roll: float = param(0.01, "Angle", "Hardened: error of the roll model's roll angle", gt=0, le=1)
    gps_coast: float = param(10.0, "Time", "Hardened: GPS outage after which the estimate is not valid", gt=0, le=600)


# ------------------------------------------------------------------------------ the estimator
class Yoon2014DualKF(ProfiledEstimator):
    """Yoon & Peng 2014 dual Kalman filters (see module docstring)."""

    config_class = Yoon2014Config
    input_names = ("ax_m", "ay_m", "yaw_rate_m", "roll_rate_m", "delta_m", *WHEEL_SPEEDS_M, "gps_ve", "gps_vn",
                   "gps_fresh", "gps_valid", "mag_x", "mag_y", "mag_z")
    extra_outputs = ("yaw_hat", "roll_hat", "bias_ax_hat", "bias_ay_hat", "gps_delay_hat", "mag_disturbed")
    needs = ("as published (profile 0): gyro biases calibrated at a standstill before driving off (an offset it "
             "could not calibrate tilts the heading, and the sideslip with it, in every turn); hardened: GPS, an "
             "undisturbed magnetometer, a flat road")
    In = input_enum("In", input_names)

    def _init_filter(self):
        cfg, ts = self.config, self.Ts
        self._field = earth_field(cfg.mag_inclination, cfg.mag_declination)
        self.heading = None                                    # started at the first magnetometer sample
        self._Q_h = np.diag([cfg.q_psi, cfg.q_phi])
        self._R_mag = np.eye(3) * cfg.sigma_mag ** 2
        self._R_mag_dist = self._R_mag * cfg.eta ** 2          # eq 21: R M with M = eta^2 I
        self._gyro_sum = [0.0, 0.0]
        self._gyro_n = 0
        self._still = 0.0                      # time standing still [s]
        self.b_r = self.b_p = 0.0
        self.kf = KalmanFilter([0.0, 0.0, 0.0, 0.0], np.diag([1.0, 0.5 ** 2, 1.0, 0.5 ** 2]))
        self._Q_s = np.diag([cfg.q_u, cfg.q_b, cfg.q_u, cfg.q_b])
        self._R_gps = np.eye(2) * cfg.sigma_gps ** 2
        self._H_gps = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])      # eq 27
        self._h_v = np.array([0.0, 0.0, 1.0, 0.0])
        # ring buffer of the last max_delay seconds: (input of the sample, pseudo-measurement, psi, phi, x, P)
        self._buffer: deque = deque(maxlen=int(math.ceil(cfg.max_delay / ts)) + 2)
        self.delay = cfg.gps_delay
        self._ident = DelayIdentifier(ts, cfg.max_delay)
        bic_cfg = BicycleObserverConfig(vehicle=cfg.vehicle, vehicle_overrides=cfg.vehicle_overrides, Ts=ts,
                                        mu=cfg.mu, v_min=cfg.v_min, consistency_check=False)
        self._bicycle = LinearBicycleObserver(bic_cfg, self.vehicle)
        self.yaw = self.roll = 0.0
        self.inclination = cfg.mag_inclination
        self.disturbed = False
        if self.hardened:
            self._hardened_init()

    def _extras(self) -> tuple:
        return (wrap_angle(self.yaw), self.roll, float(self.kf.x[Sd.BX]), float(self.kf.x[Sd.BY]), self.delay,
                1.0 if self.disturbed else 0.0)

    # ---------------------------------------------------------------- heading EKF (eqs 20-23)
    def _heading_step(self, r: float, p: float, mag: tuple) -> None:
        cfg, ts, field = self.config, self.Ts, self._field
        norm = math.sqrt(mag[0] ** 2 + mag[1] ** 2 + mag[2] ** 2)
        if self.heading is None:
            if abs(norm - 1.0) > cfg.mag_threshold:   # start from an undisturbed field only
                return
            # first sample: yaw from the horizontal field, level; the EKF refines both
            psi0 = math.atan2(field[1], field[0]) - math.atan2(mag[1], mag[0])
            self.heading = KalmanFilter([math.remainder(psi0, 2 * math.pi), 0.0], np.diag([0.1, 0.05]))
        hd = self.heading
        hd.predict(hd.x + ts * np.array([r - self.b_r, p - self.b_p]), np.eye(2), self._Q_h)     # eq 23
        self.disturbed = abs(norm - 1.0) > cfg.mag_threshold                                       # Section II.B
        R = self._R_mag_dist if (self.disturbed and cfg.disturbance_rejection) else self._R_mag    # eq 21
        psi, phi = hd.x.tolist()
        hd.update(np.array(mag) - magnetometer_h(psi, phi, field), magnetometer_H(psi, phi, field), R)  # eq 22
        hd.x[Hd.PSI] = math.remainder(hd.x[Hd.PSI], 2 * math.pi)
        self.yaw, self.roll = hd.x.tolist()

    # ---------------------------------------------------------------- sideslip KF (eqs 24-27)
    def _propagate(self, kf: KalmanFilter, u: tuple, pseudo) -> None:
        """One sample of the sideslip KF: prediction with ``u = (yaw rate, a_x, a_y - g sin(phi))``
        and, during straight driving, the bicycle pseudo-measurement ``pseudo = tan(beta_bicycle)``."""
        r, ax, ay = u
        F = sideslip_F(r, self.Ts)
        x = kf.x
        kf.predict(F.dot(x) + self.Ts * np.array([ax, 0.0, ay, 0.0]), F, self._Q_s)
        if pseudo is not None:                   # V = U tan(beta_bicycle), linearised about the prior U
            h = np.array([-pseudo, 0.0, 1.0, 0.0])
            kf.update_scalar(-float(h.dot(kf.x)), h, self.config.r_bicycle)

    def _gps_update(self, kf: KalmanFilter, ve: float, vn: float, psi: float, phi: float, accel=None) -> float:
        c, s = math.cos(psi), math.sin(psi)
        z = np.array([c * ve + s * vn, math.cos(phi) * (-s * ve + c * vn)])      # eq 26
        R = self._R_gps
        if self.hardened:
            R = R + self._hardened_gps_noise(kf, accel)
        return kf.update(z - self._H_gps.dot(kf.x), self._H_gps, R)             # eq 27

    def _sample(self, u):
        I, cfg, ts = self.In, self.config, self.Ts
        vw = self.speed(u)
        r_m, p_m, ax_m, ay_m = u[I.YAW_RATE_M], u[I.ROLL_RATE_M], u[I.AX_M], u[I.AY_M]
        self._still = self._still + ts if abs(vw) < cfg.standstill_speed else 0.0
        mag = (u[I.MAG_X], u[I.MAG_Y], u[I.MAG_Z])
        if self.hardened:
            self._hardened_heading(r_m, p_m, mag, ay_m - float(self.kf.x[Sd.BY]), self._still > cfg.standstill_settle)
        else:
            if self._still > cfg.standstill_settle:  # gyro biases at a standstill, once settled (Section III.A)
                self._gyro_sum[0] += r_m
                self._gyro_sum[1] += p_m
                self._gyro_n += 1
                self.b_r, self.b_p = self._gyro_sum[0] / self._gyro_n, self._gyro_sum[1] / self._gyro_n
            self._heading_step(r_m, p_m, mag)
        if self.heading is None:
            return
        r = r_m - self.b_r
        kf = self.kf
        straight = abs(r) < cfg.r_straight
        # bicycle model (eq 32), its pseudo-measurement in straight driving
        self._bicycle.advance(vw, u[I.DELTA_M], r)
        pseudo = math.tan(self._bicycle.beta) if straight and self._bicycle.valid else None
        if straight and vw < cfg.v_min:
            pseudo = 0.0                          # standing or creeping straight: no lateral velocity
        ui = (r, ax_m, ay_m - GRAVITY * math.sin(self.roll))                     # eq 25 inputs
        self._propagate(kf, ui, pseudo)
        self._buffer.append([ui, pseudo, self.yaw, self.roll, kf.x.copy(), kf.P.copy()])
        # GPS delay identification during straight acceleration
        self._ident.push(vw)
        fresh = u[I.GPS_FRESH] != 0.0 and u[I.GPS_VALID] != 0.0
        if fresh and cfg.identify_delay and straight and abs(ax_m - kf.x[Sd.BX]) > cfg.accel_min:
            self._ident.add_fix(math.hypot(u[I.GPS_VE], u[I.GPS_VN]))
            d = self._ident.estimate(cfg.delay_min_fixes, cfg.delay_min_speed_change)
            if d is not None:
                self.delay = d
                if self.hardened:
                    self._latency.identified(d)
        if self.hardened:
            self._hardened_course(u, r, straight, fresh)
        if fresh:
            nis = self._apply_fix(u[I.GPS_VE], u[I.GPS_VN])
            if self.hardened:
                self._gps_nis.add(nis, 2)
        self._outputs(vw, r, straight)

    def _outputs(self, vw: float, r: float, straight: bool) -> None:
        """The estimate: the bicycle model's while straight (eq 32), else the sideslip KF's (eq 28)."""
        cfg, kf = self.config, self.kf
        U, V = float(kf.x[Sd.U]), float(kf.x[Sd.V])
        self.vx, self.vy, self.yaw_rate = U, V, r
        if U < cfg.v_min or vw < cfg.v_min:    # standing, creeping or reversing (by the KF or the wheels)
            self.valid = False
            return
        P = kf.P
        if straight and self._bicycle.valid:                 # eq 32: the bicycle model alone
            self.beta, self.beta_std = self._bicycle.beta, self._bicycle.beta_std
        else:
            self.beta = math.atan2(V, U)                                           # eq 28
            self.beta_std = beta_std(U, V, P[Sd.U, Sd.U], P[Sd.V, Sd.V], P[Sd.U, Sd.V])
            if self.hardened:        # a heading error turns the GPS velocity, and the sideslip with it
                self.beta_std = math.hypot(self.beta_std * self._gps_nis.inflation(),
                                           math.sqrt(self.heading.P.item(Hd.PSI, Hd.PSI)))
        self.valid = True
        if self.hardened:
            self.valid = self._outage <= cfg.gps_coast and self._gps_nis.consistent

    def _apply_fix(self, ve: float, vn: float) -> float:
        """GPS update with measurement shifting (Fig. 7) through the ring buffer; returns the update's NIS."""
        kf, buf = self.kf, self._buffer
        back = int(round(self.delay / self.Ts)) if self.config.measurement_shifting else 0
        if back == 0 or back >= len(buf):
            nis = self._gps_update(kf, ve, vn, self.yaw, self.roll, buf[-1][0][1:])
            buf[-1][4], buf[-1][5] = kf.x.copy(), kf.P.copy()
            return nis
        s = len(buf) - 1 - back                 # the sample the fix belongs to
        entry = buf[s]
        kf.x, kf.P = entry[4].copy(), entry[5].copy()
        nis = self._gps_update(kf, ve, vn, entry[2], entry[3], entry[0][1:])
        entry[4], entry[5] = kf.x.copy(), kf.P.copy()
        for j in range(s + 1, len(buf)):        # re-propagate to now, correcting the stored history
            e = buf[j]
            self._propagate(kf, e[0], e[1])
            e[4], e[5] = kf.x.copy(), kf.P.copy()
        return nis

    # ---------------------------------------------------------------- hardened profile (module docstring)
    def _hardened_init(self) -> None:
        cfg, ts, v = self.config, self.Ts, self.vehicle
        self._roll_gain = v.m_s * v.h_s / (v.K_phi_f + v.K_phi_r - v.m_s * GRAVITY * v.h_s)   # phi per a_y
        self._F_h = np.eye(5)
        self._F_h[Hd.PSI, Hd.BR] = self._F_h[Hd.PHI, Hd.BP] = -ts
        self._Q_h = np.diag([cfg.q_psi, cfg.q_phi, cfg.q_bias, cfg.q_bias, cfg.q_inclination])
        self._psi_hist: deque = deque(maxlen=int(math.ceil(cfg.max_delay / ts)) + 2)
        self._latency = GpsLatency(ts, cfg.gps_latency, cfg.gps_latency_std, cfg.identify_delay,
                                   min(cfg.max_delay, 0.5))
        self.delay = self._latency.value
        self._gps_nis = InnovationMonitor(10, cfg.nis_limit)
        self._outage = 0.0

    def _hardened_heading(self, r: float, p: float, mag: tuple, ay: float, still: bool) -> None:
        """Hardened heading filter on ``[psi, phi, b_r, b_p, incl]``: gyros minus their offsets, zero rates
        at a standstill, the 3-axis magnetometer with the inclination a state, the roll model."""
        cfg, ts = self.config, self.Ts
        norm = math.sqrt(mag[0] ** 2 + mag[1] ** 2 + mag[2] ** 2)
        self.disturbed = abs(norm - 1.0) > cfg.mag_threshold
        if self.heading is None:
            if self.disturbed:                   # start from an undisturbed field only
                return
            field = self._field
            psi0 = math.atan2(field[1], field[0]) - math.atan2(mag[1], mag[0])
            self.heading = KalmanFilter([math.remainder(psi0, 2 * math.pi), 0.0, 0.0, 0.0, cfg.mag_inclination],
                                        np.diag([0.1, 0.05, cfg.bias_std0 ** 2, cfg.bias_std0 ** 2,
                                                 cfg.inclination_std0 ** 2]))
        hd = self.heading
        x = hd.x.tolist()
        hd.predict([x[0] + ts * (r - x[2]), x[1] + ts * (p - x[3]), x[2], x[3], x[4]], self._F_h, self._Q_h)
        if still:                                # a standstill: both rates are zero
            hd.update_state(Hd.BR, r - hd.x[Hd.BR], 1e-6)      # a gyro sample's noise (0.06 deg/s)
            hd.update_state(Hd.BP, p - hd.x[Hd.BP], 1e-6)
        psi, phi, _, _, incl = hd.x.tolist()
        field = earth_field(incl, cfg.mag_declination)
        d_field = (-math.sin(incl) * math.sin(cfg.mag_declination), -math.sin(incl) * math.cos(cfg.mag_declination),
                   -math.cos(incl))
        H = np.zeros((3, 5))
        H[:, :2] = magnetometer_H(psi, phi, field)
        H[:, 4] = magnetometer_h(psi, phi, d_field)          # the field is linear in F: dm/dincl = M dF/dincl
        R = self._R_mag_dist if (self.disturbed and cfg.disturbance_rejection) else self._R_mag    # eq 21
        hd.update(np.array(mag) - magnetometer_h(psi, phi, field), H, R)                           # eq 22
        hd.update_state(Hd.PHI, self._roll_gain * (ay - GRAVITY * math.sin(hd.x[Hd.PHI])) - hd.x[Hd.PHI],
                        cfg.sigma_roll ** 2)
        hd.x[Hd.PSI] = math.remainder(hd.x[Hd.PSI], 2 * math.pi)
        self.yaw, self.roll, self.b_r, self.b_p, self.inclination = hd.x.tolist()

    def _hardened_course(self, u, r: float, straight: bool, fresh: bool) -> None:
        """The GPS delay identified from the course, and while straight the course as a heading measurement."""
        I, cfg = self.In, self.config
        self._psi_hist.append(self.yaw)
        self._latency.push(r, self.beta)
        self._outage = 0.0 if u[I.GPS_VALID] != 0.0 else self._outage + self.Ts
        speed = math.hypot(u[I.GPS_VE], u[I.GPS_VN])
        if fresh and speed > cfg.course_speed:
            self._latency.add_fix(math.atan2(u[I.GPS_VN], u[I.GPS_VE]), r)
            self.delay = self._latency.value
            if straight and self._bicycle.valid:
                self._hardened_course_heading(u[I.GPS_VE], u[I.GPS_VN], speed, self._bicycle.beta)

    def _hardened_course_heading(self, ve: float, vn: float, speed: float, beta_bicycle: float) -> None:
        """While straight, the course (of ``delay`` ago) minus the bicycle sideslip measures the heading."""
        cfg, hd = self.config, self.heading
        lag = min(int(round(self.delay / self.Ts)), len(self._psi_hist) - 1)
        shift = self._psi_hist[-1] - self._psi_hist[-1 - lag]        # heading change since the fix's time
        z = math.atan2(vn, ve) - beta_bicycle + shift
        r = cfg.sigma_course ** 2 + (cfg.sigma_gps / speed) ** 2
        hd.update_state(Hd.PSI, math.remainder(z - hd.x[Hd.PSI], 2 * math.pi), r)
        hd.x[Hd.PSI] = math.remainder(hd.x[Hd.PSI], 2 * math.pi)
        self.yaw, self.roll, self.b_r, self.b_p, self.inclination = hd.x.tolist()

    def _hardened_gps_noise(self, kf: KalmanFilter, accel) -> np.ndarray:
        """What the delay's and the heading's uncertainty add to the GPS velocity's noise (module docstring)."""
        ax, ay = accel
        sd, var_psi = self._latency.std, self.heading.P.item(Hd.PSI, Hd.PSI)
        x = kf.x
        return np.diag([(ax * sd) ** 2 + x[Sd.V] ** 2 * var_psi, (ay * sd) ** 2 + x[Sd.U] ** 2 * var_psi])
