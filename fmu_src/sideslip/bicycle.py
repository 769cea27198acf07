"""Linear single-track (bicycle) model: the one place its matrices and gains are written.

State ``[beta, r]``, inputs ``[delta_f, M_z]``, axle cornering stiffnesses ``C_f, C_r``
with ``F_y = -C alpha`` (Park 2018 eqs 8-13; Pi 2011 eq 20; Yoon 2014 eq 32; Nguyen 2012
eqs 1-2 with ``2 C`` per axle; Kim 2016 eq 9):

    d(beta)/dt = -(C_f + C_r)/(m v) beta + ((C_r l_r - C_f l_f)/(m v^2) - 1) r + C_f/(m v) delta
    d(r)/dt    = (C_r l_r - C_f l_f)/I_z beta - (C_f l_f^2 + C_r l_r^2)/(I_z v) r
                 + C_f l_f/I_z delta + M_z / I_z
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = ["BicycleModel", "axle_forces"]


@dataclass(frozen=True)
class BicycleModel:
    """Linear single-track model.

    Parameters
    ----------
    m : float
        Mass [kg].
    I_z : float
        Yaw inertia [kg m2].
    l_f, l_r : float
        CG to front / rear axle [m].
    C_f, C_r : float
        Axle cornering stiffnesses [N/rad].
    """

    m: float
    I_z: float
    l_f: float
    l_r: float
    C_f: float
    C_r: float

    @classmethod
    def from_vehicle(cls, vehicle, mu: float = 1.0, nominal: bool = False) -> "BicycleModel":
        """Bicycle model of a :class:`~sideslip.vehicles.VehicleParams`.

        ``nominal=False`` uses the true tire stiffness on friction ``mu`` (two tires per
        axle); ``nominal=True`` the estimator-side nominal axle values.
        """
        if nominal:
            c_f, c_r = vehicle.nominal_cornering_stiffness(mu)
        else:
            c_f, c_r = (2.0 * c for c in vehicle.cornering_stiffness(mu))
        return cls(vehicle.m, vehicle.I_zz, vehicle.l_f, vehicle.l_r, c_f, c_r)

    # cached: the controllers ask for the gains several times per 1 ms step (instance __dict__, the frozen fields
    # unchanged)
    @cached_property
    def l(self) -> float:
        """Wheelbase [m]."""
        return self.l_f + self.l_r

    @cached_property
    def understeer_gradient(self) -> float:
        """Understeer gradient K = m (l_r / C_f - l_f / C_r) / l [rad s2/m] (Pi 2011 eq 32)."""
        return self.m * (self.l_r / self.C_f - self.l_f / self.C_r) / self.l

    @property
    def characteristic_speed(self) -> float:
        """sqrt(l / K) [m/s] for an understeering model (inf when neutral or oversteering)."""
        k = self.understeer_gradient
        return float(np.sqrt(self.l / k)) if k > 0 else float("inf")

    def matrices(self, vx: float) -> tuple[np.ndarray, np.ndarray]:
        """Continuous-time ``A`` (2x2) and ``B`` (2x2, inputs ``[delta_f, M_z]``) at speed ``vx``."""
        m, iz, lf, lr, cf, cr = self.m, self.I_z, self.l_f, self.l_r, self.C_f, self.C_r
        a = np.array([[-(cf + cr) / (m * vx), (cr * lr - cf * lf) / (m * vx * vx) - 1.0],
                      [(cr * lr - cf * lf) / iz, -(cf * lf * lf + cr * lr * lr) / (iz * vx)]])
        b = np.array([[cf / (m * vx), 0.0],
                      [cf * lf / iz, 1.0 / iz]])
        return a, b

    def steady_state_gains(self, vx: float) -> tuple[float, float]:
        """Steady-state ``(beta/delta_f, r/delta_f)`` [-, 1/s] at speed ``vx``.

        Closed form: ``r/delta = vx / (l + K vx^2)`` and
        ``beta/delta = (l_r - m l_f vx^2 / (l C_r)) / (l + K vx^2)``.
        """
        den = self.l + self.understeer_gradient * vx * vx
        return ((self.l_r - self.m * self.l_f * vx * vx / (self.l * self.C_r)) / den, vx / den)


def axle_forces(m: float, I_z: float, l_f: float, l_r: float, a_y: float, yaw_acc: float,
                M_z: float = 0.0) -> tuple[float, float]:
    """Axle lateral forces ``(F_yf, F_yr)`` [N] from the lateral acceleration and the yaw acceleration.

    The single-track force and moment balances ``m a_y = F_yf + F_yr`` and
    ``I_z dr/dt = l_f F_yf - l_r F_yr + M_z`` solved for the two forces (Park 2018 eq 19;
    Pi 2011 eqs 23-24, with the yaw moment ``M_z`` of a stability controller):
    ``F_yf = (m l_r a_y + I_z dr/dt - M_z) / l``, ``F_yr = (m l_f a_y - I_z dr/dt + M_z) / l``.

    Parameters
    ----------
    m : float
        Mass [kg].
    I_z : float
        Yaw inertia [kg m2].
    l_f, l_r : float
        CG to front / rear axle [m].
    a_y : float
        Lateral acceleration of the CG [m/s2].
    yaw_acc : float
        Yaw acceleration [rad/s2].
    M_z : float
        External yaw moment, e.g. from in-wheel motors [N m].
    """
    l = l_f + l_r
    return ((m * l_r * a_y + I_z * yaw_acc - M_z) / l, (m * l_f * a_y - I_z * yaw_acc + M_z) / l)
