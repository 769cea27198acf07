"""The interacting multiple model (IMM) of any number of Kalman filters.

Blom and Bar-Shalom (1988), "The interacting multiple model algorithm for systems with Markovian
switching coefficients"; Bar-Shalom, Li and Kirubarajan, *Estimation with Applications to Tracking
and Navigation* (2001), section 11.6.6.  Each *mode* is a filter on the same state with its own
model; a Markov chain with the transition matrix ``T[i, j]`` (from mode ``i`` to mode ``j`` per
sample) switches between them.  One cycle:

1. **Mixing** (interaction, :meth:`InteractingMultipleModel.mix`): with the predicted mode
   probabilities ``c_j = sum_i T[i, j] mu_i``, each filter ``j`` starts from the mixture of all with
   the weights ``w[i, j] = T[i, j] mu_i / c_j`` (:func:`mixture`).
2. Each filter runs its own predict and updates; the caller sums each filter's measurement
   log-likelihoods ``-(nis + ln det(2 pi S)) / 2``.
3. **Mode probabilities** (:meth:`InteractingMultipleModel.update`): ``mu_j`` proportional to
   ``c_j`` times the likelihood of filter ``j``.  A measurement applied outside the cycle updates
   them the same way with the current probabilities as the prior.
4. **Combination** (:meth:`InteractingMultipleModel.combine`): the moment-matched mixture with the
   weights ``mu`` (:func:`mixture`); the filters themselves keep their own estimates.
"""
from __future__ import annotations

import numpy as np

__all__ = ["InteractingMultipleModel", "mixture", "PROBABILITY_FLOOR"]

PROBABILITY_FLOOR = 1e-6
"""Smallest mode probability: a mode that becomes right again must be able to gain weight."""


def mixture(weights, means, covariances) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of a Gaussian mixture, moment-matched.

    ``x = sum_i w_i x_i`` and ``P = sum_i w_i (P_i + (x_i - x)(x_i - x)^T)``.

    Parameters
    ----------
    weights : sequence of float
        Weights of the components (summing to one).
    means, covariances : sequence of ndarray
        The components' means (n,) and covariances (n, n).
    """
    w = weights.tolist() if isinstance(weights, np.ndarray) else list(weights)    # floats: no numpy scalars
    x = w[0] * means[0]
    for k in range(1, len(w)):
        x = x + w[k] * means[k]
    P = np.zeros(covariances[0].shape)
    for k in range(len(w)):
        d = means[k] - x
        P += w[k] * (covariances[k] + d[:, None] * d[None, :])
    return x, P


class InteractingMultipleModel:
    """Mode probabilities and the mixing of the filters of an IMM (module docstring).

    Parameters
    ----------
    probabilities : sequence of float
        Initial mode probabilities (summing to one), one per filter.
    switch : float
        Probability per sample of leaving a mode, shared equally among the other modes.
    """

    __slots__ = ("probabilities", "transition")

    def __init__(self, probabilities, switch: float):
        n = len(probabilities)
        if n < 2:
            raise ValueError(f"an IMM needs two or more modes, got {n}")
        if not 0.0 < switch < 1.0:
            raise ValueError(f"the switching probability must lie in (0, 1), got {switch}")
        self.probabilities = np.array(probabilities, dtype=float)
        self.transition = np.full((n, n), switch / (n - 1))
        np.fill_diagonal(self.transition, 1.0 - switch)

    def mix(self, filters) -> np.ndarray:
        """Set every filter to its mixed prior (step 1); returns the predicted mode probabilities ``c``."""
        T, mu = self.transition, self.probabilities
        c = T.T.dot(mu)
        w = T * mu[:, None] / c[None, :]                 # w[i, j]: weight of filter i in the prior of filter j
        means = [kf.x for kf in filters]
        covariances = [kf.P for kf in filters]
        mixed = [mixture(w[:, j], means, covariances) for j in range(len(filters))]
        for kf, (x, P) in zip(filters, mixed):
            kf.x, kf.P = x, P
        return c

    def update(self, log_likelihoods, prior) -> None:
        """Mode probabilities proportional to ``prior`` times each filter's likelihood (step 3), each at least
        :data:`PROBABILITY_FLOOR`."""
        logs = np.asarray(log_likelihoods, dtype=float)
        like = np.exp(logs - logs.max()) * prior
        mu = np.maximum(like / like.sum(), PROBABILITY_FLOOR)
        mu /= mu.sum()
        self.probabilities = mu

    def combine(self, filters) -> tuple[np.ndarray, np.ndarray]:
        """The combined estimate, mean and covariance (step 4)."""
        return mixture(self.probabilities, [kf.x for kf in filters], [kf.P for kf in filters])
