"""SI units and quantities used on FMU ports and parameters.

One table, used by the signal catalogue, the parameter declarations and the FMU toolkit
(which writes it as ``UnitDefinitions``/``TypeDefinitions`` into every modelDescription).
Angles are always radians on a port; degrees exist only as a *display* unit.  Noise
parameters follow one convention: a variance is declared as a variance, with the square of
its signal's unit (``rad2``, ``N2``, ``m2/s2``), and a standard deviation with the signal's own
quantity; LQR weights carry the inverse square of the unit they weigh.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .constants import STANDARD_GRAVITY

__all__ = ["Unit", "UNITS", "QUANTITIES", "LOG_UNITS", "DEG", "unit_of_quantity", "si_factor", "wrap_angle"]


DEG = 180.0 / math.pi
"""Degrees per radian: ``angle * DEG`` is in degrees (a display unit only; ``math.radians`` converts back)."""


def wrap_angle(angle):
    """An angle, or an array of angles, wrapped to (-pi, pi] [rad]: headings on ports are reported so, and angle
    errors are scored so."""
    if isinstance(angle, (float, int)):
        return math.pi - (math.pi - angle) % (2.0 * math.pi)
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2.0 * np.pi)


@dataclass(frozen=True)
class Unit:
    """An SI unit as FMI 2.0 describes it.

    Parameters
    ----------
    name : str
        Unit string as written on variables (``"m/s2"``, ``"N.m"``, ``"1"``).
    base : dict
        Exponents of the FMI base units (``kg, m, s, A, K, mol, cd, rad``).
    display : tuple of (str, float)
        Display units as ``(name, factor)`` with ``display = factor * value``.
    """

    name: str
    base: dict = field(default_factory=dict)
    display: tuple = ()


UNITS: dict[str, Unit] = {u.name: u for u in (
    Unit("1"),
    Unit("s", {"s": 1}),
    Unit("Hz", {"s": -1}),
    Unit("m", {"m": 1}),
    Unit("m/s", {"m": 1, "s": -1}, (("km/h", 3.6),)),
    Unit("m/s2", {"m": 1, "s": -2}, (("g", 1.0 / STANDARD_GRAVITY),)),
    Unit("rad", {"rad": 1}, (("deg", DEG),)),
    Unit("rad/s", {"rad": 1, "s": -1}, (("deg/s", DEG),)),
    Unit("rad/s2", {"rad": 1, "s": -2}, (("deg/s2", DEG),)),
    Unit("kg", {"kg": 1}),
    Unit("kg.m2", {"kg": 1, "m": 2}),
    Unit("N", {"kg": 1, "m": 1, "s": -2}),
    Unit("N.m", {"kg": 1, "m": 2, "s": -2}),
    Unit("N.s/m", {"kg": 1, "s": -1}),
    Unit("N/rad", {"kg": 1, "m": 1, "s": -2, "rad": -1}),
    Unit("N.m/rad", {"kg": 1, "m": 2, "s": -2, "rad": -1}),
    Unit("N.m.s/rad", {"kg": 1, "m": 2, "s": -1, "rad": -1}),
    Unit("N.m/s", {"kg": 1, "m": 2, "s": -3}),
    Unit("1/rad", {"rad": -1}),
    Unit("m2", {"m": 2}),
    Unit("kg/m3", {"kg": 1, "m": -3}),
    Unit("s/m", {"m": -1, "s": 1}),
    Unit("1/s", {"s": -1}),
    Unit("1/s2", {"s": -2}),
    # variances (noise covariances) and LQR weights carry the unit of what they weigh
    Unit("rad2", {"rad": 2}),
    Unit("rad2/s2", {"rad": 2, "s": -2}),
    Unit("1/rad2", {"rad": -2}),
    Unit("N2", {"kg": 2, "m": 2, "s": -4}),
    Unit("m2/s2", {"m": 2, "s": -2}),
    Unit("m2/s4", {"m": 2, "s": -4}),
    Unit("s2/rad2", {"s": 2, "rad": -2}),
    Unit("1/N2/m2", {"kg": -2, "m": -4, "s": 4}),
)}

# quantity (FMI declaredType name) -> unit
QUANTITIES: dict[str, str] = {
    "Time": "s",
    "Frequency": "Hz",
    "Length": "m",
    "Position": "m",
    "Velocity": "m/s",
    "Acceleration": "m/s2",
    "Angle": "rad",
    "AngularVelocity": "rad/s",
    "AngularAcceleration": "rad/s2",
    "Mass": "kg",
    "MomentOfInertia": "kg.m2",
    "Force": "N",
    "Torque": "N.m",
    "TorqueRate": "N.m/s",
    "DampingCoefficient": "N.s/m",
    "CorneringStiffness": "N/rad",
    "RollStiffness": "N.m/rad",
    "RollDamping": "N.m.s/rad",
    "NormalisedStiffness": "1/rad",
    "Area": "m2",
    "Density": "kg/m3",
    "Slowness": "s/m",
    "InverseTime": "1/s",
    "IntegralGain": "1/s2",
    "FrictionCoefficient": "1",
    "MagneticFluxRatio": "1",
    "Dimensionless": "1",
    # covariances: a variance has the square of its signal's unit
    "AngleVariance": "rad2",
    "AngularVelocityVariance": "rad2/s2",
    "NormalisedStiffnessVariance": "1/rad2",
    "ForceVariance": "N2",
    "VelocityVariance": "m2/s2",
    "AccelerationVariance": "m2/s4",
    # LQR weights: the inverse square of the unit of the error they weigh
    "AngleWeight": "1/rad2",
    "AngularVelocityWeight": "s2/rad2",
    "TorqueWeight": "1/N2/m2",
}


def unit_of_quantity(quantity: str) -> str:
    """Unit string of a quantity (raises ``KeyError`` for an unknown quantity)."""
    return QUANTITIES[quantity]


LOG_UNITS: dict[str, tuple[str, float]] = {
    "ms": ("s", 1e-3),
    "rpm": ("rad/s", 2.0 * math.pi / 60.0),
    "mph": ("m/s", 0.44704),
    "mrad": ("rad", 1e-3),
}
"""Units a recorded log may use besides the SI units and their display units: name -> (SI unit, factor to SI)."""


def si_factor(unit: str, si_unit: str) -> float:
    """Factor that turns a value in ``unit`` into ``si_unit``: 1 for the SI unit itself, the inverse
    display factor for a display unit (``deg``, ``deg/s``, ``km/h``, ``g``), or a :data:`LOG_UNITS` factor.

    Raises
    ------
    KeyError
        When ``unit`` is not a unit of the quantity (the message lists the accepted ones).
    """
    if unit == si_unit:
        return 1.0
    for name, factor in UNITS[si_unit].display:
        if unit == name:
            return 1.0 / factor
    if unit in LOG_UNITS and LOG_UNITS[unit][0] == si_unit:
        return LOG_UNITS[unit][1]
    accepted = [si_unit] + [n for n, _ in UNITS[si_unit].display] + [n for n, (u, _) in LOG_UNITS.items() if u == si_unit]
    raise KeyError(f"unit {unit!r} is not one of {', '.join(accepted)}")
