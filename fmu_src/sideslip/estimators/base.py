"""What every estimator shares: configuration, sampling, input latching, validity, outputs.

An estimator is stepped at the master's communication step (1 ms) like any model and runs
its filter every ``Ts`` (samples at ``k Ts``, several per step if ``Ts`` is shorter than the
step).  Between samples it keeps the latest inputs; event inputs (``gps_fresh``) are latched
so that a GPS fix arriving between two samples is not missed.  A sample whose inputs are not
finite is skipped (the estimate is held and ``valid`` goes false), so no NaN reaches the
outputs even when the library class is used without the FMU toolkit; inside an FMU, where the
toolkit holds or clamps such inputs (:attr:`~sideslip.model.Model.held_inputs`), the filter runs
on the held values and ``valid`` is false.  A filter that fails
numerically (a singular innovation covariance, a non-finite estimate: a method driven far outside
what it was designed for) is restarted from its initial state with ``valid`` false, and
:attr:`Estimator.restarts` counts it: the host sees a held estimate, never an exception.  So is a
filter whose inputs come back after a fault (held, clamped or not finite): what a burst of
``1e300`` or a jump left in its state would otherwise keep ``valid`` false, or the estimate wrong,
long after the inputs are right again; restarted, it recovers in its start-up time.

What ``valid`` reports on top of an estimator's own flag is gated by :class:`ValidityGate`: not valid
above ``valid_std_max`` of reported std, and only after ``valid_hold`` seconds without a break.

The common outputs of the contract come first, in this order: ``beta_hat``,
``beta_hat_std``, ``vx_hat``, ``vy_hat``, ``yaw_rate_hat``, ``valid``; each estimator appends
its own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ..model import SampledModel
from ..params import check, param
from ..signals import ESTIMATOR_COMMON_OUTPUTS, WHEEL_SPEEDS_M
from ..vehicles import VehicleConfig, VehicleParams
from .kalman import KalmanFilter
from .model_checks import ModelConsistency

__all__ = ["EstimatorConfig", "Estimator", "ValidityGate", "undriven_wheels", "input_enum", "beta_std",
           "valid_std_max_param", "valid_hold_param", "nis_limit_param"]

RESTART_STD = 0.03
"""[rad] ``beta_hat_std`` reported before the first estimate and after a restart, with the estimate at its
prior, zero: the spread of a car's sideslip in driving (the quadratic mean of the RMS sideslip of the
benchmark's training scenarios under ``sensors+mismatch`` is 0.029 rad, 1.7 deg)."""

CONSISTENCY_TOL = math.radians(1.5)
"""[rad] ``consistency_tol``: the band's allowance for sensor offsets, a road bank and the vehicle file's geometry;
chosen on the benchmark's training set as the smallest at which the true sideslip itself stays inside the band
nearly everywhere (a slide with both axles saturated excepted, which the linearity check does not see) while
estimates far off are cleared (the measurements: design history, "Valid from the consistency monitor")."""
CONSISTENCY_INPUTS = ("yaw_rate_m", "delta_m", "ay_m")
"""The inputs the consistency check needs (:class:`~sideslip.estimators.model_checks.ModelConsistency`)."""
CONSISTENCY_PERIOD = 0.01
"""[s] The consistency check's sample period: an estimator sampled faster checks every few samples (the check
follows the car, not the filter; at 1 kHz it would cost a sixth of a filter's step)."""

EVENT_INPUTS = ("gps_fresh",)
"""Inputs that are true for one communication step and must be latched until the next sample."""


def valid_std_max_param(default: float = 0.026, prefix: str = ""):
    """The ``valid_std_max`` parameter (:class:`ValidityGate`); ``prefix`` starts its description."""
    return param(default, "Angle", prefix + "beta_hat_std above which the estimate is not valid", gt=0, le=1.0)


def valid_hold_param(default: float = 1.0, prefix: str = ""):
    """The ``valid_hold`` parameter (:class:`ValidityGate`); ``prefix`` starts its description."""
    return param(default, "Time", prefix + "how long the estimate must have been valid without a break before valid is "
                 "reported (a filter needs time to re-converge)", ge=0, le=60)


def nis_limit_param(default: float = 25.0, prefix: str = ""):
    """The ``nis_limit`` parameter (:class:`~sideslip.estimators.kalman.InnovationMonitor`); ``prefix`` starts its
    description."""
    return param(default, "Dimensionless", prefix + "innovation consistency (NIS per degree of freedom over the "
                 "method's window) above which the estimate is not valid", gt=1, le=1e6)


@dataclass(frozen=True)
class EstimatorConfig(VehicleConfig):
    """Parameters shared by every estimator."""

    Ts: float = param(0.01, "Time", "Sample period of the filter", gt=0, le=1.0)
    v_min: float = param(2.0, "Velocity", "Below this speed the estimate is held and valid is false",
                         gt=0.1, le=20)
    consistency_check: bool = param(True, "Dimensionless", "valid is false while the estimate disagrees with the "
                                    "single-track model where that model holds (ModelConsistency: it judges the "
                                    "estimate and changes none; an estimator without the yaw rate, steering and "
                                    "lateral acceleration inputs has no such check); false: the method's own flag")
    consistency_tol: float = param(CONSISTENCY_TOL, "Angle", "Disagreement with the single-track model's "
                                   "sideslip, beyond the stiffness error and the linearity gap, above which the "
                                   "estimate is not valid (consistency_check)", gt=0, le=1)

    def __post_init__(self):
        check(self)


def input_enum(name: str, names) -> IntEnum:
    """IntEnum of input positions, member names = upper-case signal names."""
    return IntEnum(name, {n.upper(): i for i, n in enumerate(names)})


def undriven_wheels(vehicle: VehicleParams) -> tuple[str, ...]:
    """Wheel-speed inputs of the undriven axle (from the drive split), all four if both axles drive."""
    if vehicle.drive_split_front >= 1.0:
        return WHEEL_SPEEDS_M[2:]
    if vehicle.drive_split_front <= 0.0:
        return WHEEL_SPEEDS_M[:2]
    return WHEEL_SPEEDS_M


def beta_std(vx: float, vy: float, var_vx: float, var_vy: float, cov: float) -> float:
    """1-sigma of ``atan2(vy, vx)`` from the velocity covariance (first-order propagation)."""
    v2 = vx * vx + vy * vy
    if v2 <= 0.0:
        return math.pi
    jx, jy = -vy / v2, vx / v2
    return math.sqrt(max(jx * jx * var_vx + 2 * jx * jy * cov + jy * jy * var_vy, 0.0))


class Estimator(SampledModel):
    """Base of the estimators (see module docstring).

    Subclasses set ``input_names`` and ``extra_outputs``, implement :meth:`_sample` (one
    filter sample with the latched inputs) and :meth:`_extras`, and keep ``beta``,
    ``beta_std``, ``vx``, ``vy``, ``yaw_rate`` and ``valid`` current.
    """

    extra_outputs: tuple = ()
    _gate = None
    """The :class:`ValidityGate` on ``valid`` (None: the method's own flag as it is)."""
    needs: str = ""
    """What the method assumes of its sensors beyond their noise (printed under a run's table)."""
    config_class = EstimatorConfig

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        cls.output_names = ESTIMATOR_COMMON_OUTPUTS + tuple(cls.extra_outputs)

    @classmethod
    def unused_inputs(cls, parameters: dict) -> tuple:
        """Inputs a configuration, given by its parameters (values by name, as an FMU's), never reads: a recorded
        drive may lack them.  None by default."""
        return ()

    def __init__(self, config=None, vehicle: VehicleParams | None = None):
        self.config = cfg = config or self.config_class()
        self.vehicle = vehicle or cfg.vehicle_params()
        self.Ts = cfg.Ts
        self._events = [i for i, n in enumerate(self.input_names) if n in EVENT_INPUTS]
        wheels = undriven_wheels(self.vehicle)
        self._wheel_ix = tuple(self.input_names.index(w) for w in wheels if w in self.input_names)
        self._wheel_gain = self.vehicle.R_w / len(wheels)
        self.reset()

    def reset(self) -> None:
        """Initial state: nothing estimated yet, ``valid`` false."""
        self._reset_clock()
        self._reset_samples()
        self._u = [0.0] * len(self.input_names)
        self._seen = {i: False for i in self._events}   # event seen since the last sample
        self.beta = self.vx = self.vy = self.yaw_rate = 0.0
        self.beta_std = RESTART_STD            # the prior's: before the first estimate nothing is known
        self.valid = False
        self._new_consistency()
        self._init_filter()
        self.restarts = 0
        self._input_fault = False
        self._out = self._pack()

    def _new_consistency(self) -> None:
        cfg, names = self.config, self.input_names
        self._consistency = None
        if cfg.consistency_check and set(CONSISTENCY_INPUTS) <= set(names):
            self._consistency_every = max(1, int(round(CONSISTENCY_PERIOD / self.Ts)))
            self._consistency = ModelConsistency(self.vehicle, self.Ts * self._consistency_every,
                                                 cfg.consistency_tol)
            self._consistency_ix = tuple(names.index(n) for n in CONSISTENCY_INPUTS)
            self._consistency_count = 0

    def _start_over(self, consistency: bool) -> None:
        """The filter (and, with ``consistency``, the consistency check) from its initial state, the speed and yaw
        rate held, ``valid`` false until the method has converged again."""
        held = (self.vx, self.yaw_rate)
        self._init_filter()
        if consistency:
            self._new_consistency()
        self.beta, self.vy, self.beta_std = 0.0, 0.0, RESTART_STD
        self.vx, self.yaw_rate = held
        self.valid = False
        self.restarts += 1

    def _init_filter(self) -> None:
        """Reset the method's own state (override)."""

    def kalman_filters(self) -> list:
        """The Kalman filters the method holds (its attributes that are one; override for filters held otherwise)."""
        return [v for v in vars(self).values() if isinstance(v, KalmanFilter)]

    def speed(self, u) -> float:
        """Speed from the undriven wheels, ``R (w_l + w_r) / 2`` (Park 2018 eq. 1) [m/s]; the mean of
        all four wheels when both axles drive."""
        ix = self._wheel_ix
        total = u[ix[0]] + u[ix[1]]
        if len(ix) == 4:
            total += u[ix[2]] + u[ix[3]]
        return self._wheel_gain * total

    def _sample(self, u: list) -> None:  # pragma: no cover - every estimator overrides it
        """One filter sample of period ``self.Ts`` with the latched inputs ``u``."""
        raise NotImplementedError

    def _extras(self) -> tuple:
        """Values of ``extra_outputs`` (override)."""
        return ()

    def _pack(self) -> tuple:
        out = (self.beta, self.beta_std, self.vx, self.vy, self.yaw_rate, 1.0 if self.valid else 0.0,
               *self._extras())
        return out if self._gate is None else self._gate(self, out)

    def _guarded_sample(self, u: list) -> None:
        """:meth:`_sample`, restarting the filter if it fails numerically or when its inputs come back after a
        fault (module docstring)."""
        if self.held_inputs:
            self._input_fault = True
        elif self._input_fault:                # the inputs are good again: what the fault left in the state goes
            self._input_fault = False
            self._start_over(consistency=True)
        try:
            self._sample(u)
            ok = math.isfinite(self.beta + self.beta_std + self.vx + self.vy + self.yaw_rate + sum(self._extras()))
        except (np.linalg.LinAlgError, ValueError, OverflowError, ZeroDivisionError):
            ok = False
        if ok and self.held_inputs:            # running on held or clamped inputs: not trustworthy
            self.valid = False
        check = self._consistency
        if ok and check is not None and self.vx >= 1.0:
            self._consistency_count += 1
            if self._consistency_count >= self._consistency_every:
                self._consistency_count = 0
                r, delta, ay = self._consistency_ix
                check.update(self.beta, self.vx, u[r], u[delta], u[ay])
            if not check.consistent:
                self.valid = False
        if not ok:
            self._start_over(consistency=False)   # sideslip back to its prior, speed and yaw rate held

    def step(self, h: float, *u) -> None:
        """Advance by ``h`` [s] with the latest inputs ``u`` (``input_names`` order)."""
        t = self._tick(h)
        latched = self._u
        latched[:] = u
        for i in self._events:                 # an event between two samples is not lost
            self._seen[i] = self._seen[i] or bool(u[i])
            latched[i] = 1.0 if self._seen[i] else 0.0
        ran = False
        for _ in range(self._samples_due(t)):
            if math.isfinite(sum(latched)):
                self._guarded_sample(latched)
            else:
                self.valid = False             # hold the estimate on bad inputs
                self._input_fault = True
            ran = True
            for i in self._events:             # an event is used by one sample only
                latched[i] = 0.0
                self._seen[i] = False
        if ran:
            self._out = self._pack()


class ValidityGate:
    """What ``valid`` reports on top of the filter's own flag: an estimate whose reported std exceeds
    ``valid_std_max`` is not valid, and after any break ``valid`` is reported only once the estimate
    has been valid for ``valid_hold`` seconds (a filter that has just left a state it could not model
    needs that long to re-converge).

    Parameters
    ----------
    std_max : float
        Largest reported std of a valid estimate [rad].
    hold : float
        Time without a break before ``valid`` is reported [s].
    """

    __slots__ = ("std_max", "hold", "_since")

    def __init__(self, std_max: float, hold: float):
        self.std_max, self.hold = std_max, hold
        self._since = None

    def __call__(self, est: Estimator, out: tuple) -> tuple:
        """The packed outputs ``out`` of ``est`` with its ``valid`` gated; sets ``est.valid`` false above the
        std limit."""
        if est.beta_std > self.std_max:
            est.valid = False
        if not est.valid:
            self._since = None
            return out[:5] + (0.0,) + out[6:]
        if self._since is None:
            self._since = est.t
        if est.t - self._since < self.hold - 1e-9:
            return out[:5] + (0.0,) + out[6:]           # the filter's own flag stays, the output waits
        return out
