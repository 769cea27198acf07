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
    """

    def __init__(self, model: BicycleModel, tau_beta: float, tau_gamma: float, Ts: float, mu: float):
        self.model, self.mu = model, mu
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

    def targets(self, delta: float, vx: float) -> tuple[float, float]:
        """Steady-state ``(beta, gamma)`` targets [rad, rad/s] for steering ``delta`` at ``vx``."""
        k_beta, k_gamma = self.model.steady_state_gains(vx)          # eqs 21-22 without the lags
        lim = self.mu * GRAVITY / (vx * abs(k_gamma))                 # limited_steer, with the gains at hand
        delta = lim if delta > lim else (-lim if delta < -lim else delta)
        return k_beta * delta, k_gamma * delta

    def run(self, delta, vx) -> tuple:
        """The references of a whole run from rest (:meth:`reset`): :meth:`step` over the samples of the arrays
        ``delta`` [rad] and ``vx`` [m/s], vectorised (the same operations, the same doubles); returns the arrays
        ``(beta_ref, gamma_ref)``."""
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
        beta, gamma = self.targets(delta, vx)
        self.beta = self._a_beta * self.beta + (1.0 - self._a_beta) * beta       # eq 21 lag
        self.gamma = self._a_gamma * self.gamma + (1.0 - self._a_gamma) * gamma  # eq 22 lag
        return self.beta, self.gamma
