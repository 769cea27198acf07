"""Roll compensation of a body-fixed lateral accelerometer with the vehicle's suspension roll model.

The sideslip papers' ``a_y`` is the lateral acceleration of the CG; an accelerometer fixed to
the body also reads ``g sin(phi)`` when the body rolls by ``phi`` (0.45 m/s2 at 0.65 g for the
Park 2018 Sonata, 0.7 m/s2 at 0.45 g for the Pi 2011 SUV).  The roll angle comes from the
second-order roll model of the vehicle parameters (the plant's roll equation without the
product of inertia and the bank)::

    I_roll phi'' + C_phi phi' + (K_phi - m_s g h_s) phi = m_s h_s a_y

driven by the compensated ``a_y`` (semi-implicit Euler at the filter's sample period), and
``a_y = (a_y,m - g sin(phi)) / cos(phi)``.  Used by Park 2018 and Pi 2011 as a documented
addition (their ``roll_compensation`` parameter).
"""
from __future__ import annotations

import math

from ..constants import GRAVITY
from ..vehicles import VehicleParams

__all__ = ["RollCompensator"]


class RollCompensator:
    """Removes the roll-gravity component from a body-fixed lateral acceleration.

    Parameters
    ----------
    vehicle : VehicleParams
        Roll inertia, stiffness, damping, sprung mass and roll-arm height.
    ts : float
        Sample period [s].
    """

    def __init__(self, vehicle: VehicleParams, ts: float):
        v = vehicle
        self._i, self._c = v.I_roll, v.C_phi_f + v.C_phi_r
        self._k = v.K_phi_f + v.K_phi_r - v.m_s * GRAVITY * v.h_s
        self._mh = v.m_s * v.h_s
        self.ts = ts
        self.phi = self.phi_rate = 0.0

    def coefficients(self) -> tuple[float, float, float, float]:
        """The roll model's ``I_roll`` [kg m2], ``C_phi`` [N m s/rad], ``K_phi - m_s g h_s`` [N m/rad] and ``m_s h_s``
        [kg m] (for a compiled step)."""
        return self._i, self._c, self._k, self._mh

    def __call__(self, ay_meas: float) -> float:
        """CG lateral acceleration [m/s2] from the body-fixed reading; advances the roll model one sample."""
        phi = self.phi
        ay = (ay_meas - GRAVITY * math.sin(phi)) / math.cos(phi)
        self.phi_rate += self.ts * (self._mh * ay - self._k * phi - self._c * self.phi_rate) / self._i
        self.phi = phi + self.ts * self.phi_rate
        return ay
