"""What a filter on the linear single-track model cannot know of its own model, added to its uncertainty.

The hardened profiles of the linear-tire methods (Kim 2016, Pi 2011, Park 2018's bicycle sub-filter,
Nguyen 2012) add what the checks of :mod:`~sideslip.estimators.model_checks` find to their
uncertainty: the error of a cornering stiffness that may be 30 % off (:func:`model_sideslip_std`), what
the single-track model with linear tires cannot explain (:class:`TireLinearity`, which also enters the
filter's covariance) and how far the estimate has moved against the kinematics (:class:`KinematicCheck`);
:class:`ModelTrust` applies them.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..params import param
from ..vehicles import VehicleParams
from .model_checks import KinematicCheck, TireLinearity, model_sideslip_std
from .profiles import HARDENED_PREFIX, ProfiledConfig
from .roll import RollCompensator

__all__ = ["LinearTireConfig", "ModelTrust"]


@dataclass(frozen=True)
class LinearTireConfig(ProfiledConfig):
    """:class:`~sideslip.estimators.profiles.ProfiledConfig` of a method built on the linear single-track model
    (:class:`ModelTrust`)."""

    stiffness_error: float = param(0.3, "Dimensionless", HARDENED_PREFIX + "relative error of the vehicle file's "
                                   "cornering stiffness in the reported std", ge=0, le=2)
    kinematic_gap: float = param(0.01, "Angle", HARDENED_PREFIX + "tire-linearity gap at which the estimate leans "
                                 "half on the kinematic (sensor) path instead of the linear tires", gt=0, le=1)
    kinematic_check: bool = param(True, "Dimensionless", HARDENED_PREFIX + "add to the reported std how far the "
                                  "estimate's changes depart from the kinematic d(beta)/dt = a_y/v_x - r "
                                  "(KinematicCheck)")
    kinematic_tol: float = param(0.02, "Angle", HARDENED_PREFIX + "departure from the kinematics that sensor noise "
                                 "and roll explain (KinematicCheck)", ge=0, le=1)
    kinematic_tau: float = param(2.0, "Time", HARDENED_PREFIX + "time constant of the high-pass filter of "
                                 "KinematicCheck (offsets slower than this drop out)", gt=0, le=60)


class ModelTrust:
    """What a hardened linear-tire filter adds to its sideslip uncertainty (:class:`LinearTireConfig`).

    :meth:`apply` raises the sideslip variance of the filter's covariance to what
    :class:`TireLinearity` leaves open (so that the filter re-converges from the measurements once
    the tires are linear again, instead of trusting an estimate fitted to the wrong model) and returns
    :func:`model_sideslip_std`, which the estimator adds to its reported std.  With
    ``kinematic_check`` it also holds a :class:`KinematicCheck` (:meth:`check_kinematics`), whose
    :attr:`kinematic_sigma` enters the reported std only.
    """

    __slots__ = ("linearity", "kinematics", "_vehicle", "_e")

    def __init__(self, vehicle: VehicleParams, ts: float, config: LinearTireConfig):
        self.linearity = TireLinearity(vehicle, ts, config.stiffness_error)
        self.kinematics = KinematicCheck(ts, config.kinematic_tol, config.kinematic_tau,
                                         RollCompensator(vehicle, ts)) if config.kinematic_check else None
        self._vehicle, self._e = vehicle, config.stiffness_error

    def apply(self, P, i: int, vx: float, r: float, delta: float, ay: float, mz: float = 0.0) -> float:
        """One sample: the linearity check updated, ``P[i, i]`` (the sideslip's variance) raised in place;
        returns the model std [rad]."""
        self.linearity.update(vx, r, delta, ay, mz)
        return self.raise_variance(P, i, ay)

    def raise_variance(self, P, i: int, ay: float) -> float:
        """:meth:`apply` after the linearity check was updated this sample."""
        sigma = self.linearity.sigma
        if P[i, i] < sigma * sigma:
            P[i, i] = sigma * sigma
        return self.model_std(ay)

    def kinematic_weight(self, half: float) -> float:
        """How far beyond the tires' linear range the car is, in ``[0, 1)``: ``sigma / (sigma + half)`` of
        :class:`TireLinearity` (``half`` [rad] the gap at which it is one half)."""
        sigma = self.linearity.sigma
        return sigma / (sigma + half)

    def model_std(self, ay: float) -> float:
        """:func:`model_sideslip_std` of the estimator's vehicle at the lateral acceleration ``ay`` plus what
        :class:`TireLinearity` last found unexplained [rad]."""
        return model_sideslip_std(self._vehicle, ay, self._e) + self.linearity.sigma

    @property
    def kinematic_sigma(self) -> float:
        """:attr:`KinematicCheck.sigma` [rad], 0 when the check is off: it enters the reported std only (the
        check judges the estimate, it is no information for the filter)."""
        return self.kinematics.sigma if self.kinematics is not None else 0.0

    def check_kinematics(self, beta: float, vx: float, r: float, ay: float) -> None:
        """:meth:`KinematicCheck.update` with this sample's estimate and the body-fixed (not roll-compensated)
        lateral acceleration (nothing when the check is off)."""
        if self.kinematics is not None:
            self.kinematics.update(beta, vx, r, ay)
