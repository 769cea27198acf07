"""Physical constants of the library, each defined once.

``GRAVITY`` is the gravitational acceleration of every model (plant, sensors, estimators,
controller, driver): 9.81 m/s2, the value of the papers' tables.  ``STANDARD_GRAVITY`` is the
unit ``g`` (9.80665 m/s2 by definition), used only where a quantity is *expressed* in g: the
display unit of accelerations and the "0.3 g" of FMVSS 126's slowly increasing steer test.
"""
from __future__ import annotations

__all__ = ["GRAVITY", "STANDARD_GRAVITY"]

GRAVITY = 9.81
"""Gravitational acceleration of the models [m/s2]."""

STANDARD_GRAVITY = 9.80665
"""The unit g [m/s2] (3rd CGPM, 1901): for values stated in g, not for the models' physics."""
