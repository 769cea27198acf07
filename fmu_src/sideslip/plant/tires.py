"""Tire models with combined slip: Dugoff (Pi 2011 eqs 7-10, re-derived) and Pacejka's Magic Formula.

Dugoff
------

The printed equations 7-10 and 19 of Pi, Chen, Wang, Zhang (2011) mix two slip definitions (``(Rw - vx)/vx`` in
braking and ``(Rw - vx)/(Rw)`` in traction) with the ``1/(1 + sigma)`` factors of Dugoff's
braking-only derivation.  Both are the same thing written in *theoretical slip*: slip
velocity divided by the rolling speed ``R*omega`` (Dugoff, Fancher & Segel 1970):

    s_x = (v_x - R w) / (R w),   s_y = v_y / (R w)

    lambda = mu_eff Fz / (2 sqrt((C_s s_x)^2 + (C_a s_y)^2))          # eq 7
    f(lambda) = (2 - lambda) lambda  if lambda < 1  else 1              # eq 8
    Fx = -C_s s_x f(lambda),   Fy = -C_a s_y f(lambda)                  # eqs 9-10

With the braking slip ``sigma = (Rw - v)/v`` one has ``sigma/(1+sigma) = -s_x`` and
``tan(alpha)/(1+sigma) = s_y``, so this is eqs 9-10 exactly, continuous through zero slip
and valid in traction and in reverse.  Signs: forces act against the slip velocity.

Low-speed regularisation: the rolling speed in the denominators is replaced by
``max(|R w|, v_min)``.  Below ``v_min`` the tire becomes a linear damper on the slip
velocity (``F = -C s_vel / v_min``), which keeps forces finite at standstill and the
wheel-spin dynamics no stiffer than ``R^2 C_s / (I_w v_min)`` (see :mod:`.vehicle`).
The velocity effect of eq 7, ``mu (1 - eps_v v_slide)``, is applied by :func:`friction`.

Magic Formula
-------------
The structure of MF 5.2 (Pacejka 2002; H. B. Pacejka, *Tire and Vehicle Dynamics*, ch. 4.3.2)
for a symmetric tire without camber: no horizontal or vertical shifts, no aligning moment, the
subset of coefficients in :class:`MagicFormula`.  Practical slips ``kappa = (R w - v_x) / |v_x|``
(positive in traction) and ``alpha = atan(v_y / |v_x|)``; pure slip

    F_x0 = D_x sin(C_x atan(B_x kappa - E_x (B_x kappa - atan(B_x kappa))))
    F_y0 = -D_y sin(C_y atan(B_y alpha - E_y (B_y alpha - atan(B_y alpha))))
    D = mu (p_D1 + p_D2 dfz) F_z,   dfz = (F_z - F_z0) / F_z0,   B = K / (C D)

with the slip stiffnesses ``K_x = C_sigma F_z / F_z0`` and ``K_y = C_alpha sin(2 atan(F_z /
(p_Ky2 F_z0))) / sin(2 atan(1 / p_Ky2))``, so that at the nominal load ``F_z0`` the slopes at
zero slip are the vehicle's ``C_sigma`` and cornering stiffness (the same as Dugoff's) and the
cornering stiffness grows less than linearly with load.  Combined slip by the weighting
functions ``G_xa = cos(r_Cx1 atan(r_Bx1 cos(atan(r_Bx2 kappa)) alpha))`` and ``G_yk =
cos(r_Cy1 atan(r_By1 cos(atan(r_By2 alpha)) kappa))``: ``F_x = G_xa F_x0``, ``F_y = G_yk F_y0``.
The road friction ``mu`` scales the peaks (``lambda_mu``), as it scales Dugoff's limit.  Below
``v_min`` the slip denominators are ``v_min``: the tire is a damper at standstill.
"""
from __future__ import annotations

from math import atan, cos, sin, sqrt
from typing import NamedTuple

__all__ = ["dugoff", "friction", "theoretical_slip", "practical_slip", "MagicFormula", "magic_formula"]


def theoretical_slip(v_x: float, v_y: float, omega: float, radius: float, v_min: float):
    """Theoretical slips of one wheel from its contact-point velocity in wheel axes.

    Parameters
    ----------
    v_x, v_y : float
        Velocity of the wheel centre along / across the wheel heading [m/s].
    omega : float
        Wheel spin rate [rad/s].
    radius : float
        Effective rolling radius [m].
    v_min : float
        Regularisation speed [m/s] (> 0).

    Returns
    -------
    s_x, s_y : float
        Longitudinal and lateral theoretical slip [-] (positive ``s_x`` = braking).
    """
    rolling = radius * omega
    den = rolling if rolling > v_min else (-rolling if -rolling > v_min else v_min)   # max(|R w|, v_min)
    return (v_x - rolling) / den, v_y / den


def friction(mu: float, eps_v: float, v_slide: float) -> float:
    """Effective friction coefficient with Dugoff's velocity effect (Pi 2011 eq 7).

    ``mu (1 - eps_v v_slide)``, floored at ``0.1 mu`` so that a large ``eps_v`` cannot
    invert the friction force.
    """
    reduction = 1.0 - eps_v * v_slide
    return mu * (reduction if reduction > 0.1 else 0.1)


def dugoff(mu_fz: float, c_sigma: float, c_alpha: float, s_x: float, s_y: float):
    """Dugoff combined-slip forces of one tire in wheel axes (Pi 2011 eqs 7-10).

    Parameters
    ----------
    mu_fz : float
        Friction-limited force ``mu_eff * Fz`` [N] (``Fz >= 0``).
    c_sigma : float
        Longitudinal slip stiffness [N per unit slip].
    c_alpha : float
        Cornering stiffness [N/rad].
    s_x, s_y : float
        Theoretical slips from :func:`theoretical_slip`.

    Returns
    -------
    F_x, F_y : float
        Longitudinal and lateral tire force [N] in wheel axes.
    """
    c_x = c_sigma * s_x
    c_y = c_alpha * s_y
    norm = sqrt(c_x * c_x + c_y * c_y)
    if norm > 0.0:
        lam = mu_fz / (2.0 * norm)
        if lam < 1.0:
            f = (2.0 - lam) * lam
            return -c_x * f, -c_y * f
    return -c_x, -c_y


# ------------------------------------------------------------------------------ Magic Formula
def practical_slip(v_x: float, v_y: float, omega: float, radius: float, v_min: float):
    """Practical slips of one wheel (the Magic Formula's inputs).

    Parameters
    ----------
    v_x, v_y : float
        Velocity of the wheel centre along / across the wheel heading [m/s].
    omega : float
        Wheel spin rate [rad/s].
    radius : float
        Effective rolling radius [m].
    v_min : float
        Regularisation speed [m/s] (> 0).

    Returns
    -------
    kappa : float
        Longitudinal slip ``(R w - v_x) / max(|v_x|, v_min)`` [-] (positive in traction).
    alpha : float
        Slip angle ``atan(v_y / max(|v_x|, v_min))`` [rad] (the lateral force opposes it).
    """
    den = v_x if v_x > v_min else (-v_x if -v_x > v_min else v_min)
    return (radius * omega - v_x) / den, atan(v_y / den)


class MagicFormula(NamedTuple):
    """Magic Formula coefficients of one tire (the MF 5.2 subset of the module docstring).

    The nominal load and the two slip stiffnesses tie the formula to the vehicle; the shape,
    peak and combined-slip coefficients come from the vehicle's parameter set
    (:meth:`sideslip.vehicles.VehicleParams.magic_formula`).
    """

    Fz0: float       #: nominal load [N]
    pCx1: float      #: longitudinal shape factor C_x
    pDx1: float      #: longitudinal friction at the nominal load (times the road's mu)
    pDx2: float      #: variation of the longitudinal friction with load
    pEx1: float      #: longitudinal curvature E_x (< 1)
    pCy1: float      #: lateral shape factor C_y
    pDy1: float      #: lateral friction at the nominal load (times the road's mu)
    pDy2: float      #: variation of the lateral friction with load
    pEy1: float      #: lateral curvature E_y (< 1)
    pKy2: float      #: load (in units of Fz0) at which the cornering stiffness would peak
    rBx1: float      #: combined slip: slope of the Fx reduction with the slip angle
    rBx2: float      #: combined slip: its variation with kappa
    rCx1: float      #: combined slip: shape of the Fx reduction
    rBy1: float      #: combined slip: slope of the Fy reduction with kappa
    rBy2: float      #: combined slip: its variation with alpha
    rCy1: float      #: combined slip: shape of the Fy reduction


def magic_formula(fz: float, mu: float, c_sigma: float, c_alpha: float, kappa: float, alpha: float,
                  p: MagicFormula):
    """Magic Formula combined-slip forces of one tire in wheel axes (module docstring).

    Parameters
    ----------
    fz : float
        Vertical load [N] (``>= 0``).
    mu : float
        Road friction (scales the peaks) [-].
    c_sigma, c_alpha : float
        Longitudinal slip stiffness [N] and cornering stiffness [N/rad] at the nominal load.
    kappa, alpha : float
        Practical slips from :func:`practical_slip` [-, rad].
    p : MagicFormula
        Coefficients.

    Returns
    -------
    F_x, F_y : float
        Longitudinal and lateral tire force [N] in wheel axes.
    """
    if fz <= 0.0:
        return 0.0, 0.0
    fz0 = p.Fz0
    dfz = (fz - fz0) / fz0
    # pure longitudinal slip
    dx = mu * (p.pDx1 + p.pDx2 * dfz) * fz
    bx = c_sigma * fz / fz0 / (p.pCx1 * dx)
    x = bx * kappa
    fx0 = dx * sin(p.pCx1 * atan(x - p.pEx1 * (x - atan(x))))
    # pure lateral slip
    dy = mu * (p.pDy1 + p.pDy2 * dfz) * fz
    ky = c_alpha * sin(2.0 * atan(fz / (p.pKy2 * fz0))) / sin(2.0 * atan(1.0 / p.pKy2))
    by = ky / (p.pCy1 * dy)
    y = by * alpha
    fy0 = -dy * sin(p.pCy1 * atan(y - p.pEy1 * (y - atan(y))))
    # combined slip: weighting functions (no shifts)
    gxa = cos(p.rCx1 * atan(p.rBx1 * cos(atan(p.rBx2 * kappa)) * alpha))
    gyk = cos(p.rCy1 * atan(p.rBy1 * cos(atan(p.rBy2 * alpha)) * kappa))
    return gxa * fx0, gyk * fy0
