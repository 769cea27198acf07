"""GPS latency: find the delay of the GPS fixes against the vehicle's own, undelayed sensors.

A GPS receiver's velocity (and course) describe the car some 0.1-0.5 s ago.  Both identifiers fit
``target(t) = signal(t - D)`` by least squares (with a free scale or offset) for every candidate
delay ``D`` on a grid of the sample period and pick the delay with the smallest residual:

* :class:`DelayIdentifier` - the GPS speed against the undriven-wheel speed, during straight
  accelerations (Yoon & Peng 2014; the free scale absorbs a rolling-radius error);
* :class:`CourseDelay` - the change of the GPS course over a window against the change of the
  gyro-integrated heading plus the estimated sideslip over the same window, while the yaw rate
  changes: it works at constant speed, where the speed has nothing to show.

:class:`DelayLine` keeps a filter's predicted measurement of the last samples so that a delayed fix
is compared with the prediction of its own time, and :class:`GpsLatency` is the delay a hardened
filter uses: a prior until the delay is identified, with the uncertainty that remains
(:class:`GpsLatencyConfig` its parameters).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from ..params import param
from .profiles import HARDENED_PREFIX

__all__ = ["DelayIdentifier", "CourseDelay", "DelayLine", "GpsLatency", "GpsLatencyConfig", "HardenedGpsLatencyConfig",
           "IDENTIFIED_STD"]

IDENTIFIED_STD = 0.025
"""[s] uncertainty of a delay identified by :class:`CourseDelay`: the RMS error of the identified delays
over the benchmark's training drives (``sensors+mismatch``, three seeds, 0.1 s true: 0.026 s; one
J-turn or the entry into a circle leaves it 0.03-0.06 s off)."""


def _refined_minimum(resid: np.ndarray, j: int) -> float:
    """The minimum of a sampled curve near its smallest sample ``j``, in samples (a parabola through
    ``j - 1, j, j + 1``)."""
    if 0 < j < len(resid) - 1:
        a, b, c = resid[j - 1], resid[j], resid[j + 1]
        den = a - 2.0 * b + c
        if den > 0:
            return j + 0.5 * (a - c) / den
    return float(j)


class DelayIdentifier:
    """GPS delay from straight accelerations: ``v_gps(t) = k v_wheel(t - D)``, least squares in ``k`` per
    candidate ``D`` on a grid of the sample period, accumulated over all qualifying fixes.

    Parameters
    ----------
    ts : float
        Sample period of the wheel-speed history [s].
    max_delay : float
        Largest candidate delay [s].
    """

    def __init__(self, ts: float, max_delay: float):
        self.ts = ts
        self.n = int(round(max_delay / ts)) + 1
        self.history: deque = deque(maxlen=self.n + 1)       # wheel speed per sample, newest last
        self.sxx = np.zeros(self.n)
        self.sxy = np.zeros(self.n)
        self.syy = 0.0
        self.fixes = 0
        self.v_lo = self.v_hi = None

    def push(self, v_wheel: float) -> None:
        """Record the wheel speed of the current sample."""
        self.history.append(v_wheel)

    def add_fix(self, v_gps: float) -> None:
        """Accumulate one GPS speed taken during straight acceleration."""
        if len(self.history) < self.n:
            return
        past = np.array(self.history)[::-1][:self.n]          # v_wheel(t - j ts), j = 0..n-1
        self.sxx += past * past
        self.sxy += past * v_gps
        self.syy += v_gps * v_gps
        self.fixes += 1
        self.v_lo = v_gps if self.v_lo is None else min(self.v_lo, v_gps)
        self.v_hi = v_gps if self.v_hi is None else max(self.v_hi, v_gps)

    def estimate(self, min_fixes: int, min_speed_change: float) -> float | None:
        """Delay [s] with the smallest residual (parabolic refinement), or None if not yet identifiable."""
        if self.fixes < min_fixes or self.v_hi - self.v_lo < min_speed_change:
            return None
        resid = self.syy - self.sxy ** 2 / np.maximum(self.sxx, 1e-12)
        return _refined_minimum(resid, int(np.argmin(resid))) * self.ts


class CourseDelay:
    """GPS delay from turning: ``Delta course(t) = Delta (heading + sideslip)(t - D) + c`` over a ``window``.

    The gyro's yaw rate is integrated to a heading every sample and the filter's sideslip estimate
    added (the course is the heading plus the sideslip: without it a slalom's or a J-turn's sideslip,
    which leads or lags the heading, reads as a delay 0.05-0.07 s off); at each fix the course change
    since the fix about ``window`` seconds earlier is the target and the predicted course's change
    over the same span ``D`` earlier the signal.  Unlike :class:`DelayIdentifier` the scale is one (course and heading
    turn together: a free scale would trade the delay of a ramp in yaw rate for a scale) and a free
    offset ``c`` takes the part of a gyro offset not yet removed; the least-squares residual is
    accumulated per candidate ``D`` on a grid of the sample period.  A steady turn adds the same
    residual to every candidate, so only changes of the yaw rate (turning in and out, slaloms) decide.
    Fixes count only while the car turns faster than ``min_rate``, and the delay is reported once
    the residual's minimum is sharp (:meth:`estimate`).

    Parameters
    ----------
    ts : float
        Sample period of the yaw rate [s].
    max_delay : float
        Largest candidate delay [s].
    window : float
        Span of the course and heading changes [s].
    min_rate : float
        Yaw rate below which a fix carries no delay information [rad/s].
    """

    def __init__(self, ts: float, max_delay: float, window: float = 1.0, min_rate: float = 0.05):
        self.ts, self.window, self.min_rate = ts, window, min_rate
        self.n = int(round(max_delay / ts)) + 1
        self._lag = int(round(window / ts))
        self._heading = 0.0
        self._hist: deque = deque(maxlen=self._lag + self.n + 1)    # integrated heading per sample, newest last
        self._fixes: deque = deque()                                # (time, course) of recent fixes
        self._t = 0.0
        self.sx = np.zeros(self.n)
        self.sxx = np.zeros(self.n)
        self.sxy = np.zeros(self.n)
        self.sy = self.syy = 0.0
        self.fixes = 0

    def push(self, yaw_rate: float, sideslip: float = 0.0) -> None:
        """Integrate the (offset-corrected) yaw rate of the current sample [rad/s]; ``sideslip`` is the
        filter's estimate of it [rad]."""
        self._t += self.ts
        self._heading += self.ts * yaw_rate
        self._hist.append(self._heading + sideslip)

    def add_fix(self, course: float, yaw_rate: float) -> None:
        """Use a fix: its course change against the one ``window`` earlier (when turning)."""
        t = self._t
        self._fixes.append((t, course))
        while self._fixes and self._fixes[0][0] < t - self.window - 0.5 * self.ts:
            self._fixes.popleft()
        t0, c0 = self._fixes[0]
        if abs(t - t0 - self.window) > 0.5 * self.ts or abs(yaw_rate) <= self.min_rate:
            return
        if len(self._hist) < self._hist.maxlen:
            return
        h = np.array(self._hist)[::-1]                              # h[j] = heading j samples ago
        x = h[:self.n] - h[self._lag:self._lag + self.n]            # predicted course change, D = j ts ago
        y = math.remainder(course - c0, 2.0 * math.pi)
        self.sx += x
        self.sxx += x * x
        self.sxy += x * y
        self.sy += y
        self.syy += y * y
        self.fixes += 1

    def residual(self) -> np.ndarray:
        """Least-squares residual per candidate delay (offset eliminated) [rad2]."""
        n = max(self.fixes, 1)
        d = self.sy - self.sx
        return self.syy - 2.0 * self.sxy + self.sxx - d * d / n

    def estimate(self, min_fixes: int = 20, sharpness: float = 2.0) -> float | None:
        """The delay [s], once ``min_fixes`` fixes were used and the residual 0.1 s away from the minimum
        is at least ``sharpness`` times the minimum (else None: not identifiable yet)."""
        if self.fixes < min_fixes:
            return None
        resid = self.residual()
        j = int(np.argmin(resid))
        k = max(1, int(round(0.1 / self.ts)))
        side = min(resid[max(j - k, 0)] if j >= k else np.inf, resid[min(j + k, self.n - 1)] if j + k < self.n else np.inf)
        if not side >= sharpness * max(resid[j], 1e-12):
            return None
        return _refined_minimum(resid, j) * self.ts


class DelayLine:
    """The predicted measurement of the last ``depth`` samples, for fixes that arrive late.

    A fix taken ``lag`` samples ago is compared with :meth:`delayed` ``(lag)``.  When a fix corrects
    the filter, :meth:`correct` adds the correction's effect on the predicted measurement to every
    stored sample: otherwise the next fix, compared with the uncorrected past, would apply the same
    correction again (an effective gain above one that makes the filter drift or ring).

    Parameters
    ----------
    depth : int
        Samples kept (the largest lag + 1).
    size : int
        Length of the measurement vector.
    """

    __slots__ = ("_buf", "_i", "_n", "count")

    def __init__(self, depth: int, size: int = 1):
        self._buf = np.zeros((depth, size))
        self._i = 0
        self._n = depth
        self.count = 0

    def push(self, value) -> None:
        """Store the prediction of the current sample."""
        self._buf[self._i] = value
        self._i = (self._i + 1) % self._n
        self.count += 1

    def delayed(self, lag: int) -> np.ndarray:
        """The prediction of ``lag`` samples ago (the oldest one kept if fewer were stored)."""
        lag = min(lag, self._n - 1, max(self.count - 1, 0))
        return self._buf[(self._i - 1 - lag) % self._n]

    def correct(self, delta) -> None:
        """Shift every stored prediction by a filter correction's effect ``delta``."""
        self._buf += delta


class GpsLatency:
    """The GPS delay of a hardened filter and its uncertainty.

    Until :class:`CourseDelay` has identified the delay (it needs changes of the yaw rate: a steady
    circle shows none) the filter uses a prior, ``prior`` +- ``prior_std`` (a receiver's datasheet
    latency; 0.1 +- 0.1 s covers the 0.05-0.2 s of automotive receivers); once identified, the
    identified value +- :data:`IDENTIFIED_STD`.  What remains uncertain enters the filter as
    measurement noise: a fix ``dD`` later than assumed shows the course of ``dD`` earlier, which is
    ``r dD`` off while the car turns at ``r`` (:meth:`course_variance`) - in a steady circle that
    error cannot be told from a sideslip, so it must be in the reported std.

    Parameters
    ----------
    ts : float
        Sample period [s].
    prior, prior_std : float
        Delay used until identified and its uncertainty [s].
    identify : bool
        Identify the delay while turning.
    max_delay : float
        Largest delay identified [s].
    """

    __slots__ = ("value", "std", "_course")

    def __init__(self, ts: float, prior: float, prior_std: float, identify: bool = True, max_delay: float = 0.5):
        self.value, self.std = prior, prior_std
        self._course = CourseDelay(ts, max_delay) if identify else None

    def push(self, yaw_rate: float, sideslip: float) -> None:
        """One sample: the offset-corrected yaw rate [rad/s] and the filter's sideslip [rad]."""
        if self._course is not None:
            self._course.push(yaw_rate, sideslip)

    def add_fix(self, course: float, yaw_rate: float) -> None:
        """A GPS fix's course [rad] (the car faster than the course's noise allows)."""
        if self._course is not None:
            self._course.add_fix(course, yaw_rate)
            d = self._course.estimate()
            if d is not None:
                self.identified(d)

    def identified(self, delay: float) -> None:
        """A delay identified by other means (e.g. :class:`DelayIdentifier`) [s]."""
        self.value, self.std = delay, IDENTIFIED_STD

    def lag(self, ts: float) -> int:
        """The delay in samples of ``ts``."""
        return int(round(self.value / ts))

    def course_variance(self, yaw_rate: float) -> float:
        """Variance of a course from the delay's uncertainty at the yaw rate ``yaw_rate`` [rad2]."""
        e = yaw_rate * self.std
        return e * e


def _latency_param(prefix: str = ""):
    return param(0.1, "Time", prefix + "GPS delay used until it is identified (the receiver's latency)", ge=0, le=0.5)


def _latency_std_param(prefix: str = ""):
    return param(0.1, "Time", prefix + "uncertainty of gps_latency (its error enters the course noise as yaw rate x "
                 "delay)", ge=0, le=0.5)


def _identify_param(prefix: str = ""):
    return param(True, "Dimensionless", prefix + "identify the GPS delay while the yaw rate changes")


@dataclass(frozen=True)
class GpsLatencyConfig:
    """The parameters of :class:`GpsLatency`, for the estimators that use GPS."""

    gps_latency: float = _latency_param()
    gps_latency_std: float = _latency_std_param()
    identify_delay: bool = _identify_param()


@dataclass(frozen=True)
class HardenedGpsLatencyConfig(GpsLatencyConfig):
    """:class:`GpsLatencyConfig` of a paper's method, whose hardened profile alone uses it."""

    gps_latency: float = _latency_param(HARDENED_PREFIX)
    gps_latency_std: float = _latency_std_param(HARDENED_PREFIX)
    identify_delay: bool = _identify_param(HARDENED_PREFIX)
