"""LQR feedback of the direct yaw moment (Nguyen 2012 eqs 25-26), scheduled on speed.

The plant for the design is the linear bicycle model (eqs 1-2) with the in-wheel motors' yaw
moment ``N_z`` as the only input, ``x = [beta, gamma]``.  The LQR minimises eq 26,
``J = 1/2 int q_beta E_beta^2 + q_gamma E_gamma^2 + q_N N_z^2 dt``, giving ``N_z = -K x``;
applied to the tracking error ``E = x* - x_hat`` this is eq 25 with ``[g_beta, g_gamma] = K``.

:func:`lqr_row` solves the Riccati equation with SciPy's ``solve_continuous_are``, the call
python-control's ``control.lqr`` makes without slycot (the same arguments, so the gains are
bit-identical: tests/test_control.py), rather than through ``control.lqr`` itself: importing
python-control takes about 2 s (it imports matplotlib and scipy.signal), which every controller
FMU would otherwise spend at instantiation.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..bicycle import BicycleModel
from .schedule import SpeedTable, speed_grid

__all__ = ["yaw_moment_model", "lqr_row", "lqr_gains", "gain_schedule"]


def yaw_moment_model(model: BicycleModel, vx: float) -> tuple[np.ndarray, np.ndarray]:
    """``A`` (2x2) and the yaw-moment column ``B_N`` (2x1) of the bicycle model at ``vx``."""
    a, b = model.matrices(vx)
    return a, b[:, 1:]


def lqr_row(a: np.ndarray, b: np.ndarray, q: np.ndarray, r: float) -> np.ndarray:
    """Gain row ``k`` of the single-input LQR ``u = -k x`` for ``dx/dt = a x + b u`` (as ``control.lqr``)."""
    from scipy.linalg import solve_continuous_are     # here: a controller without the LQR needs no SciPy

    a, b, q = (np.array(m, ndmin=2) for m in (a, b, q))
    rr = np.array([[r]], ndmin=2)
    x = solve_continuous_are(a, b, q, rr)
    return np.asarray(np.linalg.solve(rr, b.T @ x), dtype=float).ravel()


def lqr_gains(model: BicycleModel, vx: float, q_beta: float, q_gamma: float, q_N: float) -> tuple[float, float]:
    """LQR gains ``(g_beta, g_gamma)`` [N m/rad, N m s/rad] at speed ``vx`` (eqs 25-26)."""
    a, b = yaw_moment_model(model, vx)
    k = lqr_row(a, b, np.diag([q_beta, q_gamma]), q_N)
    return float(k[0]), float(k[1])


def gain_schedule(model: BicycleModel, q_beta: float, q_gamma: float, q_N: float, v_lo: float, v_hi: float,
                  n: int = 32) -> SpeedTable:
    """LQR gains on a speed grid (see :mod:`sideslip.control.schedule`)."""
    return SpeedTable(speed_grid(v_lo, v_hi, n), _gain_rows(model, q_beta, q_gamma, q_N, v_lo, v_hi, n))


@lru_cache(maxsize=256)
def _gain_rows(model: BicycleModel, q_beta: float, q_gamma: float, q_N: float, v_lo: float, v_hi: float,
               n: int) -> tuple:
    """The gains of :func:`gain_schedule`, solved once per process for a design: a study's controllers and a
    friction schedule's designs repeat the same Riccati equations."""
    return tuple(lqr_gains(model, v, q_beta, q_gamma, q_N) for v in speed_grid(v_lo, v_hi, n))
