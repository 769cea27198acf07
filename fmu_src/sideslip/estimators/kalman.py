"""The one Kalman / extended Kalman filter core of the project.

Every filter of the project (Park 2018's three EKFs, Kim 2016, Nguyen 2012, Pi 2011, Yoon 2014, the
linear bicycle observer) keeps its mean and covariance in a :class:`KalmanFilter`
and writes only its model: the predicted mean and Jacobian for :meth:`~KalmanFilter.predict`,
the innovation and measurement Jacobian for :meth:`~KalmanFilter.update`.  The caller
computes the innovation ``z - h(x)`` so that angle measurements can be wrapped.

Vector updates use the Joseph form ``P = (I - K H) P (I - K H)^T + K R K^T`` and re-symmetrise
the covariance, so it stays symmetric positive definite even with poorly conditioned gains.
Scalar updates (:meth:`update_scalar`, :meth:`update_state`) compute their gain from the same
``P``, for which the Joseph form reduces exactly to a symmetric rank-1 downdate (one BLAS call).

At 3x3-5x5 numpy's per-call overhead dominates, so the core uses ``ndarray.dot`` (half the cost
of ``@`` at this size), one raw LAPACK solve per vector update and one BLAS call per scalar
update: a predict costs ~3 us, a vector update ~12 us, a scalar update ~4 us on the 2-core
benchmark machine.

:class:`InnovationMonitor` tells whether a filter's covariance explains its innovations (the normalised
innovation squared over a window): estimators inflate their reported std by it and call themselves not valid
when it fails.

A measurement that arrives ``lag`` samples late (a GNSS fix) is applied through
:class:`DelayedMeasurements`, which keeps the filter's last samples and extrapolates the update to
now (Larsen et al. 1998) instead of re-running the filter from the measurement's time.
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np
from scipy.linalg.blas import dger as _ger
from scipy.linalg.lapack import dgesv as _gesv

__all__ = ["KalmanFilter", "DelayedMeasurements", "InnovationMonitor"]


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
        self._predictions = 0
        self.A = None       # the error transition since the last DelayedMeasurements.push, when tracked

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
            Process-noise covariance of the step, (n, n), or (n,) for a diagonal one.
        """
        self.x = np.asarray(x_pred, dtype=float)
        if self.A is not None:
            self.A = F.dot(self.A)
        P = F.dot(self.P).dot(F.T)
        if Q.ndim == 1:
            P.ravel()[::P.shape[0] + 1] += Q              # the diagonal, as a view of the fresh product
        else:
            P += Q
        self._predictions += 1
        if self._predictions % 64 == 0:         # F P F^T and the rank-1 updates are symmetric to rounding
            P = 0.5 * (P + P.T)                 # only; a periodic re-symmetrisation bounds the drift
        self.P = P

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
        if self.A is not None:
            self.A = A.dot(self.A)
        P = A.dot(P).dot(A.T) + K.dot(R).dot(K.T)         # Joseph form
        self.P = 0.5 * (P + P.T)
        return float(y.dot(X[:, n]))

    def update_scalar(self, innovation: float, h, r: float, Ph=None, hPh: float | None = None) -> float:
        """Update with one scalar measurement (row ``h``, variance ``r``); no matrix inverse.

        Equal to :meth:`update` with a 1x1 ``S``; several independent scalar measurements may
        be applied one after the other.  With the gain ``k = P h / s`` computed here from the
        same ``P``, the Joseph form reduces exactly to the rank-1 downdate
        ``P - (P h)(P h)^T / s``, done in one BLAS ``dger`` call; it stays positive definite
        because ``s = h^T P h + r > h^T P h``.

        ``Ph``, ``P h`` of the current ``P``, and ``hPh``, ``float(h.dot(Ph))``, may be passed by a caller that
        needed them before (its innovation's variance ``h^T P h``); they are computed otherwise.

        Returns
        -------
        float
            Normalised innovation squared ``y^2 / s``.
        """
        h = np.asarray(h, dtype=float)
        P = self.P
        if Ph is None:
            Ph = P.dot(h)
        s = (float(h.dot(Ph)) if hPh is None else hPh) + r
        innovation = float(innovation)
        self.x = self.x + Ph * (innovation / s)
        if self.A is not None:                            # (I - k h^T) A
            self.A = _ger(-1.0 / s, Ph, h.dot(self.A), a=self.A)
        self.P = _ger(-1.0 / s, Ph, Ph, a=P)
        return innovation * innovation / s

    def update_state(self, i: int, innovation: float, r: float) -> float:
        """Update with a direct measurement of state ``i`` (``h = e_i``), variance ``r``.

        With ``p = P[:, i]``, ``s = P[i, i] + r`` and the gain ``k = p / s`` computed here from
        the same ``P``, the Joseph form reduces exactly to the rank-1 downdate ``P - p p^T / s``;
        computed as ``p`` outer ``p`` times ``1/s`` it is symmetric bitwise and stays positive
        definite for ``r > 0`` (``p_j^2 <= P_ii P_jj < s P_jj``).  It costs a third of
        :meth:`update_scalar` (six numpy calls), which matters for the filters that update the
        yaw rate every 1 ms.

        Returns
        -------
        float
            Normalised innovation squared ``y^2 / s``.
        """
        P = self.P
        p = P[:, i].copy()                                # not a view: dger may update P's buffer in place
        s = P.item(i, i) + r                              # Python floats from here: numpy scalars are slow
        innovation = float(innovation)
        self.x = self.x + p * (innovation / s)
        if self.A is not None:
            self.A = _ger(-1.0 / s, p, self.A[i].copy(), a=self.A)
        self.P = _ger(-1.0 / s, p, p, a=P)                # BLAS rank-1 update, one call
        return innovation * innovation / s

    def std(self, i: int) -> float:
        """1-sigma of state ``i``."""
        return float(np.sqrt(max(self.P[i, i], 0.0)))


class DelayedMeasurements:
    """A filter's last samples, so that a measurement taken ``lag`` samples ago updates it now.

    Larsen, Andersen, Ravn and Poulsen (1998), "Incorporation of time delayed measurements in a
    discrete-time Kalman filter": the measurement's innovation and gain are those of the sample it
    was taken at, ``K_s = P_s H^T S^-1`` with ``S = H P_s H^T + R``, and the correction reaches
    every later sample ``j`` through the error transition ``M_j`` of the filter's own steps since
    (its predictions and updates, tracked in :attr:`KalmanFilter.A`):
    ``x_j += M_j K_s y``, ``P_j -= M_j K_s S K_s^T M_j^T``; for an extended filter the transitions
    are the Jacobians of the steps as they ran (no re-linearisation).  The stored samples are
    corrected too, so that measurements arriving faster than their delay are not counted twice.

    It equals applying the measurement at its sample and re-running the filter when only
    predictions follow it.  Updates in between keep the gains they had without it: Larsen's method
    proper lowers the covariance already at the measurement's sample, which needs to know then that
    a measurement of that sample will come; this one does not, so its estimate lies between
    dropping the measurement and re-running (tested on linear systems), at a fraction of a re-run's
    cost.  Measure it on the filter that uses it.

    Parameters
    ----------
    kf : KalmanFilter
        The filter; its transitions are tracked from now on.
    length : int
        Samples kept (the largest lag plus one).
    """

    def __init__(self, kf: KalmanFilter, length: int):
        self.kf = kf
        self._samples: deque = deque(maxlen=length)
        kf.A = kf._eye.copy()

    def __len__(self) -> int:
        return len(self._samples)

    def push(self) -> None:
        """Store the filter's state at the end of a sample (after its updates)."""
        kf = self.kf
        self._samples.append((kf.x.copy(), kf.P.copy(), kf.A))
        kf.A = kf._eye.copy()

    def clear(self) -> None:
        """Forget the stored samples (after the state was reset by other means)."""
        self._samples.clear()
        self.kf.A = self.kf._eye.copy()

    def _index(self, lag: int) -> int:
        n = len(self._samples)
        return n - 1 - lag if 0 <= lag < n else n - 1      # beyond the history: applied to the newest

    def past(self, lag: int) -> tuple[np.ndarray, np.ndarray]:
        """Mean and covariance ``lag`` samples ago (the newest sample's beyond the history; the filter's own
        before any)."""
        if not self._samples:
            return self.kf.x, self.kf.P
        x, P, _ = self._samples[self._index(lag)]
        return x, P

    def update(self, lag: int, innovation, H, R) -> float:
        """Apply a measurement taken ``lag`` samples ago, with innovation ``z - h(x_s)`` and Jacobian ``H`` at
        that sample's mean (:meth:`past`) and noise ``R``; the filter is set to the corrected newest sample,
        which must be its current state (no step since the last :meth:`push`).

        Returns
        -------
        float
            Normalised innovation squared.
        """
        y = np.asarray(innovation, dtype=float)
        samples = self._samples
        if not samples:
            self.push()
        s = self._index(lag)
        x, P, _ = samples[s]
        G = P.dot(H.T)                                     # P_s H^T
        S = H.dot(G) + R
        Si = np.linalg.inv(S)
        MG = G                                              # M_j P_s H^T, M_s = I
        for j in range(s, len(samples)):
            x, P, A = samples[j]
            if j > s:
                MG = A.dot(MG)                              # M_j = A_j M_(j-1)
            W = MG.dot(Si)
            samples[j] = (x + W.dot(y), P - W.dot(MG.T), A)
        kf = self.kf
        P = samples[-1][1]
        kf.x, kf.P = samples[-1][0].copy(), 0.5 * (P + P.T)
        return float(y.dot(Si).dot(y))


class InnovationMonitor:
    """Normalised innovation squared (NIS) of a filter over a sliding window: does its covariance
    explain its innovations?

    For a consistent filter the NIS of an ``m``-dimensional innovation averages ``m``; :attr:`ratio`
    is the window's sum of NIS over its sum of ``m``.  A ratio well above 1 says the filter's
    covariance is too small for what it sees (model error, a sensor offset): estimators
    scale their reported standard deviation by ``sqrt(ratio)`` (:meth:`inflation`) and call the
    estimate not valid above ``limit``.

    Parameters
    ----------
    window : int
        Number of updates in the window.
    limit : float
        Ratio above which the filter is judged inconsistent.
    """

    __slots__ = ("_nis", "_dof", "_i", "_sum_nis", "_sum_dof", "limit", "count")

    def __init__(self, window: int, limit: float = 10.0):
        self._nis = [0.0] * window
        self._dof = [0.0] * window
        self._i = 0
        self._sum_nis = self._sum_dof = 0.0
        self.limit = limit
        self.count = 0

    def add(self, nis: float, dof: int = 1) -> None:
        """Record one update's NIS (capped at 1e6 so one outlier cannot poison the window)."""
        nis = nis if nis < 1e6 else 1e6
        i = self._i
        self._sum_nis += nis - self._nis[i]
        self._sum_dof += dof - self._dof[i]
        self._nis[i], self._dof[i] = nis, float(dof)
        self._i = (i + 1) % len(self._nis)
        self.count += 1

    @property
    def ratio(self) -> float:
        """Sum of NIS over the sum of degrees of freedom in the window (1 for a consistent filter)."""
        return self._sum_nis / self._sum_dof if self._sum_dof > 0.0 else 1.0

    def inflation(self) -> float:
        """Factor for the reported standard deviation, ``sqrt(max(1, ratio))``."""
        r = self.ratio
        return math.sqrt(r) if r > 1.0 else 1.0

    @property
    def consistent(self) -> bool:
        """False once a full window's ratio exceeds :attr:`limit`."""
        return self.count < len(self._nis) or self.ratio <= self.limit
