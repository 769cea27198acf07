"""Discretisation of the speed-dependent linear models, cached per speed.

:func:`zoh` is the exact zero-order hold (``scipy.linalg.expm`` of the block matrix
``[[A, B], [0, 0]] T``); :func:`euler` the first-order ``I + A T``, ``B T``.  The bicycle model's
matrices depend on ``v_x`` through ``1/v_x``: at 2 m/s and 10 ms its fastest mode has
``|lambda| T ~ 2``, where any truncated series is wrong, so the hold is exact.  A 6x6 ``expm``
costs ~25 us, more than a filter sample; :class:`SpeedCache` keeps the discrete matrices per
0.01 m/s of speed (a relative model error below 0.5 % at 2 m/s, far below the stiffness error).
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.linalg import expm

__all__ = ["zoh", "euler", "SpeedCache", "lowpass"]


def lowpass(prev: float, value: float, ts: float, cutoff: float) -> float:
    """One step of a first-order low-pass filter (exact discretisation; ``cutoff`` in Hz)."""
    a = math.exp(-2.0 * math.pi * cutoff * ts)
    return a * prev + (1.0 - a) * value


def zoh(A: np.ndarray, B: np.ndarray, ts: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order hold: the blocks of ``expm([[A, B], [0, 0]] ts)``."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A * ts
    M[:n, n:] = B * ts
    E = expm(M)
    return E[:n, :n], E[:n, n:]


def euler(A: np.ndarray, B: np.ndarray, ts: float) -> tuple[np.ndarray, np.ndarray]:
    """First-order approximation ``I + A T``, ``B T``."""
    return np.eye(A.shape[0]) + A * ts, B * ts


class SpeedCache:
    """Discrete ``(F, [F, G])`` of a continuous model ``(A, B) = model(v_x)``, cached per ``resolution``.

    Parameters
    ----------
    model : callable
        ``v_x -> (A, B)`` continuous matrices.
    ts : float
        Sample period [s].
    method : callable
        :func:`zoh` or :func:`euler`.
    n : int, optional
        Keep only the leading ``n`` states (a sub-model, e.g. Nguyen 2012's SRKF).
    resolution : float
        Speed quantum [m/s].
    """

    def __init__(self, model: Callable, ts: float, method: Callable = zoh, n: int | None = None,
                 resolution: float = 0.01, size: int = 2000):
        self._model, self._ts, self._method, self._n = model, ts, method, n
        self._scale = 1.0 / resolution
        self._size = size
        self._store: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def __len__(self) -> int:
        return len(self._store)

    def __call__(self, vx: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F, FG)`` with ``FG = [F, G]``, so that ``FG [x; u] = F x + G u`` in one product."""
        key = round(vx * self._scale)
        mats = self._store.get(key)
        if mats is None:
            if len(self._store) >= self._size:
                self._store.clear()
            A, B = self._model(key / self._scale)
            F, G = self._method(A, B, self._ts)
            n = self._n or F.shape[0]
            mats = self._store[key] = (np.ascontiguousarray(F[:n, :n]), np.hstack((F[:n, :n], G[:n])))
        return mats
