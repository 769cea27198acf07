"""What the yaw-moment controllers share: configuration, speed schedule, bumpless transfer, limits.

A controller (:class:`YawMomentController`) computes an unsaturated yaw moment from the
steering, the speed, the sideslip and the yaw rate, in its :meth:`~YawMomentController._law`;
this module turns it into the command the motors get:

* the **schedule speed** follows ``vx_hat`` at most at :data:`SCHEDULE_ACCEL` (15 m/s2, more than a
  car brakes), so that a jumping speed estimate (an estimator coming up at 18 m/s) sweeps the
  speed-scheduled gains instead of stepping them;
* the command **fades in** with the schedule speed, a smoothstep from 0 at ``v_min`` to 1 at
  ``v_min + v_fade``: below it the linear model's references are far from what a car in a tight
  low-speed turn does, and the large sideslip gain there turns the difference into a moment
  against the driver's turn;
* **bumpless transfer**: ``dyc_enable`` fades the whole command and ``beta_valid`` (the estimator's
  ``valid``) the sideslip feedback in or out over ``t_transfer``; at start both fade in;
* **steering-offset learning**: in near-straight driving (``|yaw rate| < 1 deg/s``, the steering
  within 0.02 rad of its offset) the offset of ``delta_m`` is learnt as the mean, over
  ``t_steer_offset``, of the steering minus the steering the model needs for the measured yaw rate
  (``gamma / (r/delta)_ss``), and the references get the steering less it (within
  :data:`STEER_OFFSET_MAX`).  A 2 mrad offset would otherwise ask for a standing yaw rate: on the
  Sonata at 20 m/s a standing moment of about 70 N m.  It also takes out what a crowned road asks
  of the driver to go straight.  The feed-forward has zero static gain and does not need it;
* the command is **rate-limited** at ``Mz_rate_max``, then **saturated** at what the in-wheel motors
  can give, ``motor_T_max t / R_w`` (the plant's motors apply ``+-dT`` on the two wheels of their
  axle, each limited to ``motor_T_max``).

* **friction** (``friction_source = 1``): the reference's friction limit, the bicycle model whose
  steady state it follows (the nominal cornering stiffness on that friction) and the law's friction-
  dependent design (the LQR's gain schedule, the ESC's sideslip bound) follow the input ``mu_hat``, an
  estimator's friction estimate (SideslipFusion's), within ``[mu_floor, mu]`` and rounded to
  :data:`FRICTION_STEPS`; each grid value's design is made once, when first used.  The lagged references are
  held within the friction limit too (:mod:`~sideslip.control.reference`), so that a falling estimate lowers
  them at once rather than through the reference's lag.  ``mu_hat`` not above 0 (left unconnected) is no
  estimate: the parameter ``mu`` holds, as it does with ``friction_source = 0`` (the default), so a controller
  without a friction estimate designs for ``mu`` alone.

* **trust in the sideslip estimate** (``beta_std_ref > 0``): the sideslip feedback is weighted also by
  ``s^2 / (s^2 + beta_std^2)`` with ``s = beta_std_ref``, the input ``beta_std`` being the estimator's
  own 1-sigma (its ``beta_hat_std``): an estimate as uncertain as ``s`` gets half the feedback, a sure
  one all of it.  Off by default (and ``beta_std`` left unconnected reads 0: full weight).  With
  ``valid_gate = 0`` the estimator's ``valid`` is ignored and this weight is the only one: an estimator may
  declare itself invalid for reasons its sideslip does not share (SideslipFusion does while the wheels lock in a
  braked slide - its speed from the wheels falls below ``v_min`` - while its sideslip, held by GNSS, stays
  accurate).

* **yaw-rate dead band** (``deadband``): the law sees the yaw-rate error less ``deadband`` (zero inside it), so
  that the controller stays out of normal driving and out of the gyro's noise on a straight road
  (:func:`dead_zone`); 0 (the LQR's default) passes the error as it is;
* **sideslip limiter** (``k_beta > 0``): beyond ``|beta_hat| > beta_limit`` a moment
  ``K_beta (|beta_hat| - beta_limit) sign(beta_hat)``, ``K_beta = k_beta I_zz``, weighted like the sideslip
  feedback (a car sliding out of a left turn has ``beta < 0`` and needs a negative moment).  ``beta_limit = 0``
  takes ``atan(0.02 mu g)`` on the design's friction (11 deg on dry asphalt, 3.4 deg on snow), a sideslip bound
  common in the DYC literature (:func:`sideslip_limit`), times ``beta_limit_scale`` (1: the literature's bound);
  above the friction ``beta_limit_mu_max`` the bound stops growing (at 2, the ESC's default, it grows on every road):
  the literature's bound grows in proportion to the friction, and a tuning that holds a car on mu 0.5 with it lets it
  slide 1.6 times as far on a dry road before the limiter acts.
  The baseline ESC's second part; the LQR adds it to its feedback when switched on.  With ``t_beta_lead > 0`` it
  acts on the sideslip ahead, ``beta_hat + t_beta_lead d(beta_hat)/dt`` (:meth:`YawMomentController._limiter`), the
  beta-beta_dot phase plane's measure of stability (Inagaki, Kushiro and Yamamoto 1995, "Analysis on vehicle
  stability in critical cornering using phase-plane method"): a sideslip that grows fast meets the limiter before
  it is large, one that returns fast is released before the limiter's moment throws the car's yaw past the turn
  (with the bound on sideslip alone, a stiff limiter does: the car yaws out of the turn and the yaw-rate feedback
  then pushes it back into a spin).  ``d(beta_hat)/dt`` is the difference of the estimate and its first-order
  low-pass at :data:`BETA_RATE_TAU` over that time constant, a rate band-limited against an estimate that
  changes in steps;
* **yaw-rate integral** (:meth:`YawMomentController._integrate`): the integral of the yaw-rate error beyond the
  dead band, with conditional integration (it does not grow while the command is saturated in the direction of
  the error) and bleeding off once the error is back inside the dead band (ESC releases when the car is back on
  its line).  The baseline ESC's PI; the LQR adds it to its feedback when switched on.

A controller may switch these off (``shaped = False``, the LQR's published profile): then the
speed is used as it comes, the command is on above ``v_min`` and off below, ``beta_valid`` and
``beta_std`` are ignored, no offset is learnt and only the saturation remains.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..bicycle import BicycleModel
from ..constants import GRAVITY
from ..model import SampledModel
from ..params import ParameterError, check, param
from ..signals import CONTROLLER_EXTRA_INPUTS, CONTROLLER_INPUTS
from ..vehicles import VehicleConfig, VehicleParams
from .reference import ReferenceModel

__all__ = ["SCHEDULE_ACCEL", "STRAIGHT_YAW_RATE", "STRAIGHT_STEER", "STEER_OFFSET_MAX", "FRICTION_STEPS",
           "BETA_RATE_TAU",
           "YawMomentConfig", "yaw_moment_limit", "sideslip_limit", "smoothstep", "dead_zone", "Ramp",
           "YawMomentController"]

SCHEDULE_ACCEL = 15.0
"""[m/s2] fastest change of the schedule speed."""
STRAIGHT_YAW_RATE, STRAIGHT_STEER = math.radians(1.0), 0.02
"""[rad/s], [rad]: driving counts as straight for the steering-offset learning below these."""
STEER_OFFSET_MAX = 0.01
"""[rad] largest steering offset learnt (road-wheel angle; about 10 deg at the handwheel)."""
FRICTION_STEPS = 20
"""Friction grid of ``friction_source = 1``: ``mu_hat`` is rounded to ``k / FRICTION_STEPS`` (0.05)."""
BETA_RATE_TAU = 0.05
"""[s] time constant of the sideslip rate the limiter's lead uses (``t_beta_lead``): shorter than the yaw mode's
(about 0.2 s), longer than an estimator's sample period (10 ms) whose steps it smooths."""


@dataclass(frozen=True)
class YawMomentConfig(VehicleConfig):
    """Parameters every yaw-moment controller has."""

    mu: float = param(1.0, "FrictionCoefficient", "Road friction for the yaw-rate limit of the reference and the "
                      "nominal cornering stiffness", ge=0.05, le=1.5)
    Ts_control: float = param(0.001, "Time", "Sample period of the controller", gt=0, le=0.1)
    tau_beta: float = param(0.15, "Time", "Lag of the sideslip reference (eq 21)", gt=0, le=5)
    tau_gamma: float = param(0.10, "Time", "Lag of the yaw-rate reference (eq 22)", ge=0, le=5)
    yaw_rate_source: int = param(0, "Dimensionless", "Yaw rate fed back: 0 the gyro (yaw_rate_m), 1 the "
                                 "estimate (yaw_rate_hat)", choices=(0, 1))
    Mz_max: float = param(0.0, "Torque", "Yaw-moment limit (0: what the vehicle's in-wheel motors can give)",
                          ge=0, le=2.0e4)
    Mz_rate_max: float = param(4.0e4, "TorqueRate", "Rate limit of the yaw-moment command", gt=0, le=1.0e7)
    v_min: float = param(5.0, "Velocity", "Below this speed the command is zero", gt=0.5, le=30)
    v_fade: float = param(5.0, "Velocity", "Speed range above v_min over which the command fades in", gt=0,
                          le=30)
    t_transfer: float = param(0.3, "Time", "Fade time of dyc_enable and of beta_valid", gt=0, le=10)
    t_steer_offset: float = param(10.0, "Time", "Time constant of the steering-offset learning in straight "
                                  "driving (0: off)", ge=0, le=1000)
    v_max: float = param(70.0, "Velocity", "Top of the speed range of the gain schedule", gt=5, le=150)
    friction_source: int = param(0, "Dimensionless", "Friction the reference and the design follow: 0 the "
                                 "parameter mu, 1 the input mu_hat (an estimator's estimate) within [mu_floor, mu]",
                                 choices=(0, 1))
    mu_floor: float = param(0.2, "FrictionCoefficient", "Lowest friction the input mu_hat is followed down to "
                            "(mu where that is lower)", ge=0.05, le=1.5)
    beta_std_ref: float = param(0.0, "Angle", "Std of the sideslip estimate (input beta_std) at which its "
                                "feedback gets half weight (0: the std is not used)", ge=0, le=0.5)
    valid_gate: int = param(1, "Dimensionless", "1: the input beta_valid fades the sideslip feedback in and out "
                            "(over t_transfer); 0: beta_valid is ignored, the sideslip feedback weighted by beta_std "
                            "alone (beta_std_ref)", choices=(0, 1))
    deadband: float = param(0.0, "AngularVelocity", "Yaw-rate error the controller tolerates (dead band; 0: none)",
                            ge=0, le=1)
    beta_limit: float = param(0.0, "Angle", "Sideslip beyond which the limiter acts (0: beta_limit_scale "
                              "atan(0.02 mu g))", ge=0, le=0.5)
    beta_limit_scale: float = param(1.0, "Dimensionless", "Multiple of atan(0.02 mu g) beyond which the limiter "
                                    "acts when beta_limit is 0", ge=0.2, le=2.0)
    beta_limit_mu_max: float = param(2.0, "FrictionCoefficient", "Friction above which the limiter's bound "
                                     "atan(0.02 mu g) stops growing (2: above every road's, the bound grows with mu "
                                     "throughout)", ge=0.05, le=2.0)
    k_beta: float = param(0.0, "IntegralGain", "Sideslip-limiter gain: K_beta = k_beta I_zz (0: no limiter)", ge=0,
                          le=1.0e4)
    t_beta_lead: float = param(0.0, "Time", "Lead of the sideslip limiter: it acts on beta_hat + t_beta_lead "
                               "d(beta_hat)/dt (the beta-beta_dot phase plane; 0: on beta_hat alone)", ge=0, le=2.0)

    def __post_init__(self):
        check(self)
        if self.v_max <= self.v_min:
            raise ParameterError("v_max", self.v_max, f"> v_min = {self.v_min:g} m/s")


def yaw_moment_limit(vehicle: VehicleParams) -> float:
    """Largest yaw moment the in-wheel motors give, ``motor_T_max t / R_w`` [N m]."""
    track = vehicle.t_f if vehicle.motor_axle == "front" else vehicle.t_r
    return vehicle.motor_T_max * track / vehicle.R_w


def sideslip_limit(mu: float) -> float:
    """``atan(0.02 mu g)`` [rad]: the stable-sideslip bound used when ``beta_limit`` is 0."""
    return math.atan(0.02 * mu * GRAVITY)


def dead_zone(e: float, width: float) -> float:
    """``e`` less ``width`` toward zero, 0 within ``+-width``: a dead band without a step at its edges."""
    return e - width if e > width else (e + width if e < -width else 0.0)


def smoothstep(x: float) -> float:
    """0 below 0, 1 above 1, ``3 x^2 - 2 x^3`` between: a fade with zero slope at both ends."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return x * x * (3.0 - 2.0 * x)


class Ramp:
    """A weight in [0, 1] that moves toward 1 or 0 by ``rate`` per sample: a bumpless switch."""

    def __init__(self, rate: float, value: float = 0.0):
        self.rate, self.value = rate, value

    def step(self, on: bool) -> float:
        """Move toward 1 (``on``) or 0; returns the weight."""
        v = self.value + self.rate if on else self.value - self.rate
        self.value = 1.0 if v > 1.0 else (0.0 if v < 0.0 else v)
        return self.value


class YawMomentController(SampledModel):
    """A yaw-moment law (:meth:`_law`) with the schedule, transfer and limits of the module docstring.

    Parameters
    ----------
    config : YawMomentConfig
    vehicle : VehicleParams, optional
        Overrides ``config.vehicle``.
    """

    input_names = CONTROLLER_INPUTS + CONTROLLER_EXTRA_INPUTS
    shaped: bool = True

    def __init__(self, config: YawMomentConfig, vehicle: VehicleParams | None = None):
        self.config = cfg = config
        self.vehicle = vehicle or cfg.vehicle_params()
        self.model = BicycleModel.from_vehicle(self.vehicle, cfg.mu, nominal=True)
        self.Ts = cfg.Ts_control
        self.Mz_max = cfg.Mz_max if cfg.Mz_max > 0 else yaw_moment_limit(self.vehicle)
        self.reference = ReferenceModel(self.model, cfg.tau_beta, cfg.tau_gamma, self.Ts, cfg.mu,
                                        hold_limit=cfg.friction_source == 1)
        self._dv = SCHEDULE_ACCEL * self.Ts
        self._dmz = cfg.Mz_rate_max * self.Ts
        self._k_offset = self.Ts / cfg.t_steer_offset if cfg.t_steer_offset > 0 else 0.0
        self.K_beta = cfg.k_beta * self.vehicle.I_zz
        self._a_rate = 1.0 - math.exp(-self.Ts / BETA_RATE_TAU)
        self.beta_limit = cfg.beta_limit if cfg.beta_limit > 0 else self._beta_bound(cfg.mu)
        self.mu_design = cfg.mu                    # the friction the reference and the design follow now
        self.follows_friction = cfg.friction_source == 1
        self._designs: dict[float, dict] = {}      # grid friction -> its design (friction_source = 1)

    def _design(self, mu: float) -> dict:
        """What depends on the friction ``mu``: attribute name -> value (the bicycle model on it and, unless
        ``beta_limit`` is given, its sideslip bound; a subclass adds its law's design)."""
        design = {"model": BicycleModel.from_vehicle(self.vehicle, mu, nominal=True)}
        if not self.config.beta_limit > 0:
            design["beta_limit"] = self._beta_bound(mu)
        return design

    def _beta_bound(self, mu: float) -> float:
        """The limiter's bound on friction ``mu`` when ``beta_limit`` is 0 (module docstring) [rad]."""
        cfg = self.config
        return cfg.beta_limit_scale * sideslip_limit(min(mu, cfg.beta_limit_mu_max))

    def _follow_friction(self, mu_hat: float) -> None:
        """Set the reference and the design for the friction estimate ``mu_hat`` (module docstring)."""
        cfg = self.config
        floor = cfg.mu_floor if cfg.mu_floor < cfg.mu else cfg.mu
        if not mu_hat > 0.0 or mu_hat >= cfg.mu:
            mu = cfg.mu
        else:
            mu = round((mu_hat if mu_hat > floor else floor) * FRICTION_STEPS) / FRICTION_STEPS
            mu = floor if mu < floor else (cfg.mu if mu > cfg.mu else mu)
        if mu == self.mu_design:
            return
        design = self._designs.get(mu)
        if design is None:
            design = self._designs[mu] = self._design(mu)
        for name, value in design.items():
            setattr(self, name, value)
        self.reference.model, self.reference.mu = self.model, mu
        self.mu_design = mu

    def reset(self) -> None:
        """Zero command and references; the transfer weights at 0 (fading in); the design at ``mu``."""
        self._reset_clock()
        self._reset_samples()
        self._follow_friction(self.config.mu)
        self.reference.reset()
        rate = self.Ts / self.config.t_transfer
        self.enabled, self.beta_weight = Ramp(rate), Ramp(rate)
        self.v_schedule = math.nan                 # set by the first sample
        self.steer_offset = 0.0
        self.integral = 0.0
        self.beta_lowpass = math.nan               # the sideslip rate's low-pass (t_beta_lead), from the first sample
        self.Mz = 0.0
        self._parts = [0.0, 0.0]
        self._out = (0.0,) * len(self.output_names)

    def _law(self, delta: float, v: float, beta_ref: float, gamma_ref: float, beta_hat: float, yaw_rate: float,
             w_beta: float) -> tuple[float, float]:
        """The two parts of the unsaturated command [N m] (reported as the 4th and 5th outputs) at the
        schedule speed ``v`` (within ``[v_min, v_max]``), the sideslip feedback weighted by ``w_beta``."""
        raise NotImplementedError

    def _sample(self, delta, vx_hat, beta_hat, yaw_rate, beta_valid, enable, mu_hat=0.0, beta_std=0.0) -> float:
        cfg = self.config
        if self.follows_friction:
            self._follow_friction(mu_hat)
        if self.shaped:
            if self.v_schedule != self.v_schedule:             # the first sample
                self.v_schedule = vx_hat
            self.v_schedule += min(max(vx_hat - self.v_schedule, -self._dv), self._dv)
            vs = self.v_schedule
            w = smoothstep((vs - cfg.v_min) / cfg.v_fade) * self.enabled.step(enable)
            w_beta = self.beta_weight.step(beta_valid or not cfg.valid_gate)
            delta = self._learn_steer_offset(delta, vs, yaw_rate)
        else:
            vs = self.v_schedule = vx_hat
            w = 1.0 if enable and vx_hat >= cfg.v_min else 0.0
            w_beta = 1.0
        if self.shaped and cfg.beta_std_ref > 0.0:
            ref2 = cfg.beta_std_ref * cfg.beta_std_ref
            w_beta *= ref2 / (ref2 + beta_std * beta_std)
        v = min(max(vs, cfg.v_min), cfg.v_max)
        beta_ref, gamma_ref = self.reference.step(delta, v)
        a, b = self._law(delta, v, beta_ref, gamma_ref, beta_hat, yaw_rate, w_beta)
        self._parts[0], self._parts[1] = w * a, w * b
        return w * (a + b)

    def _limiter(self, beta_hat: float, w_beta: float) -> float:
        """The sideslip limiter's moment [N m] (module docstring), weighted by ``w_beta``; with ``t_beta_lead`` on the
        sideslip ahead, which advances the rate's low-pass by one sample (called once per sample)."""
        lead = self.config.t_beta_lead
        if lead > 0.0:
            lp = self.beta_lowpass
            if lp != lp:                               # the first sample: no rate yet
                lp = beta_hat
            rate = (beta_hat - lp) / BETA_RATE_TAU     # d(beta_hat)/dt through a first-order low-pass
            self.beta_lowpass = lp + self._a_rate * (beta_hat - lp)
            beta_hat = beta_hat + lead * rate
        over = abs(beta_hat) - self.beta_limit
        # a car sliding out has the sideslip of the opposite sign to its (excess) yaw rate: a moment of
        # the sideslip's sign turns it back
        return w_beta * self.K_beta * math.copysign(over, beta_hat) if over > 0.0 else 0.0

    def _integrate(self, e: float) -> float:
        """Advance the yaw-rate error's integral by one sample of ``e`` (the error beyond the dead band) [rad/s];
        returns it [rad].  Conditional integration: it does not grow while the command is saturated in the direction of
        ``e``, and it bleeds off by ``self._bleed`` per sample once ``e`` is 0 (the car back on its line)."""
        self.integral = self._accumulate(self.integral, e, e != 0.0, self._bleed)
        return self.integral

    def _accumulate(self, value: float, e: float, grow: bool, bleed: float) -> float:
        """An integral ``value`` [rad] of the yaw-rate error advanced by one sample of ``e`` [rad/s]: ``e Ts`` added
        while ``grow`` unless the command is saturated in the direction of ``e`` (conditional integration), times
        ``bleed`` otherwise."""
        if not grow:
            return value * bleed
        lim = self.Mz_max
        if self.Mz >= lim and e > 0.0 or self.Mz <= -lim and e < 0.0:
            return value
        return value + e * self.Ts

    def _learn_steer_offset(self, delta: float, v: float, yaw_rate: float) -> float:
        """Update the steering offset in straight driving (module docstring); the steering less it [rad]."""
        off = self.steer_offset
        if (self._k_offset and v > self.config.v_min and abs(yaw_rate) < STRAIGHT_YAW_RATE
                and abs(delta - off) < STRAIGHT_STEER):
            off += self._k_offset * (delta - yaw_rate / self.model.steady_state_gains(v)[1] - off)
            self.steer_offset = off = min(max(off, -STEER_OFFSET_MAX), STEER_OFFSET_MAX)
        return delta - off

    def _command(self, n: float) -> None:
        """Rate limit (when shaped) and saturation of the command ``n`` [N m]."""
        if self.shaped:
            n = self.Mz + min(max(n - self.Mz, -self._dmz), self._dmz)
        lim = self.Mz_max
        self.Mz = lim if n > lim else (-lim if n < -lim else n)

    def step(self, h: float, delta_m: float, vx_hat: float, beta_hat: float, yaw_rate_m: float,
             yaw_rate_hat: float = 0.0, beta_valid: bool = True, dyc_enable: bool = True,
             mu_hat: float = 0.0, beta_std: float = 0.0) -> None:
        """Advance by ``h`` [s]; runs a sample at every multiple of ``Ts_control``.

        A sample with a non-finite input (among those it uses) asks for a zero command and holds
        the references.
        """
        t = self._tick(h)
        ran = False
        yaw_rate = yaw_rate_hat if self.config.yaw_rate_source else yaw_rate_m
        for _ in range(self._samples_due(t)):
            if math.isfinite(delta_m + vx_hat + beta_hat + yaw_rate):
                n = self._sample(delta_m, vx_hat, beta_hat, yaw_rate, beta_valid, dyc_enable, mu_hat, beta_std)
            else:
                n = self._parts[0] = self._parts[1] = 0.0
            self._command(n)
            ran = True
        if ran:
            self._out = (self.Mz, self.reference.beta, self.reference.gamma, *self._parts)
