"""The maneuver driver: speed controller, path follower, open-loop steering, road and wind.

Steering: a pure-pursuit path follower (look-ahead ``max(preview_min, preview_time vx)``
on the rear axle geometry, ``delta = atan(2 l sin(a) / L_d)``) tracks the plan's path;
for open-loop maneuvers the handwheel profile takes over at ``t_open`` on top of the
correction held at that instant.  The handwheel rate is limited to ``steer_rate_max``.

Speed: ``a_cmd = dv_ref/dt + kp e + ki int(e)`` with feed-forward of rolling resistance
and drag, ``T = (m a_cmd + F_res) R`` split into drive (``T > 0``) and brake torque,
saturated, integrator frozen while saturated; on paths the target is capped by a curve
speed profile ``sqrt(a_lat_max / |kappa|)`` propagated backwards with the braking limit.
At standstill with zero target the brake holds the car.

The step runs compiled (:mod:`sideslip.plant.kernel`, the same doubles) where this platform's binary is present
and ``compiled`` is 1: the path follower and the speed controller in C, the maneuver's schedules (target speed,
open-loop handwheel, environment) in Python; this module's Python is the reference it is checked against.

The driver also emits the scenario environment: friction ``mu``, bank angle and wind
force/moment as time tables (the plant takes them as inputs); a crowned road (``road_crown``) adds
a crossfall that changes side where the car crosses the crown line, as in a lane change.

Numeric configuration (hosts that cannot set String parameters, e.g. OMSimulator): the Integer
``maneuver_kind`` selects a maneuver (0: the String ``maneuver``; 1..n: :data:`MANEUVER_KINDS`)
whose values are the parameters ``<maneuver>.<field>``; ``constant.road_mu`` and its siblings give
the environment as constants while the String tables keep their defaults.
"""
from __future__ import annotations

import dataclasses
import math
from math import atan, atan2, cos, hypot, sin
from dataclasses import dataclass

import numpy as np

from ..model import Model
from ..params import ParameterError, ParamGroup, check, format_assignments, param
from ..constants import GRAVITY
from ..signals import DRIVER_INPUTS, DRIVER_OUTPUTS
from ..vehicles import VehicleConfig, VehicleParams
from . import kernel
from .maneuvers import MANEUVERS, TimeTable, parse_maneuver

__all__ = ["DriverConfig", "Driver", "ConstantEnvironment", "MANEUVER_KINDS"]

MANEUVER_KINDS: tuple[str, ...] = tuple(MANEUVERS)
"""Maneuvers by the number ``maneuver_kind`` selects (1 is the first)."""

_TABLES = ("road_mu", "road_bank", "wind_force", "wind_moment")


@dataclass(frozen=True)
class ConstantEnvironment:
    """The environment as constants: the numeric parameters ``constant.<field>`` of the driver FMU."""

    road_mu: float = param(1.0, "FrictionCoefficient", "Road friction while the String road_mu is not set",
                           ge=0.05, le=1.5)
    road_bank: float = param(0.0, "Angle", "Road bank angle while the String road_bank is not set",
                             ge=-0.5, le=0.5)
    wind_force: float = param(0.0, "Force", "Lateral wind force while the String wind_force is not set",
                              ge=-1e5, le=1e5)
    wind_moment: float = param(0.0, "Torque", "Wind yaw moment while the String wind_moment is not set",
                               ge=-1e6, le=1e6)


@dataclass(frozen=True)
class DriverConfig(VehicleConfig):
    """Parameters of the driver FMU / :class:`Driver`."""

    maneuver: str = param("straight:v0=20,v=20", "Dimensionless",
                          "Maneuver spec 'name:key=value,...' (see sideslip.plant.maneuvers)")
    road_mu: str = param("1.0", "Dimensionless", "Friction: a number or a time table 't0:v0, t1:v1, ...'")
    road_bank: str = param("0", "Dimensionless", "Bank angle [rad]: a number or a time table")
    wind_force: str = param("0", "Dimensionless", "Lateral wind force [N]: a number or a time table")
    wind_moment: str = param("0", "Dimensionless", "Wind yaw moment [N.m]: a number or a time table")
    road_crown: float = param(0.0, "Angle", "Crossfall of a crowned road, falling to each side of a crown line "
                              "parallel to the start heading (added to the bank; 0: no crown)", ge=0, le=0.1)
    crown_offset: float = param(1.75, "Length", "Crown line to the left of the start position (a lane's half "
                                "width: the car starts in the right lane)", ge=-50, le=50)
    speed_kp: float = param(1.5, "InverseTime", "Speed controller: acceleration per speed error", ge=0, le=50)
    speed_ki: float = param(0.3, "IntegralGain", "Speed controller: integral gain", ge=0, le=50)
    accel_max: float = param(4.0, "Acceleration", "Largest drive acceleration the driver asks for", gt=0, le=20)
    decel_max: float = param(9.0, "Acceleration", "Largest braking deceleration the driver asks for", gt=0, le=20)
    preview_time: float = param(0.6, "Time", "Look-ahead time of the path follower", gt=0.05, le=5)
    preview_min: float = param(6.0, "Length", "Minimum look-ahead distance", gt=0.5, le=100)
    steer_rate_max: float = param(math.radians(1000.0), "AngularVelocity", "Largest handwheel rate",
                                  gt=0, le=100)
    maneuver_kind: int = param(0, "Dimensionless", "Maneuver from numeric parameters: 0 the String 'maneuver'; "
                               + ", ".join(f"{i} {n} ({n}.*)" for i, n in enumerate(MANEUVER_KINDS, 1)),
                               ge=0, le=len(MANEUVER_KINDS))
    compiled: int = param(1, "Dimensionless", "Step computation: 1 compiled C where the FMU carries it for this "
                          "platform (the same doubles, faster), 0 the pure-Python reference", choices=(0, 1))

    def __post_init__(self):
        check(self)
        parse_maneuver(self.maneuver)
        for name in ("road_mu", "road_bank", "wind_force", "wind_moment"):
            TimeTable(getattr(self, name), name)
        if any(not 0.05 <= v <= 1.5 for v in TimeTable(self.road_mu).values()):
            raise ParameterError("road_mu", self.road_mu, "friction values in [0.05, 1.5]")
        if any(abs(v) > 0.5 for v in TimeTable(self.road_bank).values()):
            raise ParameterError("road_bank", self.road_bank, "bank angles in [-0.5, 0.5] rad")

    STRING_STAND_INS = VehicleConfig.STRING_STAND_INS + ("maneuver",) + _TABLES

    @classmethod
    def parameter_groups(cls) -> tuple[ParamGroup, ...]:
        """The vehicle's numeric parameters, ``constant.*`` and ``<maneuver>.*`` of every maneuver."""
        return (*super().parameter_groups(), ParamGroup("constant", ConstantEnvironment),
                *(ParamGroup(name, MANEUVERS[name]) for name in MANEUVER_KINDS))

    def with_parameter_groups(self, values: dict) -> "DriverConfig":
        """This configuration with the numeric parameters applied (see the module docstring).

        Precedence: a String table set away from its default wins over ``constant.*``; ``maneuver_kind``
        0 keeps the String ``maneuver``, 1..n builds the maneuver from its ``<maneuver>.*`` values. Every
        numeric value is checked against its range, used or not (errors name the parameter).
        """
        cfg = super().with_parameter_groups(values)
        constant, *maneuvers = self.parameter_groups()[len(super().parameter_groups()):]
        fields = {f.name: f for f in dataclasses.fields(self)}
        changes = {name: repr(value) for name, value in constant.changed(values).items()
                   if getattr(self, name) == fields[name].default}
        specs = [f"{group.prefix}:{format_assignments(group.values(values))}" for group in maneuvers]
        if self.maneuver_kind:
            changes["maneuver"] = specs[self.maneuver_kind - 1]
        return dataclasses.replace(cfg, **changes) if changes else cfg

    def numeric_parameters(self) -> dict:
        """The numeric parameters that configure this driver without Strings.

        Raises
        ------
        ParameterError
            For a time table (friction, bank or wind that changes in time has no numeric form).
        """
        out = super().numeric_parameters()
        constant, *maneuvers = self.parameter_groups()[len(super().parameter_groups()):]
        for name in _TABLES:
            table = TimeTable(getattr(self, name), name)
            if len(set(table.values())) > 1:
                raise ParameterError(name, getattr(self, name), "a constant for the numeric form (a time table has "
                                     "none: set the String where the host can)")
            out[f"{constant.prefix}.{name}"] = table(0.0)
        maneuver = parse_maneuver(self.maneuver)
        kind = next(i for i, group in enumerate(maneuvers, 1) if type(maneuver) is group.cls)
        return {**out, "maneuver_kind": kind, **maneuvers[kind - 1].numbers(maneuver)}


class Driver(kernel.CompiledStep, Model):
    """Closed-loop driver executing one maneuver.

    Parameters
    ----------
    config : DriverConfig, optional
        Driver parameters.
    vehicle : VehicleParams, optional
        Vehicle (loaded from the config if omitted).
    """

    input_names = DRIVER_INPUTS
    output_names = DRIVER_OUTPUTS

    def __init__(self, config: DriverConfig | None = None, vehicle: VehicleParams | None = None):
        self.config = cfg = config or DriverConfig()
        self.vehicle = vehicle or cfg.vehicle_params()
        self.maneuver = parse_maneuver(cfg.maneuver)
        self.plan = self.maneuver.plan(self.vehicle)
        self._mu = TimeTable(cfg.road_mu, "road_mu")
        self._bank = TimeTable(cfg.road_bank, "road_bank")
        self._fw = TimeTable(cfg.wind_force, "wind_force")
        self._mw = TimeTable(cfg.wind_moment, "wind_moment")
        self._vlim = self._curve_speed_profile()
        path = self.plan.path
        self._crown_line = (float(path.x[0]), float(path.y[0]), math.sin(path.psi[0]), math.cos(path.psi[0]))
        self._constants()
        self.reset()

    def _constants(self) -> None:
        """Per-step constants, each computed as the step's expression would compute it (the same doubles)."""
        cfg, v = self.config, self.vehicle
        tables = (self._mu, self._bank, self._fw, self._mw)
        # the environment when none of its tables changes in time: _pack then skips four table look-ups
        self._env = tuple(table(0.0) for table in tables) if all(len(t.points) == 1 for t in tables) else None
        self._rate = cfg.steer_rate_max / v.steering_ratio          # handwheel rate at the road wheels [rad/s]
        self._two_l = 2.0 * v.l
        plan = self.plan
        # the speed controller's: gains, rolling resistance [N], drag [kg/m], mass, force bounds, radius, times
        self._speed_law = (cfg.speed_kp, cfg.speed_ki, v.m * GRAVITY * v.f_rr, 0.5 * v.rho_air * v.CdA, v.m,
                           v.m * -cfg.decel_max, v.m * cfg.accel_max, v.R_w, plan.brake_only_from, plan.coast_from)
        self._compile()

    def _compile(self) -> None:
        cfg = self.config
        self._native = None
        if cfg.compiled and kernel.available():
            law = dict(zip(("kp", "ki", "roll_force", "drag", "m", "f_lo", "f_hi", "radius", "brake_only_from",
                            "coast_from"), self._speed_law))
            self._native = kernel.DriverKernel(self.plan.path, self._vlim, dict(
                preview_time=cfg.preview_time, preview_min=cfg.preview_min, two_l=self._two_l, rate=self._rate,
                hold_torque=self._hold_torque(), **law)).step

    def _curve_speed_profile(self) -> list | None:
        """Speed limit per path sample from curvature, propagated backwards with decel_max."""
        plan = self.plan
        if not math.isfinite(plan.a_lat_max):
            return None
        kappa = np.abs(plan.path.kappa)
        vlim = np.sqrt(plan.a_lat_max / np.maximum(kappa, 1e-9))
        s = plan.path.s
        a = 0.5 * self.config.decel_max      # plan to brake comfortably, at half the maximum
        n = len(vlim)
        passes = 2 if plan.path.closed else 1
        for _ in range(passes):
            for i in range(n - 2, -1, -1):
                vlim[i] = min(vlim[i], math.sqrt(vlim[i + 1] ** 2 + 2 * a * (s[i + 1] - s[i])))
            if plan.path.closed:
                vlim[-1] = min(vlim[-1], math.sqrt(vlim[0] ** 2 + 2 * a * (plan.path.length - s[-1])))
        return vlim.tolist()

    def __getstate__(self):
        # the plan holds closures and large path arrays: rebuild it from the config instead
        state = self.__dict__.copy()
        for key in ("maneuver", "plan", "_vlim", "_native"):    # (ctypes buffers do not pickle either)
            state.pop(key, None)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self.maneuver = parse_maneuver(self.config.maneuver)
        self.plan = self.maneuver.plan(self.vehicle)
        self._vlim = self._curve_speed_profile()
        self._constants()

    def reset(self) -> None:
        """Initial state at t = 0 with outputs for t = 0."""
        self._reset_clock()
        self._idx = 0
        self._integ = 0.0
        self._delta_hold = None
        self._delta = 0.0
        self._v_prev = self.plan.v_ref(0.0)
        self._crown = self._crown_bank(self._crown_line[0], self._crown_line[1])
        v = self.vehicle
        v0 = self.plan.v_ref(0.0)
        t_ff = (v.m * GRAVITY * v.f_rr + 0.5 * v.rho_air * v.CdA * v0 * v0) * v.R_w if v0 > 0 else 0.0
        steer0 = self.plan.steer_sw(0.0) / v.steering_ratio if (self.plan.steer_sw and self.plan.t_open <= 0) else 0.0
        self._delta = steer0
        self._out = self._pack(0.0, steer0, t_ff, 0.0 if v0 > 0 else self._hold_torque(), v0)

    def _hold_torque(self) -> float:
        v = self.vehicle
        return 0.3 * v.m * GRAVITY * v.R_w

    def _crown_bank(self, px: float, py: float) -> float:
        """Bank of a crowned road at the car's position [rad]: positive (left side up) right of the crown line,
        rounded over 0.5 m either side of it as a car's width straddles the crown."""
        if self.config.road_crown == 0.0:
            return 0.0
        x0, y0, s, c = self._crown_line
        left = -(px - x0) * s + (py - y0) * c - self.config.crown_offset
        return -self.config.road_crown * math.tanh(left / 0.5)

    def _pack(self, t, delta, t_drive, t_brake, v_ref) -> tuple:
        env = self._env
        if env is None:
            env = (self._mu(t), self._bank(t), self._fw(t), self._mw(t))
        return (delta, t_drive, t_brake, env[0], env[1] + self._crown, env[2], env[3],
                delta * self.vehicle.steering_ratio, v_ref)

    def _pure_pursuit(self, vx: float, px: float, py: float, yaw: float) -> float:
        path, cfg = self.plan.path, self.config
        self._idx, station = path.project(px, py, self._idx)
        look = cfg.preview_time * (vx if vx > 0.0 else -vx)
        if look < cfg.preview_min:
            look = cfg.preview_min
        tx, ty = path.point_at(station + look)
        dx, dy = tx - px, ty - py
        c, s = cos(yaw), sin(yaw)
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        return atan(self._two_l * sin(atan2(ly, lx)) / hypot(lx, ly))

    def step(self, h: float, vx: float, X: float, Y: float, yaw: float) -> None:
        """Advance by ``h`` [s] (> 0); arguments are the latest plant truth (``vx``, position, yaw)."""
        t = self._tick(h)
        cfg, plan = self.config, self.plan
        if cfg.road_crown != 0.0:
            self._crown = self._crown_bank(X, Y)

        # ---- steering
        open_loop = plan.steer_sw is not None and t >= plan.t_open
        if open_loop:
            if self._delta_hold is None:
                self._delta_hold = self._delta
            target = self._delta_hold + plan.steer_sw(t) / self.vehicle.steering_ratio
        if self._native is not None:                     # the rest of the step, compiled
            idx, self._delta, self._integ, self._v_prev, t_drive, t_brake, v_ref = self._native(
                h, t, vx, X, Y, yaw, open_loop, target if open_loop else 0.0, plan.v_ref(t), self._idx, self._delta,
                self._integ, self._v_prev)
            self._idx = int(idx)
            self._out = self._pack(t, self._delta, t_drive, t_brake, v_ref)
            return
        if not open_loop:
            target = self._pure_pursuit(vx, X, Y, yaw)
        max_step = self._rate * h
        change = target - self._delta
        change = max_step if change > max_step else (-max_step if change < -max_step else change)
        delta = self._delta + change
        self._delta = delta = 0.7 if delta > 0.7 else (-0.7 if delta < -0.7 else delta)

        # ---- speed
        v_ref = plan.v_ref(t)
        if self._vlim is not None:
            limit = self._vlim[self._idx]
            if limit < v_ref:
                v_ref = limit
        dv_ref = (v_ref - self._v_prev) / h
        self._v_prev = v_ref
        speed = vx if vx >= 0 else -vx
        if v_ref <= 0.05 and speed < 0.3:
            self._integ = 0.0
            self._out = self._pack(t, delta, 0.0, self._hold_torque(), v_ref)
            return
        kp, ki, roll_force, drag, m, f_lo, f_hi, radius, brake_only_from, coast_from = self._speed_law
        err = v_ref - vx
        a_cmd = dv_ref + kp * err + ki * self._integ
        f_res = roll_force * (1.0 if vx >= 0 else -1.0) + drag * vx * speed
        if t >= brake_only_from:
            f_hi = 0.0
        force = m * a_cmd + f_res
        if f_lo < force < f_hi:
            self._integ += err * h                       # no wind-up while saturated
        else:
            force = f_lo if force <= f_lo else f_hi
        torque = force * radius if t < coast_from else 0.0
        # max(torque, 0.0) and max(-torque, 0.0), signed zeros included
        self._out = self._pack(t, delta, 0.0 if 0.0 > torque else torque, 0.0 if 0.0 > -torque else -torque, v_ref)
