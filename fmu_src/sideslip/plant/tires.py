"""Dugoff tire model with combined slip (Pi 2011 eqs 7-10, re-derived) and slip kinematics.

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
"""
from __future__ import annotations

from math import sqrt

__all__ = ["dugoff", "friction", "theoretical_slip"]


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
