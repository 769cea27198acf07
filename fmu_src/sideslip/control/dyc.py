"""LQR direct-yaw-moment controller (Nguyen 2012 section IV, Fig. 4).

``N_z = sat(N_ff + N_fb)`` with

* the reference model (eqs 21-22, friction-limited): :mod:`sideslip.control.reference`;
* the feed-forward ``G_ff`` of eq 24: :mod:`sideslip.control.feedforward`;
* the LQR feedback ``g_beta (beta* - beta_hat) + g_gamma (gamma* - gamma)`` of eqs 25-26:
  :mod:`sideslip.control.lqr`; the yaw rate ``gamma`` is the gyro's (``yaw_rate_m``) or, with
  ``yaw_rate_source = 1``, the estimator's (``yaw_rate_hat``, offset-corrected: a gyro offset ``b``
  is otherwise a standing moment ``g_gamma b``, 90 N m on the SUV at 18 m/s for 0.6 deg/s).

Additions to the paper, each switched by a parameter and acting in the drivable profile only (the published
profile is eq 25 as printed whatever they are set to); the tuning study searches them.  The drivable profile's
defaults are the tuning study's chosen point (:data:`TUNED`, the parameter file ``examples/lqr_tuned.json`` to three
significant figures); each addition's off value is given with it:

* the weights scheduled on the friction the design is made for:
  ``q_beta (mu / mu_ref)^p_beta`` and ``q_gamma (mu / mu_ref)^p_gamma`` (``q_beta_mu_exponent``,
  ``q_gamma_mu_exponent``; off: 0), ``mu`` being the parameter ``mu`` or, with ``friction_source = 1``, the
  estimate ``mu_hat``: one tuning holds the yaw rate hard on a dry road and softly on snow, where a hard hold brakes
  the rear axle's grip away (docs, "Tuning studies");
* the sideslip feedback on the sideslip beyond its reference only (``beta_feedback = 1``; off: 0): the error
  ``beta* - beta_hat`` is measured from the band between 0 and ``beta*`` and is 0 inside it, so the feedback never
  turns the car *into* a sideslip the model asks for (eq 25 does: while the car's sideslip is still short of the
  reference's, it asks for a moment into the turn, which on snow starts a spin); beyond the band it acts as eq 25;
* the sideslip feedback inside the band, and beyond it only to turn the car back (``beta_feedback = 2``): the
  error is eq 25's for the sideslip held within the band between 0 and ``beta*``; the part from the sideslip beyond
  the band is added only where it is a moment of the sideslip's sign.  Eq 25's sideslip gain ``g_beta`` has either
  sign: a high ``q_beta`` makes it negative (a moment that turns a sliding car back), a low one positive (it then
  mostly cancels the yaw moment the linear tires make from a sideslip, ``(C_r l_r - C_f l_f) beta``); beyond the
  band the tires are no longer linear and a positive ``g_beta`` pushes a sliding car further into its slide;
* sideslip first (``sideslip_priority = 1``; off: 0): while the sideslip is beyond the band
  between 0 and ``beta*`` (and the estimate has more than half its weight), the feedback may only turn the car
  back (a moment of the sideslip's sign), not track a yaw rate into the slide: a car sliding out of a turn on
  snow is otherwise pushed further by the yaw-rate term, which asks for the reference's yaw rate the road cannot
  give;
* the yaw-rate dead band, the sideslip limiter (with its lead on the sideslip's rate, the beta-beta_dot phase
  plane) and the yaw-rate integral of :mod:`sideslip.control.base` (``deadband``, ``k_beta``, ``t_beta_lead``,
  ``k_integral``; off: 0), the limiter's moment and ``g_gamma k_integral int(e) dt`` added to the feedback.  The
  integral tells a yaw rate that persists from a transient one: a linear gain that stops a spin-prone car yawing after a
  sine with dwell also holds back the first half-wave, where the car turns as much as asked, and with it FMVSS 126's
  lateral displacement; the integral grows only while the error lasts;
* the understeer integral (``k_understeer``; off: 0), ``g_gamma k_understeer int(e) dt`` added to the feedback, ``e``
  the yaw-rate error beyond the dead band, grown only while the car understeers: it turns less than the reference in
  the reference's direction (``e gamma* > 0``, ``gamma gamma* > 0``) and its sideslip is not outward of the turn
  (``beta_hat gamma* >= 0``: the rear is not sliding out).  It bleeds off at ``k_understeer`` otherwise, with the
  conditional integration of ``k_integral``'s integral.  Production stability control treats understeer and
  oversteer apart (van Zanten, SAE 2000-01-1633: a moment into the turn for an understeering car, out of it for an
  oversteering one); a car ploughing through a braked turn on snow holds a yaw-rate error that a gain sized for a car
  spinning out leaves standing, and the integral builds the moment into the turn that turns it in.  The sideslip
  condition stops it as soon as the rear slides out, so that it does not turn the car into a spin.

Then saturation at what the in-wheel motors can give (:mod:`sideslip.control.base`).

Two profiles (parameter ``control_profile``):

* ``0``, as published: eq 24 made proper by the first-order low-pass ``tau_ff``; the command is
  switched on above ``v_min``; the sideslip feedback always on; no rate limit; none of the additions (the
  weights as set, unscheduled; eq 25 as printed).  The paper gives no weights and no lags: the control evaluation's
  published row sets its own (:data:`~sideslip.studies.control_eval.PUBLISHED_VALUES`).
* ``1``, drivable (the default): the speed schedule, fade-in, bumpless transfer, steering-offset
  learning and rate limit of :mod:`sideslip.control.base`, and no feed-forward unless asked for
  (``feedforward = 1``): then through a second-order low-pass at ``f_ff`` (noise figures in
  :mod:`sideslip.control.feedforward`), fed with the steering clipped at what the road can turn
  (:meth:`~sideslip.control.reference.ReferenceModel.limited_steer`).

Why the drivable profile leaves the feed-forward out: eq 24 makes the *sideslip* follow its
reference (lag ``tau_beta`` = 0.15 s, faster than the car's own sideslip response), at the cost of
the yaw rate, effort and saturation on every training maneuver; band-limited so that steering noise
stays quiet, it acts late (the figures: docs, "Stability control").

The step runs compiled (:mod:`sideslip.plant.kernel`, the same doubles) where this platform's binary is present,
``compiled`` is 1 and the feed-forward is off (the drivable profile's default): the sample clock and the whole law
in C, the choice of the design on ``mu_hat`` (``friction_source = 1``) in Python, made at every step with finite
inputs (the reference makes it at its samples: the samples use the same design); this module's and
:mod:`sideslip.control.base`'s Python is the reference it is checked against.  With the feed-forward the reference
runs.

No wind-up: the controller's states are the reference lags, the feed-forward filter (driven by the steering
alone), the transfer weights, the rate limiter and (``k_integral > 0``, ``k_understeer > 0``) the yaw-rate integrals,
which do not grow while the command is saturated in the error's direction; none is fed by the saturated output, so a
saturated command leaves saturation as soon as the unsaturated one does (at the rate limit in profile 1).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..constants import GRAVITY
from ..params import param, redefault
from ..plant import kernel
from ..plant.clock import StepClock
from ..signals import LQR_OUTPUTS
from ..vehicles import VehicleParams
from .base import (BETA_RATE_TAU, STEER_OFFSET_MAX, STRAIGHT_STEER, STRAIGHT_YAW_RATE, YawMomentConfig,
                   YawMomentController, dead_zone, yaw_moment_limit)
from .feedforward import ScheduledFeedforward, first_order_lowpass, second_order_lowpass
from .lqr import gain_schedule

__all__ = ["PUBLISHED", "DRIVABLE", "TUNED", "LqrDycConfig", "LqrDycController", "yaw_moment_limit"]

PUBLISHED, DRIVABLE = 0, 1
"""Values of the ``control_profile`` parameter."""
TUNED = {"q_beta": 2.29e8, "q_gamma": 7.02e8, "q_beta_mu_exponent": 0.228, "q_gamma_mu_exponent": 0.208,
         "tau_beta": 0.411, "tau_gamma": 0.0772, "Mz_rate_max": 5.55e4, "v_fade": 1.72, "friction_source": 1,
         "mu_floor": 0.116, "deadband": 0.0241, "beta_feedback": 2, "k_beta": 18.2, "beta_limit_scale": 0.632,
         "beta_limit_mu_max": 0.562, "t_beta_lead": 0.192, "k_integral": 0.184, "k_understeer": 8.69, "valid_gate": 0,
         "beta_std_ref": 0.0254}
"""The defaults that differ from :class:`~sideslip.control.base.YawMomentConfig`'s and from the additions' off
values: the tuning study's chosen point (docs, "The shipped parameter file"), ``examples/lqr_tuned.json`` to three
significant figures (the file's ``feedforward`` 0 and ``sideslip_priority`` 0 are what the defaults do; its ``f_ff``
acts only with the feed-forward on)."""


@dataclass(frozen=True)
class LqrDycConfig(YawMomentConfig):
    """Parameters of :class:`LqrDycController` (the paper gives no numbers for any of them)."""

    control_profile: int = param(DRIVABLE, "Dimensionless", "0: as published (feed-forward through tau_ff, on "
                                 "above v_min, no rate limit); 1: drivable (fade-in over v_fade, bumpless transfer, "
                                 "steering-offset learning, rate limit)", choices=(PUBLISHED, DRIVABLE))
    q_beta: float = param(TUNED["q_beta"], "AngleWeight", "Weight of the sideslip error in eq 26", gt=0, le=1e16)
    q_gamma: float = param(TUNED["q_gamma"], "AngularVelocityWeight", "Weight of the yaw-rate error in eq 26", gt=0,
                           le=1e16)
    q_N: float = param(1.0, "TorqueWeight", "Weight of the yaw moment in eq 26", gt=0, le=1e16)
    q_beta_mu_exponent: float = param(TUNED["q_beta_mu_exponent"], "Dimensionless", "Friction schedule of the "
                                      "sideslip weight: q_beta (mu / mu_ref)^p on the design's friction mu (0: the "
                                      "same weight on every road; profile 1)", ge=-4, le=4)
    q_gamma_mu_exponent: float = param(TUNED["q_gamma_mu_exponent"], "Dimensionless", "Friction schedule of the "
                                       "yaw-rate weight: q_gamma (mu / mu_ref)^p on the design's friction mu (0: the "
                                       "same weight on every road; profile 1)", ge=-4, le=4)
    mu_ref: float = param(1.0, "FrictionCoefficient", "Friction at which the weights are q_beta and q_gamma",
                          ge=0.05, le=1.5)
    beta_feedback: int = param(TUNED["beta_feedback"], "Dimensionless", "Sideslip feedback of eq 25: 0 on the "
                               "error to beta_ref (as published), 1 on the sideslip beyond the band between 0 and "
                               "beta_ref only, 2 on the sideslip within the band and beyond it only where it turns the "
                               "car back (profile 1)",
                               choices=(0, 1, 2))
    k_integral: float = param(TUNED["k_integral"], "InverseTime", "Yaw-rate integral added to the feedback, "
                              "g_gamma k_integral int(e) dt, e the yaw-rate error beyond the dead band; it bleeds "
                              "off at the same rate once e is inside it (profile 1); 0: off", ge=0, le=100)
    k_understeer: float = param(TUNED["k_understeer"], "InverseTime", "Understeer integral added to the feedback, "
                                "g_gamma k_understeer int(e) dt, e the yaw-rate error beyond the dead band, grown "
                                "only while the car turns less than the reference in its direction with its sideslip "
                                "not outward of the turn; it bleeds off at the same rate otherwise (profile 1); 0: off",
                                ge=0, le=100)
    sideslip_priority: int = param(0, "Dimensionless", "1: while the sideslip is beyond the band between 0 and "
                                   "beta_ref, the feedback only turns the car back (a moment of the sideslip's sign; "
                                   "profile 1); 0: off", choices=(0, 1))
    feedforward: int = param(2, "Dimensionless", "Feed-forward of eq 24: 0 off, 1 on, 2 as the profile says "
                             "(published: on; drivable: off)", choices=(0, 1, 2))
    tau_ff: float = param(0.02, "Time", "Low-pass that makes the feed-forward of eq 24 proper (profile 0)", gt=0, le=1)
    f_ff: float = param(2.0, "Frequency", "Bandwidth of the feed-forward: second-order Butterworth (profile 1)",
                        ge=0.05, le=50)
    tau_beta: float = redefault(YawMomentConfig, "tau_beta", TUNED["tau_beta"])
    tau_gamma: float = redefault(YawMomentConfig, "tau_gamma", TUNED["tau_gamma"])
    Mz_rate_max: float = redefault(YawMomentConfig, "Mz_rate_max", TUNED["Mz_rate_max"])
    v_fade: float = redefault(YawMomentConfig, "v_fade", TUNED["v_fade"])
    friction_source: int = redefault(YawMomentConfig, "friction_source", TUNED["friction_source"])
    mu_floor: float = redefault(YawMomentConfig, "mu_floor", TUNED["mu_floor"])
    beta_std_ref: float = redefault(YawMomentConfig, "beta_std_ref", TUNED["beta_std_ref"])
    valid_gate: int = redefault(YawMomentConfig, "valid_gate", TUNED["valid_gate"])
    deadband: float = redefault(YawMomentConfig, "deadband", TUNED["deadband"])
    beta_limit_scale: float = redefault(YawMomentConfig, "beta_limit_scale", TUNED["beta_limit_scale"])
    beta_limit_mu_max: float = redefault(YawMomentConfig, "beta_limit_mu_max", TUNED["beta_limit_mu_max"])
    k_beta: float = redefault(YawMomentConfig, "k_beta", TUNED["k_beta"])
    t_beta_lead: float = redefault(YawMomentConfig, "t_beta_lead", TUNED["t_beta_lead"])
    compiled: int = param(1, "Dimensionless", "Step computation: 1 compiled C where the FMU carries it for this "
                          "platform and the feed-forward is off (the same doubles, faster), 0 the pure-Python "
                          "reference", choices=(0, 1))


class LqrDycController(kernel.CompiledStep, YawMomentController):
    """Reference model + feed-forward + scheduled LQR + saturation (see module docstring).

    Parameters
    ----------
    config : LqrDycConfig, optional
    vehicle : VehicleParams, optional
        Overrides ``config.vehicle``.
    """

    config_class = LqrDycConfig
    output_names = LQR_OUTPUTS

    def __init__(self, config: LqrDycConfig | None = None, vehicle: VehicleParams | None = None):
        cfg = config or LqrDycConfig()
        super().__init__(cfg, vehicle)
        self.shaped = cfg.control_profile == DRIVABLE
        if not self.shaped:             # the paper's controller: none of the nonlinear parts, no friction schedule
            self.follows_friction, self.K_beta, self.reference.hold_limit = False, 0.0, False
        self._deadband = cfg.deadband if self.shaped else 0.0
        self._band = cfg.beta_feedback if self.shaped else 0
        self._first = self.shaped and cfg.sideslip_priority == 1
        self._k_integral = cfg.k_integral if self.shaped else 0.0
        self._bleed = math.exp(-self.Ts * self._k_integral)
        self._k_understeer = cfg.k_understeer if self.shaped else 0.0
        self._understeer_bleed = math.exp(-self.Ts * self._k_understeer)
        self.gains = self._gains(self.model, cfg.mu)
        self.use_ff = cfg.feedforward == 1 or (cfg.feedforward == 2 and not self.shaped)
        self.ff = None
        if self.use_ff:                 # designed only when used: python-control's import takes about 2 s
            lowpass = second_order_lowpass(cfg.f_ff) if self.shaped else first_order_lowpass(cfg.tau_ff)
            self.ff = ScheduledFeedforward(self.model, cfg.tau_beta, lowpass, self.Ts, cfg.v_min, cfg.v_max)
        self._compile()
        self.reset()

    def _compile(self) -> None:
        """The compiled step (module docstring), where it runs."""
        cfg = self.config
        self._native = None
        if not (cfg.compiled and not self.use_ff and kernel.available()):
            return
        ref = self.reference
        self._native = kernel.LqrKernel(dict(
            shaped=int(self.shaped), valid_gate=int(bool(cfg.valid_gate)), hold_limit=int(bool(ref.hold_limit)),
            band=self._band, first=int(self._first), clock_rounding=StepClock.RELATIVE_ROUNDING, v_min=cfg.v_min,
            v_fade=cfg.v_fade, v_max=cfg.v_max, dv=self._dv, dmz=self._dmz, Mz_max=self.Mz_max, k_offset=self._k_offset,
            beta_std_ref=cfg.beta_std_ref if self.shaped else 0.0, ramp_rate=self.Ts / cfg.t_transfer,
            a_beta=ref._a_beta, a_gamma=ref._a_gamma, gravity=GRAVITY, deadband=self._deadband,
            k_integral=self._k_integral, bleed=self._bleed, k_understeer=self._k_understeer,
            understeer_bleed=self._understeer_bleed, Ts=self.Ts, K_beta=self.K_beta,
            straight_yaw_rate=STRAIGHT_YAW_RATE, straight_steer=STRAIGHT_STEER, steer_offset_max=STEER_OFFSET_MAX,
            t_beta_lead=cfg.t_beta_lead, a_rate=self._a_rate, beta_rate_tau=BETA_RATE_TAU)).step

    def _design(self, mu: float) -> dict:
        """The bicycle model on friction ``mu`` and its LQR gain schedule (the feed-forward stays at ``mu``)."""
        design = super()._design(mu)
        design["gains"] = self._gains(design["model"], mu)
        return design

    def _gains(self, model, mu: float):
        """The LQR gain schedule of the bicycle model ``model`` on friction ``mu``, the weights scheduled on it (in the
        drivable profile)."""
        cfg = self.config
        scale = mu / cfg.mu_ref
        shaped = cfg.control_profile == DRIVABLE
        q_beta = cfg.q_beta * scale ** cfg.q_beta_mu_exponent if shaped and cfg.q_beta_mu_exponent else cfg.q_beta
        q_gamma = cfg.q_gamma * scale ** cfg.q_gamma_mu_exponent if shaped and cfg.q_gamma_mu_exponent else cfg.q_gamma
        return gain_schedule(model, q_beta, q_gamma, cfg.q_N, cfg.v_min, cfg.v_max)

    def reset(self) -> None:
        """Zero command, references and filter state (see :meth:`YawMomentController.reset`)."""
        super().reset()
        self.understeer_integral = 0.0
        if self.ff is not None:
            self.ff.reset()

    @property
    def Mz_ff(self) -> float:
        """Feed-forward part of the last command, before saturation [N m]."""
        return self._parts[0]

    @property
    def Mz_fb(self) -> float:
        """Feedback part of the last command, before saturation [N m]."""
        return self._parts[1]

    def step(self, h: float, delta_m: float, vx_hat: float, beta_hat: float, yaw_rate_m: float,
             yaw_rate_hat: float = 0.0, beta_valid: bool = True, dyc_enable: bool = True,
             mu_hat: float = 0.0, beta_std: float = 0.0) -> None:
        """:meth:`YawMomentController.step`, with its clock and samples compiled where they run (module
        docstring; the step clock's and the sample count's state go in and out of the kernel)."""
        native = self._native
        if native is None or not h > 0.0:
            return super().step(h, delta_m, vx_hat, beta_hat, yaw_rate_m, yaw_rate_hat, beta_valid, dyc_enable,
                                mu_hat, beta_std)
        yaw_rate = yaw_rate_hat if self.config.yaw_rate_source else yaw_rate_m
        if self.follows_friction and math.isfinite(delta_m + vx_hat + beta_hat + yaw_rate):
            # the design the step's samples use: the reference's, which follows mu_hat at its samples
            self._follow_friction(mu_hat)
        clock, ref, parts = self._clock, self.reference, self._parts
        (clock.t, clock._base, n, clock._h, done, samples, self.v_schedule, self.enabled.value, self.beta_weight.value,
         self.steer_offset, self.integral, mz, ref.beta, ref.gamma, parts[0], parts[1], self.beta_lowpass,
         self.understeer_integral) = native(
            self, h, delta_m, vx_hat, beta_hat, yaw_rate, beta_valid, dyc_enable, beta_std, clock.t, clock._base,
            clock._n, math.nan if clock._h is None else clock._h, self._samples, 0.0, self.v_schedule,
            self.enabled.value, self.beta_weight.value, self.steer_offset, self.integral, self.Mz, ref.beta, ref.gamma,
            parts[0], parts[1], self.beta_lowpass, self.understeer_integral)
        clock._n, self._samples, self.Mz = int(n), int(done), mz
        if samples:
            self._out = (mz, ref.beta, ref.gamma, parts[0], parts[1])
        return None

    def _law(self, delta, v, beta_ref, gamma_ref, beta_hat, yaw_rate, w_beta):
        n_ff = 0.0
        if self.use_ff:
            if self.shaped:             # the feed-forward inverts the linear model up to the road's limit
                delta = self.reference.limited_steer(delta, v)
            n_ff = self.ff.step(delta, v)
        g_beta, g_gamma = self.gains(v)
        e_beta = beta_ref - beta_hat
        if self._band == 1:             # the error from the band [0, beta_ref] (module docstring)
            e_beta = dead_zone(e_beta - 0.5 * beta_ref, 0.5 * abs(beta_ref))
        elif self._band == 2:           # within the band; beyond it only what turns the car back (module docstring)
            lo, hi = (beta_ref, 0.0) if beta_ref < 0.0 else (0.0, beta_ref)
            inside = lo if beta_hat < lo else (hi if beta_hat > hi else beta_hat)
            e_beta = beta_ref - inside
            if g_beta * (inside - beta_hat) * beta_hat > 0.0:
                e_beta += inside - beta_hat
        e_gamma = dead_zone(gamma_ref - yaw_rate, self._deadband)
        n_fb = w_beta * g_beta * e_beta + g_gamma * e_gamma                                          # eq 25
        if self._k_integral:            # the yaw rate a car keeps after the steering returned: its integral
            n_fb += g_gamma * self._k_integral * self._integrate(e_gamma)
        if self._k_understeer:          # a car that turns less than asked, not sliding out: turn it in (docstring)
            self.understeer_integral = self._accumulate(
                self.understeer_integral, e_gamma,
                e_gamma * gamma_ref > 0.0 and yaw_rate * gamma_ref > 0.0 and beta_hat * gamma_ref >= 0.0,
                self._understeer_bleed)
            n_fb += g_gamma * self._k_understeer * self.understeer_integral
        if self.K_beta:
            n_fb += self._limiter(beta_hat, w_beta)
        if self._first and w_beta > 0.5:
            # sliding beyond the reference: no moment into the slide (module docstring)
            if beta_hat < beta_ref and beta_hat < 0.0 and n_fb > 0.0 or beta_hat > beta_ref and beta_hat > 0.0 > n_fb:
                n_fb = 0.0
        return n_ff, n_fb
