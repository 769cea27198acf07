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

__all__ = ["INCLINATION", "DECLINATION", "earth_field", "tilt_compensated_heading"]

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


def tilt_compensated_heading(mag: tuple[float, float, float], tilt: float,
                             declination: float = DECLINATION) -> tuple[float, float, float]:
    """Heading from a 3-axis magnetometer on a body tilted by ``tilt`` about its x axis (zero pitch).

    The reading is rotated back by the tilt, ``b_y = cos(tilt) m_y - sin(tilt) m_z``, and the
    horizontal field ``(b_x, b_y)`` points to magnetic north; with the heading counter-clockwise from
    east (ENU), ``psi = atan2(b_x, b_y) - declination`` (the inverse of :func:`earth_field` seen
    through ``R_x(tilt)^T R_z(psi)^T``).  The inclination is not needed: it only sets how a tilt error
    turns into a heading error.

    Parameters
    ----------
    mag : tuple of float
        Magnetometer reading, sensor axes (any scale).
    tilt : float
        The body's tilt about x, roll plus the road's bank [rad].
    declination : float
        Magnetic north east of true north [rad].

    Returns
    -------
    tuple of float
        The heading [rad], its sensitivity to the tilt ``d psi / d tilt`` [rad/rad] and the horizontal
        field's norm squared (the reading's units squared; the heading's noise is the reading's over
        its square root).
    """
    mx, my, mz = mag
    c, s = math.cos(tilt), math.sin(tilt)
    bx, by, up = mx, c * my - s * mz, s * my + c * mz
    h2 = bx * bx + by * by
    return math.atan2(bx, by) - declination, bx * up / h2 if h2 > 0.0 else 0.0, h2
