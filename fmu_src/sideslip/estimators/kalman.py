"""The one Kalman / extended Kalman filter core of the project.

Every filter (Park 2018's three EKFs, Kim 2016, the linear bicycle observer, and the
estimators of the later issues) keeps its mean and covariance in a :class:`KalmanFilter`
and writes only its model: the predicted mean and Jacobian for :meth:`~KalmanFilter.predict`,
the innovation and measurement Jacobian for :meth:`~KalmanFilter.update`.  The caller
computes the innovation ``z - h(x)`` so that angle measurements can be wrapped.

Covariance updates use the Joseph form ``P = (I - K H) P (I - K H)^T + K R K^T`` and the
covariance is re-symmetrised after every update, so it stays symmetric positive definite
even with poorly conditioned gains.  At 3x3-5x5 numpy's per-call overhead dominates, so the
core uses ``ndarray.dot`` (half the cost of ``@`` at this size) and one raw LAPACK solve per
update: a predict costs ~4 us, an update ~12 us on the 2-core benchmark machine.  Filters
that run every 1 ms use :meth:`update_scalar`, which needs no solve.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgesv as _gesv

__all__ = ["KalmanFilter"]


class KalmanFilter:
    """Mean ``x`` (n,) and covariance ``P`` (n, n) with predict and update steps.

    Parameters
    ----------
    x0 : array_like
        Initial mean.
    P0 : array_like
        Initial covariance (symmetric positive definite).
    """

    def __init__(self, x0, P0):
        self.x = np.array(x0, dtype=float)
        self.P = np.array(P0, dtype=float)
        n = self.x.size
        if self.P.shape != (n, n):
            raise ValueError(f"P0 must be {n}x{n}, got {self.P.shape}")
        self._eye = np.eye(n)

    @property
    def n(self) -> int:
        """State dimension."""
        return self.x.size

    def predict(self, x_pred, F, Q) -> None:
        """Time update: ``x = x_pred``, ``P = F P F^T + Q``.

        Parameters
        ----------
        x_pred : array_like
            Predicted mean ``f(x, u)`` (for a linear model ``F x + B u``).
        F : ndarray
            State-transition matrix or Jacobian of ``f`` at the prior mean.
        Q : ndarray
            Process-noise covariance of the step.
        """
        self.x = np.asarray(x_pred, dtype=float)
        self.P = F.dot(self.P).dot(F.T) + Q     # symmetric to rounding; every update re-symmetrises

    def update(self, innovation, H, R) -> float:
        """Measurement update with innovation ``z - h(x)``, Jacobian ``H`` and noise ``R``.

        Returns
        -------
        float
            Normalised innovation squared ``y^T S^-1 y`` (for gating and consistency checks).
        """
        y = np.asarray(innovation, dtype=float)
        P = self.P
        PHt = P.dot(H.T)
        # one LAPACK solve S X = [H P, y] gives the gain K = X[:, :n]^T and S^-1 y for the NIS;
        # the raw LAPACK wrapper costs ~3 us, np.linalg.solve/inv ~10 us of Python-level checks
        _, _, X, info = _gesv(H.dot(PHt) + R, np.concatenate((PHt.T, y[:, None]), axis=1))
        if info != 0:
            raise np.linalg.LinAlgError(f"innovation covariance is singular (LAPACK dgesv info {info})")
        n = self.x.size
        K = X[:, :n].T
        self.x = self.x + K.dot(y)
        A = self._eye - K.dot(H)
        P = A.dot(P).dot(A.T) + K.dot(R).dot(K.T)         # Joseph form
        self.P = 0.5 * (P + P.T)
        return float(y.dot(X[:, n]))

    def update_scalar(self, innovation: float, h, r: float) -> float:
        """Update with one scalar measurement (row ``h``, variance ``r``); no matrix inverse.

        Equal to :meth:`update` with a 1x1 ``S``; several independent scalar measurements may
        be applied one after the other.

        Returns
        -------
        float
            Normalised innovation squared ``y^2 / s``.
        """
        h = np.asarray(h, dtype=float)
        Ph = self.P.dot(h)
        s = float(h.dot(Ph)) + r
        k = Ph / s
        self.x = self.x + k * innovation
        A = self._eye - k[:, None] * h
        P = A.dot(self.P).dot(A.T) + r * (k[:, None] * k)     # Joseph form
        self.P = 0.5 * (P + P.T)
        return innovation * innovation / s

    def std(self, i: int) -> float:
        """1-sigma of state ``i``."""
        return float(np.sqrt(max(self.P[i, i], 0.0)))
