"""Sensor models: IMU, wheel speeds, steering angle, single-antenna GPS and magnetometer.

Every sensor samples at its own rate (samples at ``k / rate``, zero-order hold between),
adds a constant bias and white Gaussian noise; the yaw-rate bias may also wander as a random
walk (``yaw_rate_bias_drift``, drawn from a stream of its own so the noise stays the same).
Inputs passed to :meth:`SensorSuite.step` are the plant truth at the *end* of the step (the
master steps the plant before the sensors), so a sensor sample at ``t_k`` sees the truth at
``t_k``.

GPS: fixes at ``k / gps_rate`` (k >= 1) carry the truth velocity of ``t_k - gps_delay``
(linear interpolation in a bounded history, exact when the delay is a multiple of the
step), plus noise; ``gps_fresh`` is true in the step a fix arrives; during an outage
window no fix arrives and ``gps_valid`` is false.  Course is ``atan2(vn, ve)``, counter-
clockwise from east like the yaw angle.

Magnetometer: Earth field of unit norm with inclination/declination, expressed in
vehicle axes through yaw and roll (no pitch in the plant); during disturbance episodes a
constant random vector with norm in ``[mag_dist_min, mag_dist_max]`` is added (Yoon 2014
Table II: 24 episodes with norm in [0.5, 2]; Table III: "[0.05, 1] at 20 %" = norm range
and share of time disturbed).  Episodes are drawn once from the seed, non-overlapping.

Steering sensor faults from ``steer_fault_time`` on: ``stuck`` freezes the output at its
last value, ``offset`` adds ``steer_fault_offset``.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from .. import geomagnetic
from ..geomagnetic import earth_field
from ..model import Model
from ..params import ParameterError, check, param
from ..signals import SENSOR_INPUTS, SENSOR_OUTPUTS

__all__ = ["SensorConfig", "SensorSuite", "SO", "parse_windows"]

SO = IntEnum("SO", {name.upper(): i for i, name in enumerate(SENSOR_OUTPUTS)})
SO.__doc__ = "Positions of the sensor outputs (names of :data:`sideslip.signals.SENSOR_OUTPUTS`, upper case)."
# plain-int copies (indexing a list with an IntEnum member costs several times more; the step writes some every 1 ms)
(_AX_M, _AY_M, _YAW_RATE_M, _ROLL_RATE_M, _DELTA_M, _DELTA_FAULT_ACTIVE, _OMEGA_FL_M, _OMEGA_FR_M, _OMEGA_RL_M,
 _OMEGA_RR_M, _GPS_VE, _GPS_VN, _GPS_SPEED, _GPS_COURSE, _GPS_FRESH, _GPS_VALID, _MAG_X, _MAG_Y, _MAG_Z,
 _MAG_DISTURBANCE_ACTIVE) = (int(SO[name]) for name in (
    "AX_M", "AY_M", "YAW_RATE_M", "ROLL_RATE_M", "DELTA_M", "DELTA_FAULT_ACTIVE", "OMEGA_FL_M", "OMEGA_FR_M",
    "OMEGA_RL_M", "OMEGA_RR_M", "GPS_VE", "GPS_VN", "GPS_SPEED", "GPS_COURSE", "GPS_FRESH", "GPS_VALID", "MAG_X",
    "MAG_Y", "MAG_Z", "MAG_DISTURBANCE_ACTIVE"))

_NOISE_BLOCK = 4096
_EPS_SAMPLE = 1e-6   # tolerance of the sample-time test, in samples


def parse_windows(text: str, name: str = "gps_outages") -> tuple[tuple[float, float], ...]:
    """Parse ``"10-15, 30-32.5"`` into ``((10, 15), (30, 32.5))`` [s].

    Raises
    ------
    ParameterError
        For malformed items or a window with end <= start.
    """
    out = []
    for item in text.replace(";", ",").split(","):
        item = item.strip()
        if not item:
            continue
        try:
            a, b = (float(v) for v in item.split("-", 1))
        except ValueError:
            raise ParameterError(name, item, "comma-separated 'start-end' windows in seconds") from None
        if not (math.isfinite(a) and math.isfinite(b) and 0 <= a < b):
            raise ParameterError(name, item, "windows with 0 <= start < end")
        out.append((a, b))
    return tuple(sorted(out))


@dataclass(frozen=True)
class SensorConfig:
    """Parameters of the sensors FMU / :class:`SensorSuite` (SI units, 1-sigma noise)."""

    seed: int = param(1, "Dimensionless", "Seed of the noise and disturbance generator", ge=0, le=2**31 - 1)
    imu_rate: float = param(100.0, "Frequency", "IMU sample rate", ge=1, le=10000)
    ax_sigma: float = param(0.05, "Acceleration", "Noise of ax_m", ge=0, le=10)
    ay_sigma: float = param(0.05, "Acceleration", "Noise of ay_m", ge=0, le=10)
    ax_bias: float = param(0.0, "Acceleration", "Bias of ax_m", ge=-10, le=10)
    ay_bias: float = param(0.0, "Acceleration", "Bias of ay_m", ge=-10, le=10)
    yaw_rate_sigma: float = param(0.002, "AngularVelocity", "Noise of yaw_rate_m", ge=0, le=1)
    yaw_rate_bias: float = param(0.0, "AngularVelocity", "Bias of yaw_rate_m", ge=-1, le=1)
    roll_rate_sigma: float = param(0.002, "AngularVelocity", "Noise of roll_rate_m", ge=0, le=1)
    roll_rate_bias: float = param(0.0, "AngularVelocity", "Bias of roll_rate_m", ge=-1, le=1)
    wheel_rate: float = param(100.0, "Frequency", "Wheel-speed sample rate", ge=1, le=10000)
    wheel_sigma: float = param(0.05, "AngularVelocity", "Noise of the wheel speeds", ge=0, le=10)
    wheel_radius_error: float = param(0.0, "Dimensionless", "Relative rolling-radius error: omega_m = "
                                      "omega (1 + e), i.e. R_nominal omega_m overstates speed by e",
                                      ge=-0.2, le=0.2)
    steer_rate: float = param(100.0, "Frequency", "Steering-sensor sample rate", ge=1, le=10000)
    steer_sigma: float = param(0.0005, "Angle", "Noise of delta_m (road-wheel angle)", ge=0, le=0.1)
    steer_bias: float = param(0.0, "Angle", "Bias of delta_m (road-wheel angle)", ge=-0.1, le=0.1)
    steer_fault: str = param("none", "Dimensionless", "Steering-sensor fault mode", choices=("none", "stuck", "offset"))
    steer_fault_time: float = param(1e9, "Time", "Time the steering-sensor fault starts (1e9: never)",
                                    ge=0, le=1e9)
    steer_fault_offset: float = param(0.0, "Angle", "Offset added by an 'offset' steering fault", ge=-0.5, le=0.5)
    gps_rate: float = param(10.0, "Frequency", "GPS fix rate", ge=0.1, le=100)
    gps_delay: float = param(0.0, "Time", "GPS latency (a fix shows the velocity of this long ago)", ge=0, le=2)
    gps_vel_sigma: float = param(0.05, "Velocity", "Noise of each GPS velocity component", ge=0, le=5)
    gps_outages: str = param("", "Dimensionless", "GPS outage windows, e.g. '10-15, 30-32' [s]")
    mag_rate: float = param(100.0, "Frequency", "Magnetometer sample rate", ge=1, le=10000)
    mag_sigma: float = param(0.005, "MagneticFluxRatio", "Noise of each magnetometer axis (normalised)", ge=0, le=1)
    mag_inclination: float = param(geomagnetic.INCLINATION, "Angle", "Inclination (dip) of the Earth field, "
                                   "positive pointing down", ge=-math.pi / 2, le=math.pi / 2)
    mag_declination: float = param(geomagnetic.DECLINATION, "Angle",
                                   "Declination: magnetic north east of true north",
                                   ge=-math.pi, le=math.pi)
    mag_dist_count: int = param(0, "Dimensionless", "Number of magnetic disturbance episodes", ge=0, le=1000)
    mag_dist_share: float = param(0.1, "Dimensionless", "Share of the horizon that is disturbed", ge=0, le=1)
    mag_dist_min: float = param(0.5, "MagneticFluxRatio", "Smallest disturbance norm (normalised)", ge=0, le=10)
    mag_dist_max: float = param(2.0, "MagneticFluxRatio", "Largest disturbance norm (normalised)", ge=0, le=10)
    mag_dist_horizon: float = param(30.0, "Time", "Time span over which the episodes are spread", gt=0, le=1e5)
    yaw_rate_bias_drift: float = param(0.0, "AngularVelocity", "Random walk of the yaw-rate bias: 1-sigma of its "
                                       "change over 100 s (0: a constant bias)", ge=0, le=0.1)

    def __post_init__(self):
        check(self)
        parse_windows(self.gps_outages)
        if self.mag_dist_min > self.mag_dist_max:
            raise ParameterError("mag_dist_min", self.mag_dist_min, f"<= mag_dist_max = {self.mag_dist_max:g}")


class _Sampler:
    """Sample clock of one sensor: due when ``floor(t * rate)`` advances."""

    __slots__ = ("rate", "last")

    def __init__(self, rate: float):
        self.rate = rate
        self.last = 0          # samples at k / rate for k >= 1

    def due(self, t: float) -> bool:
        n = math.floor(t * self.rate + _EPS_SAMPLE)
        if n > self.last:
            self.last = n
            return True
        return False

    def not_before(self) -> float:
        """A time before which :meth:`due` is false: ``floor(t rate + eps) > last`` needs ``t >= (last + 1 - eps) /
        rate``, less a relative margin far above the rounding of either side [s]."""
        return (self.last + 1 - _EPS_SAMPLE) / self.rate * (1.0 - 1e-9)


class SensorSuite(Model):
    """All sensors of the vehicle; one :meth:`step` per communication step.

    Parameters
    ----------
    config : SensorConfig, optional
        Sensor parameters (defaults if omitted).
    """

    input_names = SENSOR_INPUTS
    output_names = SENSOR_OUTPUTS

    def __init__(self, config: SensorConfig | None = None):
        self.config = cfg = config or SensorConfig()
        self._outages = parse_windows(cfg.gps_outages)
        self._field = earth_field(cfg.mag_inclination, cfg.mag_declination)
        self._rng = np.random.default_rng(cfg.seed)
        self.episodes = self._draw_episodes()
        self.reset()

    def _draw_episodes(self):
        """Disturbance episodes ``(start, end, (dx, dy, dz))``, non-overlapping, from the seed."""
        cfg = self.config
        n = cfg.mag_dist_count
        if n == 0 or cfg.mag_dist_share == 0.0:
            return ()
        length = cfg.mag_dist_share * cfg.mag_dist_horizon / n
        free = cfg.mag_dist_horizon - n * length
        starts = np.sort(self._rng.uniform(0.0, free, n)) + length * np.arange(n)
        norms = self._rng.uniform(cfg.mag_dist_min, cfg.mag_dist_max, n)
        dirs = self._rng.standard_normal((n, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        return tuple((float(s), float(s + length), tuple((d * k).tolist()))
                     for s, k, d in zip(starts, norms, dirs))

    def reset(self) -> None:
        """Initial state: no samples yet, GPS invalid, noise stream restarted from the seed."""
        cfg = self.config
        self._rng = np.random.default_rng([cfg.seed, 1])   # noise stream, independent of the episodes
        self._walk_rng = np.random.default_rng([cfg.seed, 2])   # bias random walk: leaves the noise stream alone
        self.yaw_rate_bias = cfg.yaw_rate_bias
        self._noise: list = []
        self._noise_i = 0
        self._reset_clock()
        self._imu = _Sampler(cfg.imu_rate)
        self._wheel = _Sampler(cfg.wheel_rate)
        self._steer = _Sampler(cfg.steer_rate)
        self._gps = _Sampler(cfg.gps_rate)
        self._mag = _Sampler(cfg.mag_rate)
        self._samplers = (self._imu, self._wheel, self._steer, self._gps, self._mag)
        self._next_due = 0.0                 # no sensor is due before (most steps take none: no sampler is asked)
        # truth history for the GPS delay: (t, ve, vn), trimmed to the delay window
        self._hist: deque = deque()
        self._gps_seen = False
        self._episode = 0
        self._out = [0.0] * len(SENSOR_OUTPUTS)
        self._out[SO.MAG_X], self._out[SO.MAG_Y], self._out[SO.MAG_Z] = self._field

    def _gauss(self) -> float:
        i = self._noise_i
        if i >= len(self._noise):
            self._noise = self._rng.standard_normal(_NOISE_BLOCK).tolist()
            i = 0
        self._noise_i = i + 1
        return self._noise[i]

    def _draws(self, k: int) -> list:
        """The next ``k`` values of the noise stream, those ``k`` calls of :meth:`_gauss` return (one slice but at
        the end of a block)."""
        i = self._noise_i
        j = i + k
        if j <= len(self._noise):
            self._noise_i = j
            return self._noise[i:j]
        return [self._gauss() for _ in range(k)]

    def _in_outage(self, t: float) -> bool:
        for a, b in self._outages:
            if a <= t < b:
                return True
        return False

    def _delayed_velocity(self, t: float):
        """Truth ``(ve, vn)`` at time ``t`` from the history (None if not yet recorded)."""
        hist = self._hist
        if not hist or t < hist[0][0] - 1e-9:
            return None
        for i in range(len(hist) - 1, -1, -1):
            t1, ve1, vn1 = hist[i]
            if t1 <= t + 1e-9:
                if i == len(hist) - 1 or abs(t1 - t) <= 1e-9:
                    return ve1, vn1
                t2, ve2, vn2 = hist[i + 1]
                w = (t - t1) / (t2 - t1)
                return ve1 + w * (ve2 - ve1), vn1 + w * (vn2 - vn1)
        return None

    def step(self, h: float, ax, ay, yaw_rate, roll_rate, delta_f, omega_fl, omega_fr, omega_rl, omega_rr,
             vx, vy, yaw, roll) -> None:
        """Advance by ``h`` [s] (> 0); the arguments are the plant truth at the end of the step."""
        t = self._tick(h)
        cfg, out, g = self.config, self._out, self._gauss
        c, s = math.cos(yaw), math.sin(yaw)
        hist = self._hist
        hist.append((t, vx * c - vy * s, vx * s + vy * c))
        horizon = t - cfg.gps_delay - 1e-6
        while len(hist) > 2 and hist[1][0] < horizon:
            hist.popleft()

        due = t >= self._next_due
        if due and self._imu.due(t):
            n_ax, n_ay, n_r, n_p = self._draws(4)
            out[_AX_M] = ax + cfg.ax_bias + cfg.ax_sigma * n_ax
            out[_AY_M] = ay + cfg.ay_bias + cfg.ay_sigma * n_ay
            if cfg.yaw_rate_bias_drift > 0.0:      # random walk: variance drift^2 per 100 s
                self.yaw_rate_bias += cfg.yaw_rate_bias_drift * math.sqrt(0.01 / cfg.imu_rate) * \
                    float(self._walk_rng.standard_normal())
            out[_YAW_RATE_M] = yaw_rate + self.yaw_rate_bias + cfg.yaw_rate_sigma * n_r
            out[_ROLL_RATE_M] = roll_rate + cfg.roll_rate_bias + cfg.roll_rate_sigma * n_p
        if due and self._steer.due(t):
            fault = t >= cfg.steer_fault_time and cfg.steer_fault != "none"
            if not (fault and cfg.steer_fault == "stuck"):
                out[_DELTA_M] = delta_f + cfg.steer_bias + cfg.steer_sigma * g() + (
                    cfg.steer_fault_offset if fault else 0.0)
            out[_DELTA_FAULT_ACTIVE] = 1.0 if fault else 0.0    # describes the held sample
        if due and self._wheel.due(t):
            k, sig = 1.0 + cfg.wheel_radius_error, cfg.wheel_sigma
            n_fl, n_fr, n_rl, n_rr = self._draws(4)
            out[_OMEGA_FL_M] = omega_fl * k + sig * n_fl
            out[_OMEGA_FR_M] = omega_fr * k + sig * n_fr
            out[_OMEGA_RL_M] = omega_rl * k + sig * n_rl
            out[_OMEGA_RR_M] = omega_rr * k + sig * n_rr
        out[_GPS_FRESH] = 0.0
        outage = bool(self._outages) and self._in_outage(t)
        if due and self._gps.due(t):
            truth = self._delayed_velocity(t - cfg.gps_delay)
            if truth is not None:
                # drawn during outages too, so that an outage leaves every other noise sample unchanged
                n_e, n_n = self._draws(2)
                ve = truth[0] + cfg.gps_vel_sigma * n_e
                vn = truth[1] + cfg.gps_vel_sigma * n_n
            if truth is not None and not outage:
                out[_GPS_VE], out[_GPS_VN] = ve, vn
                out[_GPS_SPEED] = math.hypot(ve, vn)
                out[_GPS_COURSE] = math.atan2(vn, ve)
                out[_GPS_FRESH] = 1.0
                self._gps_seen = True
        out[_GPS_VALID] = 1.0 if (self._gps_seen and not outage) else 0.0
        if due and self._mag.due(t):
            episode = self._episode_at(t)
            fx, fy, fz = self._field
            bx, by = c * fx + s * fy, -s * fx + c * fy           # yaw (Rz^T)
            cr, sr = math.cos(roll), math.sin(roll)
            mx, my, mz = bx, cr * by + sr * fz, -sr * by + cr * fz   # roll (Rx^T)
            if episode is not None:
                dx, dy, dz = episode[2]
                mx, my, mz = mx + dx, my + dy, mz + dz
            sig = cfg.mag_sigma
            n_x, n_y, n_z = self._draws(3)
            out[_MAG_X] = mx + sig * n_x
            out[_MAG_Y] = my + sig * n_y
            out[_MAG_Z] = mz + sig * n_z
            out[_MAG_DISTURBANCE_ACTIVE] = 1.0 if episode is not None else 0.0  # describes the held sample
        if due:
            self._next_due = min(sampler.not_before() for sampler in self._samplers)

    def _episode_at(self, t: float):
        eps = self.episodes
        i = self._episode
        while i < len(eps) and eps[i][1] <= t:
            i += 1
        self._episode = i
        if i < len(eps) and eps[i][0] <= t:
            return eps[i]
        return None
