"""Exact simulation time for models stepped with a (mostly) constant step."""
from __future__ import annotations

__all__ = ["StepClock"]


class StepClock:
    """Time after ``n`` steps of size ``h`` computed as ``t_base + n h``, not by summation.

    Summing 0.001 a thousand times gives 0.9999999999999062; sample times, outage windows
    and schedules compared against such a time would be off by one step.  A change of step
    size starts a new base; a step that differs from the current one by rounding only (a
    host that computes each step as the difference of two communication points, such as
    OMSimulator) is the same step.
    """

    RELATIVE_ROUNDING = 1e-9
    """Relative difference of two step sizes below which they are the same step."""

    __slots__ = ("t", "_base", "_n", "_h")

    def __init__(self, t0: float = 0.0):
        self.t, self._base, self._n, self._h = t0, t0, 0, None

    def tick(self, h: float) -> float:
        """Advance by ``h`` [s] and return the new time [s]."""
        if self._h is None or abs(h - self._h) > self.RELATIVE_ROUNDING * self._h:
            self._base, self._n, self._h = self.t, 0, h
        self._n += 1
        self.t = self._base + self._n * self._h
        return self.t
