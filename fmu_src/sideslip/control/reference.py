"""Reference model of the stability controller (Nguyen 2012 eqs 21-22).

The driver's steering asks for the steady-state sideslip and yaw rate of the linear bicycle
model (nominal cornering stiffness, :class:`~sideslip.bicycle.BicycleModel`), each through a
first-order lag.  Eq 22 as printed lacks the ``s`` of its lag (``1 + tau_gamma``); it is the
lag ``1 / (1 + tau_gamma s)`` like eq 21.

Friction limit: on a road of friction ``mu`` the car cannot turn faster than
``mu g / v_x`` (``a_y = v_x r <= mu g``), so the yaw-rate target is clipped there; when it
is, the sideslip target is scaled by the same factor so that the pair stays on the model's
steady-state line (the bicycle model's ``beta / r`` ratio) instead of asking for the
sideslip of a turn the road cannot give.

Held limit (``hold_limit``, a controller following a friction estimate): the clip above acts on the
targets, before the lags, so when the friction falls (or the speed rises) faster than ``tau_gamma`` the
lagged references stay above what the road can turn for a few tenths of a second.  Held, each lagged reference is
kept within its own target's bound at the current friction and speed (``|gamma| <= mu g / v_x``,
``|beta| <= |k_beta| mu g / (v_x |k_gamma|)``); with a constant friction and speed it never binds.
"""
from __future__ import annotations

import math

from ..bicycle import BicycleModel
from ..constants import GRAVITY

__all__ = ["ReferenceModel"]


class ReferenceModel:
    """Sideslip and yaw-rate references from the steering angle (eqs 21-22), friction-limited.

    Parameters
    ----------
    model : BicycleModel
        Nominal linear bicycle model.
    tau_beta, tau_gamma : float
        Time constants of the first-order lags [s] (0: no lag).
    Ts : float
        Sample period [s] (lags discretised exactly).
    mu : float
        Road friction used for the yaw-rate limit [-].
    hold_limit : bool
        Keep the lagged references within the friction limit too (module docstring).
    """

    def __init__(self, model: BicycleModel, tau_beta: float, tau_gamma: float, Ts: float, mu: float,
                 hold_limit: bool = False):
        self.model, self.mu, self.hold_limit = model, mu, hold_limit
        self._a_beta = math.exp(-Ts / tau_beta) if tau_beta > 0 else 0.0
        self._a_gamma = math.exp(-Ts / tau_gamma) if tau_gamma > 0 else 0.0
        self.reset()

    def reset(self) -> None:
        """References at zero."""
        self.beta = self.gamma = 0.0

    def limited_steer(self, delta: float, vx: float) -> float:
        """The steering clipped at what the road can turn: ``|k_gamma delta| <= mu g / vx`` [rad]."""
        lim = self.mu * GRAVITY / (vx * abs(self.model.steady_state_gains(vx)[1]))
        return lim if delta > lim else (-lim if delta < -lim else delta)

    def run(self, delta, vx) -> tuple:
        """The references of a whole run from rest (:meth:`reset`): :meth:`step` over the samples of the arrays
        ``delta`` [rad] and ``vx`` [m/s], vectorised (the same operations, the same doubles); returns the arrays
        ``(beta_ref, gamma_ref)``.  Not with ``hold_limit``, whose clip feeds back into the lags."""
        if self.hold_limit:
            raise ValueError("a held friction limit feeds back into the lags: step the references instead")
        import numpy as np
        from scipy.signal import lfilter

        delta, vx = np.asarray(delta, dtype=float), np.asarray(vx, dtype=float)
        k_beta, k_gamma = self.model.steady_state_gains(vx)
        lim = self.mu * GRAVITY / (vx * np.abs(k_gamma))
        delta = np.clip(delta, -lim, lim)
        lag = lambda a, x: lfilter([1.0 - a], [1.0, -a], x)              # noqa: E731 - eqs 21-22's lags
        return lag(self._a_beta, k_beta * delta), lag(self._a_gamma, k_gamma * delta)

    def step(self, delta: float, vx: float) -> tuple[float, float]:
        """Advance the lags by one sample; returns ``(beta_ref, gamma_ref)``."""
        k_beta, k_gamma = self.model.steady_state_gains(vx)          # eqs 21-22 without the lags
        lim = self.mu * GRAVITY / (vx * abs(k_gamma))                 # limited_steer, with the gains at hand
        clipped = lim if delta > lim else (-lim if delta < -lim else delta)
        beta = self._a_beta * self.beta + (1.0 - self._a_beta) * (k_beta * clipped)       # eq 21 lag
        gamma = self._a_gamma * self.gamma + (1.0 - self._a_gamma) * (k_gamma * clipped)  # eq 22 lag
        if self.hold_limit:                                           # the targets' bounds now
            b_max, g_max = abs(k_beta) * lim, abs(k_gamma) * lim
            beta = b_max if beta > b_max else (-b_max if beta < -b_max else beta)
            gamma = g_max if gamma > g_max else (-g_max if gamma < -g_max else gamma)
        self.beta, self.gamma = beta, gamma
        return beta, gamma
