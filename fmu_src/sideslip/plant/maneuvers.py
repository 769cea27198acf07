"""Driving maneuvers: typed, validated specifications and the plans the driver executes.

A maneuver is written as a spec string ``"name:key=value,key=value"`` (SI units, angles in
rad, handwheel angles for open-loop steering).  :func:`parse_maneuver` validates it against
the maneuver's declared parameters (same mechanism as every config, so an unknown key or an
out-of-range value is reported with the allowed set).  Each maneuver builds a :class:`Plan`:
a speed schedule, optionally a reference path (path-following maneuvers) and optionally an
open-loop handwheel profile (which takes over from a straight-line path follower at
``t_start``).

Speed schedule (every maneuver): hold ``v0`` until ``t_go``, then change to ``v`` at
``accel`` [m/s2].  Maneuvers that need more (coast, braking) extend it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Callable

from ..params import ParameterError, build, check, param, parse_assignments
from ..constants import GRAVITY
from . import paths as P

__all__ = ["Plan", "TimeTable", "MANEUVERS", "parse_maneuver", "maneuver_names"]



class TimeTable:
    """Piecewise-linear function of time from ``"0.8"`` or ``"0:0.8, 5:0.8, 5.2:0.3"``.

    Held constant before the first and after the last breakpoint.
    """

    def __init__(self, text: str, name: str = "table"):
        text = str(text).strip()
        pts = []
        try:
            if ":" not in text:
                pts = [(0.0, float(text))]
            else:
                for item in text.replace(";", ",").replace(" ", ",").split(","):
                    if item.strip():
                        a, b = item.split(":")
                        pts.append((float(a), float(b)))
        except ValueError:
            raise ParameterError(name, text, "a number or 't0:v0, t1:v1, ...' with increasing times") from None
        if not pts or any(not (math.isfinite(a) and math.isfinite(b)) for a, b in pts) or any(
                b[0] <= a[0] for a, b in zip(pts, pts[1:])):
            raise ParameterError(name, text, "a number or 't0:v0, t1:v1, ...' with increasing times")
        self.points = tuple(pts)
        self._i = 0

    def __call__(self, t: float) -> float:
        pts = self.points
        if t <= pts[0][0]:
            return pts[0][1]
        if t >= pts[-1][0]:
            return pts[-1][1]
        i = self._i if pts[self._i][0] <= t else 0
        while pts[i + 1][0] < t:
            i += 1
        self._i = i
        (t0, v0), (t1, v1) = pts[i], pts[i + 1]
        return v0 + (v1 - v0) * (t - t0) / (t1 - t0)

    def values(self) -> list[float]:
        """Breakpoint values (for range checks)."""
        return [v for _, v in self.points]


@dataclass
class Plan:
    """What the driver executes.

    Attributes
    ----------
    v_ref : callable
        Target speed [m/s] as a function of time.
    path : Path
        Reference line followed before ``t_open`` (and throughout if ``steer_sw`` is None).
    steer_sw : callable or None
        Open-loop handwheel angle [rad] as a function of time, active from ``t_open``.
    t_open : float
        Time the open-loop profile takes over [s].
    coast_from : float
        From this time the driver neither drives nor brakes, unless ``v_ref`` asks to brake.
    brake_only_from : float
        From this time the speed controller may brake but not drive.
    duration : float
        Suggested run length [s].
    a_lat_max : float
        Lateral acceleration the driver accepts on curves [m/s2] (limits speed on paths).
    """

    v_ref: Callable[[float], float]
    path: P.Path
    steer_sw: Callable[[float], float] | None = None
    t_open: float = math.inf
    coast_from: float = math.inf
    brake_only_from: float = math.inf
    duration: float = 30.0
    a_lat_max: float = math.inf


def _ramp_speed(v0: float, v: float, t_go: float, accel: float) -> Callable[[float], float]:
    t_end = t_go + abs(v - v0) / accel
    sign = 1.0 if v >= v0 else -1.0

    def v_ref(t: float) -> float:
        if t <= t_go:
            return v0
        if t >= t_end:
            return v
        return v0 + sign * accel * (t - t_go)
    return v_ref


def _distance(v0: float, v: float, t_go: float, accel: float, t: float) -> float:
    """Distance covered by the speed schedule until time ``t`` [m]."""
    t_ramp = abs(v - v0) / accel
    if t <= t_go:
        return v0 * t
    d = v0 * t_go
    tr = min(t - t_go, t_ramp)
    d += v0 * tr + 0.5 * math.copysign(accel, v - v0) * tr * tr
    if t > t_go + t_ramp:
        d += v * (t - t_go - t_ramp)
    return d


@dataclass(frozen=True)
class _Base:
    """Speed schedule shared by all maneuvers."""

    v0: float = param(20.0, "Velocity", "Initial speed (the plant starts rolling at it)", ge=0, le=70)
    v: float = param(20.0, "Velocity", "Target speed after the ramp", ge=0, le=70)
    t_go: float = param(0.0, "Time", "Time the speed ramp from v0 to v starts", ge=0, le=3600)
    accel: float = param(1.5, "Acceleration", "Acceleration (or deceleration) of the speed ramp", gt=0, le=10)
    duration: float = param(20.0, "Time", "Suggested length of the run", gt=0, le=3600)

    def __post_init__(self):
        check(self)

    def _speed(self):
        return _ramp_speed(self.v0, self.v, self.t_go, self.accel)

    def _straight(self) -> P.Path:
        length = _distance(self.v0, self.v, self.t_go, self.accel, self.duration) + 200.0
        return P.offset_path(length, [], tail=0.0)


@dataclass(frozen=True)
class StraightLine(_Base):
    """Straight driving with the speed schedule (standstill and launch when ``v0 = 0``)."""

    def plan(self, vehicle) -> Plan:
        return Plan(self._speed(), self._straight(), duration=self.duration)


@dataclass(frozen=True)
class SineSteer(_Base):
    """Sinusoidal handwheel input of ``cycles`` periods from ``t_start``."""

    amplitude: float = param(math.radians(50), "Angle", "Handwheel amplitude", ge=0, le=15)
    frequency: float = param(0.5, "Frequency", "Steering frequency", gt=0, le=10)
    cycles: float = param(3.0, "Dimensionless", "Number of periods", gt=0, le=1000)
    t_start: float = param(3.0, "Time", "Start of steering", ge=0, le=3600)

    def plan(self, vehicle) -> Plan:
        a, f, t0, t1 = self.amplitude, self.frequency, self.t_start, self.t_start + self.cycles / self.frequency

        def steer(t):
            return a * math.sin(2.0 * math.pi * f * (t - t0)) if t0 <= t <= t1 else 0.0
        return Plan(self._speed(), self._straight(), steer, t0, duration=self.duration)


@dataclass(frozen=True)
class SteerSweep(_Base):
    """Handwheel sine sweep from ``t_start``: the frequency rises linearly from ``f_start`` to ``f_end`` over
    ``sweep_time`` (a calibration drive's excitation of the yaw dynamics, :mod:`sideslip.studies.identify`)."""

    amplitude: float = param(math.radians(20), "Angle", "Handwheel amplitude", ge=0, le=15)
    f_start: float = param(0.2, "Frequency", "Frequency at the start of the sweep", gt=0, le=10)
    f_end: float = param(2.0, "Frequency", "Frequency at the end of the sweep", gt=0, le=10)
    sweep_time: float = param(40.0, "Time", "Length of the sweep", gt=0, le=3600)
    t_start: float = param(3.0, "Time", "Start of steering", ge=0, le=3600)

    def plan(self, vehicle) -> Plan:
        a, f0, t0, T = self.amplitude, self.f_start, self.t_start, self.sweep_time
        rate = (self.f_end - f0) / T

        def steer(t):
            u = t - t0
            return a * math.sin(2.0 * math.pi * (f0 * u + 0.5 * rate * u * u)) if 0.0 <= u <= T else 0.0
        return Plan(self._speed(), self._straight(), steer, t0, duration=self.duration)


@dataclass(frozen=True)
class StepSteer(_Base):
    """Handwheel ramp to ``amplitude`` at ``rate`` from ``t_start``, then held (step steer)."""

    amplitude: float = param(math.radians(90), "Angle", "Handwheel angle held after the ramp (sign = direction)",
                             ge=-15, le=15)
    rate: float = param(math.radians(500), "AngularVelocity", "Handwheel rate of the ramp", gt=0, le=50)
    t_start: float = param(3.0, "Time", "Start of steering", ge=0, le=3600)
    coast: bool = param(False, "Dimensionless", "Release the throttle at t_start (J-turn)")

    def plan(self, vehicle) -> Plan:
        a, r, t0 = self.amplitude, self.rate, self.t_start
        t_ramp = abs(a) / r

        def steer(t):
            if t < t0:
                return 0.0
            return a if t >= t0 + t_ramp else a * (t - t0) / t_ramp
        return Plan(self._speed(), self._straight(), steer, t0,
                    coast_from=t0 if self.coast else math.inf, duration=self.duration)


@dataclass(frozen=True)
class JTurn(StepSteer):
    """J-turn: step steer with the throttle released at the start of steering."""

    coast: bool = param(True, "Dimensionless", "Release the throttle at t_start")


@dataclass(frozen=True)
class SlowlyIncreasingSteer(_Base):
    """FMVSS 126 slowly increasing steer: handwheel ramp at ``rate`` at constant speed."""

    v0: float = param(80 / 3.6, "Velocity", "Initial speed", ge=0, le=70)
    v: float = param(80 / 3.6, "Velocity", "Speed held", ge=0, le=70)
    rate: float = param(math.radians(13.5), "AngularVelocity", "Handwheel rate", gt=0, le=10)
    direction: float = param(1.0, "Dimensionless", "+1 steer left, -1 steer right", choices=(1.0, -1.0))
    t_start: float = param(2.0, "Time", "Start of the ramp", ge=0, le=3600)
    max_angle: float = param(math.radians(270), "Angle", "Handwheel angle where the ramp stops", gt=0, le=15)

    def plan(self, vehicle) -> Plan:
        r, t0, lim, d = self.rate, self.t_start, self.max_angle, self.direction

        def steer(t):
            return d * min(max(t - t0, 0.0) * r, lim)
        return Plan(self._speed(), self._straight(), steer, t0, duration=self.duration)


@dataclass(frozen=True)
class SineWithDwell(_Base):
    """FMVSS 126 sine with dwell: 0.7 Hz sine, 500 ms dwell at the second peak, coasting.

    The handwheel amplitude is ``factor * A`` where ``A`` is the handwheel angle giving
    0.3 g in the slowly increasing steer test (scenario-specific, see
    :func:`sideslip.scenarios.fmvss126_reference_angle`).
    """

    v0: float = param(80 / 3.6, "Velocity", "Entry speed (80 km/h)", ge=0, le=70)
    v: float = param(80 / 3.6, "Velocity", "Speed held before the maneuver", ge=0, le=70)
    A: float = param(math.radians(20), "Angle", "Handwheel angle for 0.3 g in the SIS test", gt=0, le=10)
    factor: float = param(1.5, "Dimensionless", "Amplitude as a multiple of A", gt=0, le=20)
    frequency: float = param(0.7, "Frequency", "Sine frequency", gt=0, le=5)
    dwell: float = param(0.5, "Time", "Dwell at the second peak", ge=0, le=5)
    direction: float = param(1.0, "Dimensionless", "+1 steer left first, -1 right first", choices=(1.0, -1.0))
    t_start: float = param(3.0, "Time", "Beginning of steer", ge=0, le=3600)
    max_amplitude: float = param(math.radians(270), "Angle", "Cap of the amplitude (FMVSS 126: 270 deg)", gt=0, le=15)

    @property
    def amplitude(self) -> float:
        """Handwheel amplitude [rad]."""
        return min(self.factor * self.A, self.max_amplitude)

    @property
    def completion_of_steer(self) -> float:
        """Time of completion of steer [s] (beginning + 1/f + dwell)."""
        return self.t_start + 1.0 / self.frequency + self.dwell

    def plan(self, vehicle) -> Plan:
        a, w, t0, dw, d = self.amplitude, 2.0 * math.pi * self.frequency, self.t_start, self.dwell, self.direction
        t_peak2 = t0 + 0.75 / self.frequency

        def steer(t):
            if t < t0:
                return 0.0
            if t < t_peak2:
                return d * a * math.sin(w * (t - t0))
            if t < t_peak2 + dw:
                return -d * a
            tau = t - dw
            if tau < t0 + 1.0 / self.frequency:
                return d * a * math.sin(w * (tau - t0))
            return 0.0
        return Plan(self._speed(), self._straight(), steer, t0, coast_from=t0, duration=self.duration)


@dataclass(frozen=True)
class BrakeInTurn(_Base):
    """Brake in a turn (Park 2018 case 5): steer ramp and braking at ``decel`` from ``t_start``.

    The steering returns to zero at ``t_release``; braking continues until ``v_end``.
    """

    amplitude: float = param(math.radians(200), "Angle", "Handwheel angle of the turn", ge=-15, le=15)
    rate: float = param(math.radians(200), "AngularVelocity", "Handwheel rate of the ramps", gt=0, le=50)
    t_start: float = param(5.0, "Time", "Start of braking and steering", ge=0, le=3600)
    t_release: float = param(7.5, "Time", "Time the handwheel is back to zero", ge=0, le=3600)
    decel: float = param(0.2 * GRAVITY, "Acceleration", "Target deceleration", gt=0, le=10)
    v_end: float = param(0.0, "Velocity", "Speed where braking stops", ge=0, le=70)

    def plan(self, vehicle) -> Plan:
        a, r, t0, t2 = self.amplitude, self.rate, self.t_start, self.t_release
        t_up = abs(a) / r
        t_down0 = max(t2 - t_up, t0 + t_up)
        base = self._speed()
        decel, v_end = self.decel, self.v_end

        def steer(t):
            if t < t0:
                return 0.0
            if t < t0 + t_up:
                return a * (t - t0) / t_up
            if t < t_down0:
                return a
            return max(0.0, 1.0 - (t - t_down0) / t_up) * a

        def v_ref(t):
            if t < t0:
                return base(t)
            return max(v_end, base(t0) - decel * (t - t0))
        return Plan(v_ref, self._straight(), steer, t0, brake_only_from=t0, duration=self.duration)


@dataclass(frozen=True)
class _PathManeuver(_Base):
    lead_in: float = param(80.0, "Length", "Straight before the maneuver geometry", ge=0, le=5000)
    a_lat_max: float = param(50.0, "Acceleration", "Lateral acceleration the driver accepts (slows for "
                             "curves above it)", gt=0, le=50)
    tail: float = param(300.0, "Length", "Straight after the maneuver geometry", ge=0, le=5000)

    def _offsets(self):  # pragma: no cover - overridden
        raise NotImplementedError

    def plan(self, vehicle) -> Plan:
        return Plan(self._speed(), P.offset_path(self.lead_in, self._offsets(), self.tail),
                    duration=self.duration, a_lat_max=self.a_lat_max)


@dataclass(frozen=True)
class DoubleLaneChange(_PathManeuver):
    """ISO 3888-1 double lane change (centre line), repeated ``repeat`` times ``gap`` apart."""

    offset: float = param(3.5, "Length", "Lateral offset of the centre line", ge=-10, le=10)
    repeat: int = param(1, "Dimensionless", "Number of double lane changes", ge=1, le=20)
    gap: float = param(60.0, "Length", "Straight between repetitions", ge=0, le=5000)

    def _offsets(self):
        segs = []
        for k in range(self.repeat):
            if k:
                segs.append((self.gap, 0.0))
            segs += P.iso3888_dlc_offsets(self.offset)
        return segs


@dataclass(frozen=True)
class LaneChange(_PathManeuver):
    """Single lane change: raised-cosine offset over ``length``."""

    offset: float = param(3.5, "Length", "Lateral offset", ge=-10, le=10)
    length: float = param(30.0, "Length", "Length of the transition", gt=1, le=1000)

    def _offsets(self):
        return P.lane_change_offsets(self.offset, self.length)


@dataclass(frozen=True)
class Slalom(_PathManeuver):
    """Slalom through ``cones`` cones ``spacing`` apart with lateral amplitude ``amplitude``."""

    spacing: float = param(30.0, "Length", "Cone spacing", gt=1, le=500)
    amplitude: float = param(1.0, "Length", "Lateral amplitude at the cones", gt=0, le=10)
    cones: int = param(6, "Dimensionless", "Number of cones", ge=1, le=100)

    def _offsets(self):
        return P.slalom_offsets(self.spacing, self.amplitude, self.cones)


@dataclass(frozen=True)
class CircleTurn(_Base):
    """Straight lead-in then a constant-radius circle (left for positive ``radius``).

    With ``v > v0`` the speed ramp gives the acceleration in a turn of Park 2018 cases 3-4.
    """

    radius: float = param(25.0, "Length", "Circle radius (negative turns right)", ge=-1000, le=1000)
    lead_in: float = param(40.0, "Length", "Straight before the circle", ge=0, le=5000)

    def __post_init__(self):
        super().__post_init__()
        if abs(self.radius) < 5.0:
            raise ParameterError("radius", self.radius, "|radius| >= 5 m")

    def plan(self, vehicle) -> Plan:
        # three times the scheduled distance, so runs longer than `duration` stay on the circle
        circle = 3.0 * _distance(self.v0, self.v, self.t_go, self.accel, self.duration) + 100.0
        path = P.arc_chain([(self.lead_in, math.inf), (circle, self.radius)], ds=0.25)
        return Plan(self._speed(), path, duration=self.duration)


@dataclass(frozen=True)
class TrackLap(_Base):
    """Laps of the ~3 km closed track with curve-limited speed (Kim 2016 scenario)."""

    a_lat_max: float = param(3.0, "Acceleration", "Lateral acceleration the driver accepts", gt=0, le=20)
    duration: float = param(200.0, "Time", "Suggested length of the run", gt=0, le=3600)

    def plan(self, vehicle) -> Plan:
        return Plan(self._speed(), P.closed_track(), duration=self.duration, a_lat_max=self.a_lat_max)


MANEUVERS: dict[str, type] = {
    "straight": StraightLine,
    "sine_steer": SineSteer,
    "step_steer": StepSteer,
    "j_turn": JTurn,
    "slowly_increasing_steer": SlowlyIncreasingSteer,
    "sine_with_dwell": SineWithDwell,
    "brake_in_turn": BrakeInTurn,
    "double_lane_change": DoubleLaneChange,
    "lane_change": LaneChange,
    "slalom": Slalom,
    "circle": CircleTurn,
    "track": TrackLap,
    "steer_sweep": SteerSweep,
}


def maneuver_names() -> list[str]:
    """Registered maneuver names."""
    return sorted(MANEUVERS)


def parse_maneuver(spec: str):
    """Maneuver object from ``"name:key=value,..."``.

    Raises
    ------
    ParameterError
        Unknown maneuver name (lists the known ones), unknown key or value out of range.
    """
    name, _, rest = spec.strip().partition(":")
    name = name.strip()
    if name not in MANEUVERS:
        raise ParameterError("maneuver", name, "one of " + ", ".join(maneuver_names()))
    return build(MANEUVERS[name], parse_assignments(rest, "maneuver"), prefix=f"maneuver {name}: ")


def maneuver_spec(name: str, **values) -> str:
    """Spec string of maneuver ``name`` with ``values`` (inverse of :func:`parse_maneuver`)."""
    if name not in MANEUVERS:
        raise ParameterError("maneuver", name, "one of " + ", ".join(maneuver_names()))
    known = {f.name for f in fields(MANEUVERS[name])}
    for key in values:
        if key not in known:
            raise ParameterError(f"maneuver {name}: {key}", values[key], "a known name: " + ", ".join(sorted(known)))
    return name + (":" + ",".join(f"{k}={v!r}" if isinstance(v, str) else f"{k}={v:.12g}"
                                  for k, v in values.items()) if values else "")
