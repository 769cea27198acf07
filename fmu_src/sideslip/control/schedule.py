"""Tables scheduled on the longitudinal speed: computed once on a grid, interpolated per step.

The bicycle model changes with ``v_x``, so the LQR gains and the feed-forward filter do too.
Solving a Riccati equation or discretising a transfer function every millisecond would cost
milliseconds; instead both are computed on a geometric speed grid at initialisation (denser
at low speed, where they change fastest) and interpolated linearly, clamped at the ends.
"""
from __future__ import annotations

from bisect import bisect_right

import numpy as np

__all__ = ["SpeedTable", "speed_grid"]


def speed_grid(v_lo: float, v_hi: float, n: int = 40) -> np.ndarray:
    """Geometric grid of ``n`` speeds from ``v_lo`` to ``v_hi`` [m/s]."""
    return np.geomspace(v_lo, v_hi, n)


class SpeedTable:
    """Rows of values on a speed grid, linearly interpolated.

    Parameters
    ----------
    grid : array_like, shape (n,)
        Increasing speeds [m/s].
    rows : array_like, shape (n, m)
        Values at each speed.
    """

    def __init__(self, grid, rows):
        self.grid = [float(v) for v in grid]
        self.rows = [[float(x) for x in r] for r in np.atleast_2d(np.asarray(rows, dtype=float))]
        if len(self.rows) != len(self.grid) or any(b <= a for a, b in zip(self.grid, self.grid[1:])):
            raise ValueError("grid must be increasing with one row per speed")
        self.width = len(self.rows[0])
        self._out = [0.0] * self.width

    def __call__(self, vx: float) -> list:
        """Interpolated row at ``vx`` (clamped to the grid); the returned list is reused."""
        grid, rows, out = self.grid, self.rows, self._out
        if vx <= grid[0]:
            out[:] = rows[0]
        elif vx >= grid[-1]:
            out[:] = rows[-1]
        else:
            i = bisect_right(grid, vx) - 1
            w = (vx - grid[i]) / (grid[i + 1] - grid[i])
            lo, hi = rows[i], rows[i + 1]
            for j in range(self.width):
                out[j] = lo[j] + w * (hi[j] - lo[j])
        return out
