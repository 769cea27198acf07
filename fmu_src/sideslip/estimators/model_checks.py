"""Checks of a car, and of an estimate, against the linear single-track model.

Beyond the tires' linear range (on snow at 0.3 g, on asphalt near the limit) every linear-model
estimate is wrong whatever its covariance says, and a vehicle file's cornering stiffness may be 30 %
off.  What these checks find is what a filter on that model cannot know of its own model
(:mod:`~sideslip.estimators.model_trust` adds it to the hardened profiles' uncertainty) and whether an
estimate of any method agrees with the model where it holds (the published profiles' ``valid``):

* :func:`model_sideslip_std` - the sideslip error of a cornering stiffness that is a fraction off.
* :class:`TireLinearity` - does the single-track model with linear tires explain the measured
  steering, yaw rate and accelerations?  The gap sets a sideslip uncertainty.
* :class:`KinematicCheck` - does the estimate follow the sideslip's kinematics
  ``d(beta)/dt = a_y / v_x - r``?  When both axles leave their linear range together (on snow in a
  sine steer) :class:`TireLinearity` sees little, yet the car slides by degrees in a second while a
  linear-tire estimate stays where its model puts it; the kinematics, high-passed so that sensor
  offsets and a road bank drop out, show it.
* :class:`ModelConsistency` - is an estimate within what the single-track model's own sideslip is known to?
"""
from __future__ import annotations

import math

from ..bicycle import axle_forces
from ..vehicles import VehicleParams
from .discrete import lowpass
from .roll import RollCompensator

__all__ = ["model_sideslip_std", "TireLinearity", "KinematicCheck", "ModelConsistency", "KINEMATIC_LIMIT"]

KINEMATIC_LIMIT = math.radians(1.0)
"""[rad] ``kinematic_limit`` of :class:`ModelConsistency`: how far an estimate may have lately moved against the
kinematics before it is not consistent; chosen on the benchmark's training set, where it catches slides the
single-track band (open beyond the linear range) cannot and clears no sample of an estimate that follows the car
(the measurements: design history, "Valid from the consistency monitor")."""


def model_sideslip_std(vehicle: VehicleParams, ay: float, stiffness_error: float) -> float:
    """1-sigma of a linear-tire sideslip from an uncertain cornering stiffness [rad].

    The sideslip of a single-track model is set by the rear slip angle ``alpha_r = F_yr / C_r`` with
    ``F_yr = m l_f a_y / l``; a relative stiffness error ``e`` moves it by ``e alpha_r``.  The hardened
    model-based estimators add this to their filter's std: their covariance knows the sensor noise,
    not that the vehicle file's stiffness may be 30 % off.  (What the tires' departure from linear
    adds is measured by :class:`TireLinearity`.)
    """
    v = vehicle
    return stiffness_error * abs(v.m * v.l_f * ay / (v.l * v.C_r_nominal))


class TireLinearity:
    """Sideslip uncertainty from what the single-track model with linear tires cannot explain.

    The measured lateral and yaw accelerations give the axle forces (force and moment balance,
    :func:`~sideslip.bicycle.axle_forces`); linear tires turn them into slip angles
    ``alpha_i = F_yi / C_i``.  The geometry of the single-track model ties their difference to the
    measured steering angle whatever the sideslip: ``alpha_f - alpha_r = delta - l r / v_x``.  Within
    the tires' linear range the two sides agree up to the stiffness error (``rel`` of the slip angles)
    and the sensor offsets (``delta_abs``); beyond it - the front or the rear axle saturated on snow,
    or at the limit on asphalt - they part, and by about the slip angle that the saturated axle has
    beyond its linear value: a linear-tire sideslip is that uncertain.  The gap, low-pass filtered
    with ``tau``, is :attr:`sigma` [rad].  The check needs no sideslip estimate, so a filter that has
    fitted its sideslip to the wrong model cannot hide it.  It rises with ``tau`` and falls with
``tau_down``: after a slide the filter needs time to re-converge.

    Parameters
    ----------
    vehicle : VehicleParams
        The estimator's vehicle (nominal axle stiffness at mu = 1).
    ts : float
        Sample period [s].
    rel : float
        Relative tolerance on the slip angles (the stiffness error the vehicle file may have).
    delta_abs : float
        Absolute tolerance [rad] (steering and accelerometer offsets, road bank).
    tau : float
        Time constant of the low-pass filters on the yaw acceleration and of the gap's rise [s].
    tau_down : float
        Time constant of the gap's fall [s].
    """

    __slots__ = ("_m", "_iz", "_lf", "_lr", "_cf", "_cr", "_ts", "_rel", "_abs", "_cut", "_cut_down", "_r_prev",
                 "_r_dot", "sigma", "alpha_r")

    def __init__(self, vehicle: VehicleParams, ts: float, rel: float = 0.3, delta_abs: float = 0.005,
                 tau: float = 0.1, tau_down: float = 2.0):
        v = vehicle
        self._m, self._iz, self._lf, self._lr = v.m, v.I_zz, v.l_f, v.l_r
        self._cf, self._cr = v.C_f_nominal, v.C_r_nominal
        self._ts, self._rel, self._abs = ts, rel, delta_abs
        self._cut = 1.0 / (2.0 * math.pi * tau)
        self._cut_down = 1.0 / (2.0 * math.pi * tau_down)
        self._r_prev = None
        self._r_dot = self.sigma = 0.0
        self.alpha_r = 0.0                       #: the rear axle's linear slip angle of the last sample [rad]

    def update(self, vx: float, r: float, delta: float, ay: float, mz: float = 0.0) -> float:
        """One sample with the measured yaw rate, steering angle [rad], lateral acceleration [m/s2] and the
        controller's yaw moment [N m]; returns :attr:`sigma` [rad]."""
        if self._r_prev is not None:
            self._r_dot = lowpass(self._r_dot, (r - self._r_prev) / self._ts, self._ts, self._cut)
        self._r_prev = r
        fyf, fyr = axle_forces(self._m, self._iz, self._lf, self._lr, ay, self._r_dot, mz)
        alpha_f, alpha_r = fyf / self._cf, fyr / self._cr
        self.alpha_r = alpha_r
        gap = abs(delta - (self._lf + self._lr) * r / vx - (alpha_f - alpha_r)) \
            - self._rel * (abs(alpha_f) + abs(alpha_r)) - self._abs
        gap = gap if gap > 0.0 else 0.0
        # up fast, down slowly: a filter that has just left a state it could not model is wrong for a while
        self.sigma = lowpass(self.sigma, gap, self._ts, self._cut if gap > self.sigma else self._cut_down)
        return self.sigma


class ModelConsistency:
    """Does an estimate agree with the single-track model where that model holds, and with the sideslip's kinematics?
    (``valid`` of every estimator with the inputs, :class:`~sideslip.estimators.base.Estimator`: it judges the
    estimate, changes none.)

    Where the single-track model with linear tires explains the car (:class:`TireLinearity`), its sideslip is
    ``beta_m = l_r r / v_x - alpha_r``, with ``alpha_r = F_yr / C_r`` the rear axle's slip angle of the measured
    lateral and yaw accelerations, whatever the filter: it is known to within the stiffness's error
    (:func:`model_sideslip_std`), ``gap_factor`` times the linearity gap (beyond the linear range the model knows
    nothing, and the band opens) and ``tol`` (sensor offsets, a road bank, the vehicle file's geometry).  An
    estimate further from it than that is not consistent with the car.  Beyond the linear range, where the band is
    open, the kinematics still hold: an estimate that has lately moved against ``d(beta)/dt = a_y / v_x - r`` by
    more than ``kinematic_limit`` beyond :class:`KinematicCheck`'s tolerance (a slide it does not follow) is not
    consistent either.

    Parameters
    ----------
    vehicle : VehicleParams
        The estimator's vehicle.
    ts : float
        Sample period [s].
    tol : float
        Disagreement [rad] that is not counted.
    stiffness_error : float
        Relative error of the vehicle file's cornering stiffness.
    gap_factor : float
        Multiple of the linearity gap by which the band opens.
    kinematic_limit : float
        :attr:`KinematicCheck.sigma` [rad] beyond which the estimate is not consistent.
    """

    __slots__ = ("linearity", "kinematics", "_roll", "_vehicle", "_lr", "_e", "_tol", "_k", "_kin", "model_beta",
                 "consistent")

    def __init__(self, vehicle: VehicleParams, ts: float, tol: float, stiffness_error: float = 0.3,
                 gap_factor: float = 3.0, kinematic_limit: float = KINEMATIC_LIMIT):
        self.linearity = TireLinearity(vehicle, ts, stiffness_error)
        self.kinematics = KinematicCheck(ts)      # fed the roll-compensated a_y of the model check
        self._roll = RollCompensator(vehicle, ts)
        self._vehicle, self._lr, self._e, self._tol, self._k = vehicle, vehicle.l_r, stiffness_error, tol, gap_factor
        self._kin = kinematic_limit
        self.model_beta = 0.0                    #: the single-track model's sideslip of the last sample [rad]
        self.consistent = True

    def update(self, beta: float, vx: float, r: float, delta: float, ay_m: float) -> bool:
        """One sample with the estimate [rad], the speed [m/s], the measured yaw rate [rad/s], steering angle [rad]
        and body-fixed lateral acceleration [m/s2]; returns :attr:`consistent`."""
        ay = self._roll(ay_m)
        gap = self.linearity.update(vx, r, delta, ay)
        self.model_beta = self._lr * r / vx - self.linearity.alpha_r
        band = self._tol + model_sideslip_std(self._vehicle, ay, self._e) + self._k * gap
        moved = self.kinematics.update(beta, vx, r, ay)
        self.consistent = abs(beta - self.model_beta) <= band and moved <= self._kin
        return self.consistent


class KinematicCheck:
    """Sideslip uncertainty from an estimate that does not follow the sideslip's kinematics.

    Whatever the tires, the sideslip of a car at a slowly changing speed obeys
    ``d(beta)/dt = a_y / v_x - r``.  The departure ``e = d(beta_hat)/dt - (a_y / v_x - r)`` of an
    estimate is constant from sensor offsets and a road bank, and a pulse when the car slides and the
    estimate does not (a linear-tire model with both axles saturated: the car's sideslip swings by
    5 deg in a second while the model's stays under 1 deg).  The check high-passes ``e`` (its mean
    over ``tau`` subtracted) and integrates the rest with a leak of ``tau``: the result ``d`` [rad] is
    how far the estimate has moved against the kinematics lately; what exceeds ``tol`` is
    :attr:`sigma`, which rises at once and falls with ``tau``.  ``tol`` takes the sensor noise, the
    neglected ``beta dv_x / v_x`` and what the roll model (``roll``, which removes the roll's
    ``g sin(phi)`` from a body-fixed ``a_y``) leaves.  During the first ``tau`` the filter converges
    and the offsets' mean is learnt: nothing is counted.  The defaults of ``tol`` and ``tau``
    (``kinematic_tol``, ``kinematic_tau``) were chosen on the benchmark's training set.

    Parameters
    ----------
    ts : float
        Sample period [s].
    tol : float
        Departure [rad] that is not counted.
    tau : float
        Time constant of the high-pass filter and of the leak [s].
    roll : RollCompensator, optional
        Removes ``g sin(phi)`` from a body-fixed ``a_y``; None when ``a_y`` is the CG's.
    """

    __slots__ = ("_ts", "_tol", "_a", "_roll", "_warmup", "_n", "_beta_prev", "_mean", "d", "sigma")

    def __init__(self, ts: float, tol: float = 0.02, tau: float = 2.0, roll: RollCompensator | None = None):
        self._ts, self._tol, self._a, self._roll = ts, tol, math.exp(-ts / tau), roll
        self._warmup = max(1, int(round(tau / ts)))
        self._n = 0
        self._beta_prev = None
        self._mean = self.d = self.sigma = 0.0

    def update(self, beta: float, vx: float, r: float, ay: float) -> float:
        """One sample with the estimate [rad], the speed [m/s], the yaw rate [rad/s] (offset removed where the
        filter estimates it) and the lateral acceleration [m/s2]; returns :attr:`sigma` [rad]."""
        if self._roll is not None:
            ay = self._roll(ay)
        prev, self._beta_prev = self._beta_prev, beta
        if prev is None:
            return self.sigma
        ts, a = self._ts, self._a
        e = (beta - prev) / ts - (ay / vx - r)
        self._n += 1
        if self._n <= self._warmup:            # the first tau: the offsets' mean is learnt while the filter converges
            self._mean += (e - self._mean) / self._n
            return self.sigma
        self.d = a * self.d + (e - self._mean) * ts
        self._mean = a * self._mean + (1.0 - a) * e
        gap = abs(self.d) - self._tol
        gap = gap if gap > 0.0 else 0.0
        self.sigma = gap if gap > self.sigma else a * self.sigma + (1.0 - a) * gap
        return self.sigma
