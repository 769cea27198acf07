"""The fusion filter's tire model: an axle's slip angle from its lateral force (the inverse brush tire).

An axle's lateral force ``F_y`` (from the force and moment balances) gives its slip angle through a
brush (Fiala) tire, ``alpha = 3 F_max / C (1 - (1 - |F_y| / F_max)^(1/3))`` (:func:`fiala_slip`),
whose cornering stiffness ``C = s C_nominal(mu)`` is the vehicle file's, softer on low friction
(:func:`axle_stiffness`), scaled by the filter's state ``s``, and whose friction ``F_max = mu F_z``
is the filter's friction state times the axle's load.  A braked or driven axle has less friction
left for its lateral force: ``sqrt(F_max^2 - F_x^2)`` (the friction ellipse, :func:`lateral_capacity`).
Every function also returns the derivatives the filter's Jacobian needs.
"""
from __future__ import annotations

import math
from typing import NamedTuple

__all__ = ["BrushSlip", "AxleSlip", "CAPACITY_MIN", "fiala_slip", "axle_stiffness", "lateral_capacity", "axle_slip",
           "axle_slip_values"]

CAPACITY_MIN = 0.3
"""Smallest share of an axle's friction :func:`lateral_capacity` leaves for its lateral force."""


class BrushSlip(NamedTuple):
    """:func:`fiala_slip`'s slip angle and its derivatives."""

    alpha: float                #: slip angle [rad], of the force's sign
    d_ln_stiffness: float       #: d alpha / d ln C [rad] (``-alpha``)
    d_ln_friction: float        #: d alpha / d ln F_max [rad]
    utilisation: float          #: |F| / F_max, not clipped


class AxleSlip(NamedTuple):
    """:func:`axle_slip`'s slip angle of an axle, its derivatives and the tire it used."""

    alpha: float                #: slip angle [rad]
    d_ln_stiffness: float       #: d alpha / d ln C [rad]
    d_ln_friction: float        #: d alpha / d ln F_max [rad]
    utilisation: float          #: |F_y| / F_max
    stiffness: float            #: the cornering stiffness used, C [N/rad]
    f_max: float                #: the lateral capacity used, F_max [N]
    stiffness_slope: float      #: d ln C / d ln mu of the vehicle file's stiffness
    capacity_slope: float       #: d ln F_max / d ln mu of the lateral capacity


def fiala_slip(force: float, stiffness: float, f_max: float, u_max: float) -> BrushSlip:
    """Slip angle of a brush (Fiala) tire carrying ``force`` [N], and its derivatives.

    ``alpha = 3 F_max / C (1 - (1 - u)^(1/3))`` with ``u = |F| / F_max`` (clipped at ``u_max``: at
    saturation the slip angle is not defined by the force), the inverse of
    ``F = C alpha - C^2 alpha |alpha| / (3 F_max) + C^3 alpha^3 / (27 F_max^2)``; ``F / C`` for small
    forces (Pacejka, *Tire and Vehicle Dynamics*, section 3.2).

    Parameters
    ----------
    force : float
        Lateral force [N].
    stiffness : float
        Cornering stiffness ``C`` [N/rad].
    f_max : float
        Friction limit of the lateral force [N].
    u_max : float
        Utilisation at which the slip angle is clipped.
    """
    return BrushSlip(*_fiala(force, stiffness, f_max, u_max))


def _fiala(force: float, stiffness: float, f_max: float, u_max: float) -> tuple:
    """:func:`fiala_slip` as a plain tuple (the filter's hot path)."""
    u = abs(force) / f_max
    uc = u if u < u_max else u_max
    w = (1.0 - uc) ** (1.0 / 3.0)
    a = 3.0 * f_max / stiffness
    alpha = math.copysign(a * (1.0 - w), force)
    # beyond u_max the derivative of the clipped curve, not zero: a friction estimated too low must be able to
    # climb back out of saturation
    d_fmax = a * ((1.0 - w) - uc / (3.0 * w * w))                    # <= 0: more friction, less slip
    if force < 0.0:
        d_fmax = -d_fmax
    return alpha, -alpha, d_fmax, u


def axle_stiffness(c_hi: float, c_lo: float, mu_lo: float, mu: float) -> tuple[float, float]:
    """The vehicle file's axle cornering stiffness at friction ``mu`` (linear between ``mu_lo`` and 1, held
    outside: tires on snow are softer in their linear range too) [N/rad] and ``d ln C / d ln mu``."""
    w = (mu - mu_lo) / (1.0 - mu_lo)
    if w >= 1.0:
        return c_hi, 0.0
    if w <= 0.0:
        return c_lo, 0.0
    c = c_lo + w * (c_hi - c_lo)
    return c, mu * (c_hi - c_lo) / ((1.0 - mu_lo) * c)


def lateral_capacity(f_max: float, f_x: float) -> tuple[float, float]:
    """The lateral force an axle can carry beside its longitudinal force ``f_x`` [N] (friction ellipse, isotropic:
    ``sqrt(F_max^2 - F_x^2)``, at least ``CAPACITY_MIN F_max``) and its ``d ln / d ln F_max``.

    A braked or driven tire has used part of its friction, so it slides sideways earlier (the brush model at
    combined slip, Pacejka, *Tire and Vehicle Dynamics*, ch. 3: the slip's magnitude, whatever its direction,
    saturates the friction circle).
    """
    f2 = f_max * f_max
    lat2 = f2 - f_x * f_x
    if lat2 <= (CAPACITY_MIN * f_max) ** 2:        # more than the friction estimate allows: it is too low
        return CAPACITY_MIN * f_max, 1.0
    return math.sqrt(lat2), f2 / lat2


def axle_slip(force: float, f_z: float, f_x: float, c_hi: float, c_lo: float, mu_lo: float, ln_scale: float,
              mu: float, u_max: float) -> AxleSlip:
    """Slip angle of an axle carrying the lateral ``force`` [N] on a load ``f_z`` [N] beside a longitudinal ``f_x``
    [N], at friction ``mu`` and the log stiffness scale ``ln_scale`` (:func:`axle_stiffness`,
    :func:`lateral_capacity`, :func:`fiala_slip`); ``c_hi``, ``c_lo`` are the vehicle file's stiffness at
    friction 1 and ``mu_lo`` [N/rad]."""
    return AxleSlip(*axle_slip_values(force, f_z, f_x, c_hi, c_lo, mu_lo, ln_scale, mu, u_max))


def axle_slip_values(force: float, f_z: float, f_x: float, c_hi: float, c_lo: float, mu_lo: float, ln_scale: float,
                     mu: float, u_max: float) -> tuple:
    """:func:`axle_slip` as a plain tuple in :class:`AxleSlip`'s order (the filter's hot path: a named tuple costs
    a Python call each)."""
    c, k = axle_stiffness(c_hi, c_lo, mu_lo, mu)
    c *= math.exp(ln_scale)
    f_max, g = lateral_capacity(mu * f_z, f_x)
    alpha, d_c, d_m, u = _fiala(force, c, f_max, u_max)
    return alpha, d_c, d_m, u, c, f_max, k, g
