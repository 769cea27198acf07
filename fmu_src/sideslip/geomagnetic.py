"""The Earth's magnetic field, as the magnetometer model makes it and the heading filters expect it.

One place for the field so that the sensors FMU and an estimator that uses the magnetometer
(Yoon & Peng 2014) agree by default: a mismatch of the inclination between the two reads as a
roll angle of the same size (and, through ``g sin(roll)``, as a lateral-acceleration bias).
The closed-loop runner also hands a scenario's field to the estimators, as it hands them the
vehicle (:func:`sideslip.scenarios.scenario_params`), the way a real magnetometer is
calibrated to the local field.
"""
from __future__ import annotations

import math

__all__ = ["INCLINATION", "DECLINATION", "earth_field"]

INCLINATION = math.radians(68.0)
"""Default inclination (dip) [rad], positive pointing down: about 68 deg, southern Michigan (where
Yoon & Peng drove; the paper gives no number)."""

DECLINATION = 0.0
"""Default declination [rad]: magnetic north east of true north."""


def earth_field(inclination: float, declination: float) -> tuple[float, float, float]:
    """Unit Earth field in ENU: horizontal part to magnetic north, dipping by the inclination.

    Parameters
    ----------
    inclination, declination : float
        Dip below the horizon and angle of magnetic north east of true north [rad].

    Returns
    -------
    tuple of float
        East, north and up components (normalised, dimensionless).
    """
    return (math.cos(inclination) * math.sin(declination), math.cos(inclination) * math.cos(declination),
            -math.sin(inclination))
