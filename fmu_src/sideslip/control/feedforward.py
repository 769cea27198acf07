"""Feed-forward of the direct yaw moment (Nguyen 2012 eqs 23-24), scheduled on speed.

Eq 23 splits the bicycle model's sideslip response, ``beta = G_11 delta_f + G_12 N_z``, and
eq 24 picks the yaw moment that makes it the reference response ``G_beta`` of eq 21:
``G_ff = (G_beta - G_11) / G_12``.  ``G_11`` and ``G_12`` share the model's characteristic
polynomial and ``G_12`` has a constant numerator (the yaw moment reaches the sideslip only
through the yaw rate), so ``G_ff`` has a second-order numerator over ``1 + tau_beta s``:
improper.  It is made proper with a first-order low-pass ``1 / (1 + tau_ff s)``, so the
realised feed-forward tracks ``G_beta`` up to about ``1 / (2 pi tau_ff)`` Hz.

python-control does the algebra (with ``minreal`` cancelling the shared polynomial) and the
discretisation, by the bilinear (Tustin) map rather than the zero-order hold: the filter is
biproper with a fast low-pass, so its continuous output moves within a sample, and the ZOH
filter's samples of it, held by the plant for a whole step, miss the target.  On the SUV at
80 km/h with a 0.7 Hz steer (1 ms), the linear model's sideslip deviates from ``G_beta delta``
by 9.4 / 2.3 / 0.46 % of its peak with Tustin for ``tau_ff`` = 20 / 5 / 1 ms, and by
10.6 / 15 / 81 % with the ZOH (tests/test_control.py).  The denominator of the result,
``(1 + tau_beta s)(1 + tau_ff s)``, does not depend on the speed, so the discrete filter has
fixed poles and a speed-scheduled numerator: interpolating the numerator between grid speeds
gives a well-defined time-varying filter (transposed direct form II).
"""
from __future__ import annotations

import warnings
from functools import lru_cache

import control
import numpy as np

from ..bicycle import BicycleModel
from .schedule import SpeedTable, speed_grid

__all__ = ["sideslip_responses", "reference_sideslip", "feedforward_tf", "ScheduledFeedforward"]


def sideslip_responses(model: BicycleModel, vx: float) -> tuple[control.TransferFunction, control.TransferFunction]:
    """``G_11`` (steering -> sideslip) and ``G_12`` (yaw moment -> sideslip) of eq 23 at ``vx``.

    Written from ``(sI - A)^-1 B`` by Cramer's rule rather than ``ss2tf``, whose round-off
    leaves a spurious ``1e-15 s`` in the numerator of ``G_12`` that spoils the division of eq 24.
    """
    a, b = model.matrices(vx)
    den = [1.0, -(a[0, 0] + a[1, 1]), a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]]
    g11 = control.tf([b[0, 0], a[0, 1] * b[1, 0] - a[1, 1] * b[0, 0]], den)
    g12 = control.tf([a[0, 1] * b[1, 1]], den)
    return g11, g12


def reference_sideslip(model: BicycleModel, vx: float, tau_beta: float) -> control.TransferFunction:
    """``G_beta`` of eq 21: the steady-state sideslip gain through the lag ``1 / (1 + tau_beta s)``."""
    return control.tf([model.steady_state_gains(vx)[0]], [tau_beta, 1.0])


def feedforward_tf(model: BicycleModel, vx: float, tau_beta: float, tau_ff: float) -> control.TransferFunction:
    """The proper feed-forward ``G_ff(s) / (1 + tau_ff s)`` of eq 24 at ``vx`` [N m/rad]."""
    g11, g12 = sideslip_responses(model, vx)
    lag = control.tf([tau_beta, 1.0], [1.0])
    with warnings.catch_warnings():            # the intermediate (G_beta - G_11)/G_12 * lag is improper
        warnings.simplefilter("ignore")
        poly = control.minreal((reference_sideslip(model, vx, tau_beta) - g11) / g12 * lag, verbose=False)
    num = np.atleast_1d(np.squeeze(poly.num[0][0])) / float(np.squeeze(poly.den[0][0]))
    if np.size(np.atleast_1d(np.squeeze(poly.den[0][0]))) != 1 or num.size > 3:
        raise ArithmeticError("eq 24 did not reduce to a polynomial over the reference lag")
    return control.tf(num, np.polymul([tau_beta, 1.0], [tau_ff, 1.0]))


@lru_cache(maxsize=64)
def _discrete_schedule(model: BicycleModel, tau_beta: float, tau_ff: float, Ts: float, v_lo: float, v_hi: float,
                       n: int) -> tuple:
    """Grid, discrete numerators and the fixed denominator ``(a1, a2)`` of the feed-forward.

    Cached: it depends on the model and time constants only, not on the LQR weights, so a
    tuning study computes it once per worker process.
    """
    grid = speed_grid(v_lo, v_hi, n)
    nums, den = [], None
    for v in grid:
        d = control.c2d(feedforward_tf(model, v, tau_beta, tau_ff), Ts, method="tustin")
        num_v, den_v = (np.atleast_1d(np.squeeze(p[0][0])) for p in (d.num, d.den))
        num_v = np.concatenate([np.zeros(3 - num_v.size), num_v]) / den_v[0]
        den_v = den_v / den_v[0]
        if den is None:
            den = den_v
        elif not np.allclose(den_v, den, rtol=1e-9, atol=1e-12):       # fixed poles, see module doc
            raise ArithmeticError("feed-forward poles vary with speed")
        nums.append(tuple(num_v))
    return tuple(grid), tuple(nums), float(den[1]), float(den[2])


class ScheduledFeedforward:
    """Discrete feed-forward filter ``delta_f -> N_z_ff`` with its numerator scheduled on speed.

    Parameters
    ----------
    model : BicycleModel
        Nominal model the feed-forward inverts.
    tau_beta, tau_ff : float
        Reference-lag and proper-ing low-pass time constants [s].
    Ts : float
        Sample period [s].
    v_lo, v_hi : float
        Speed range of the grid [m/s].
    """

    def __init__(self, model: BicycleModel, tau_beta: float, tau_ff: float, Ts: float, v_lo: float,
                 v_hi: float, n: int = 32):
        grid, nums, self.a1, self.a2 = _discrete_schedule(model, tau_beta, tau_ff, Ts, v_lo, v_hi, n)
        self.numerator = SpeedTable(grid, nums)
        self.reset()

    def reset(self) -> None:
        """Zero filter state."""
        self._s1 = self._s2 = 0.0

    def step(self, delta: float, vx: float) -> float:
        """One sample: feed-forward yaw moment [N m] for steering ``delta`` [rad] at ``vx`` [m/s]."""
        b0, b1, b2 = self.numerator(vx)
        y = b0 * delta + self._s1                     # transposed direct form II
        self._s1 = b1 * delta - self.a1 * y + self._s2
        self._s2 = b2 * delta - self.a2 * y
        return y
