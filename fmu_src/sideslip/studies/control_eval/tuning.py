"""What a tuning study of the LQR searches and scores: its parameters, the maneuver sets, the objectives.

The sets are disjoint from the control evaluation's (:data:`~sideslip.studies.control_eval.SCENARIOS`, the FMVSS 126
runs on the SUV at mu 0.8, seeds 0 and 1), which is the study's test set:

* **training** (:data:`TRAINING_SET`, seeds :data:`TRAINING_SEEDS`): what the optimiser sees - FMVSS 126 at mu 0.5
  (the SUV at 2.5A, 5A and 6.5A) and at 6A on mu 0.8 (the Sonata), Pi 2011's sine steer on mu 0.8 at 80 km/h (the
  SUV), the estimator benchmark's training brake in a turn on snow and J-turn on a wet road (Sonata), its sine steer
  on snow and its sine steer while the friction drops from 1.0 to 0.35 and returns (SUV, 22 s), spin-outs braking in
  a turn on snow with the rear brakes saturating (the SUV; the Sonata from 54 km/h), FMVSS 126 at 2A on mu 0.5 on a
  car that spins from there uncontrolled (Sonata), FMVSS 126 on mu 0.8 on a car that understeers and, like the
  test's SUV, needs a controller only at the larger amplitudes (the small car at 2A, 3.5A and 5A), a brake in a turn
  on snow on its own brake balance (the small car ploughs) and a straight drive (SUV, 12 -> 28 m/s);
* **development** (:data:`DEVELOPMENT_SET`, seeds :data:`DEVELOPMENT_SEEDS`): where the Pareto front's points are
  compared with the baseline ESC and one is chosen - FMVSS 126 at mu 0.5 at other amplitudes (the SUV at 3A, 4A
  and 6A), Pi 2011's sine steer on mu 0.5 at 60 km/h, the benchmark's development J-turn on ice (SUV) and friction
  drop (small car), spin-outs braking in a turn on ice (small car) and on snow (the Sonata from 52 km/h, mu 0.32),
  FMVSS 126 at 4A and 6.5A on mu 0.8 (Sonata), FMVSS 126 on mu 0.8 on another such car (the track car at 2.5A, 4A
  and 5.5A), its brake in a turn on snow (it ploughs) and a straight drive (small car, 14 -> 26 m/s).

The objectives (:data:`OBJECTIVES`) are means over the maneuvers.  Six constraints (:func:`constraints`), which
the sampler is told of (Optuna's trial constraints: the samplers and the Pareto front prefer the points within
them) and the choice keeps: the straight drives' ``RMS Mz_cmd <= STRAIGHT_RMS_MAX`` (the sensors' noise through the
command on a straight road); FMVSS 126's responsiveness - the mean lateral displacement 1.07 s after the
beginning of steer of the FMVSS runs at 5A and more no smaller than the baseline ESC's on the same runs less that
mean's standard error (the ESC passes the criterion where the LQR is to; on mu 0.5 no controller reaches its
1.83 m, so the ESC is the bar, measured on a few runs); FMVSS 126's yaw stability - no more of the FMVSS runs
failing it than the ESC fails; FMVSS 126's sideslip - the mean max ``|beta|`` of the FMVSS runs no larger than
the ESC's, and on the FMVSS maneuver where the point holds the most sideslip no more than the ESC holds on its
worst (the mean is the runs on mu 0.5's, and a point may hold less there and more on a dry road); and FMVSS 126's
effort - the FMVSS runs' effort at most :data:`EFFORT_CAP` times the ESC's, on the mean over the cars and roads
of each one's ratio (the means over every maneuver are dominated by the spin-outs, where the two differ by far more;
a mean over the FMVSS runs by those of the car and road where the ESC spends most; the test set is one car on one
road).

A study may run each point on several sources (the truth and an estimator: :func:`as_sources`), so that one
parameter file serves the LQR fed by either: the objectives are then the means over the sources, and a point is
within a constraint when it is on every source (:func:`point_figures`).  The baseline ESC, the bar of the
constraints and of the choice, runs on the truth (the control evaluation's ``ESC / truth`` row).

All under ``sensors+mismatch`` (sensor errors; the plant on Magic Formula tires and the controller's vehicle
perturbed from the plant's), the plant with the evaluation's wheel-slip control
(:data:`~sideslip.studies.control_eval.WHEEL_SLIP_MAX`).  A run's figures are those of the control evaluation
(:func:`~sideslip.studies.control_eval.control_metrics`).
"""
from __future__ import annotations

import math

import numpy as np

from ...control.dyc import LqrDycConfig
from .cases import ControlCase, Source, fmvss_family
from .engines import run_control_case

__all__ = ["TRAINING_SET", "TRAINING_SEEDS", "DEVELOPMENT_SET", "DEVELOPMENT_SEEDS", "CONDITION", "SEARCH_SPACE",
           "OBJECTIVES", "STRAIGHT", "STRAIGHT_RMS_MAX", "EFFORT_CAP", "TRUST", "as_sources", "search_space",
           "tuning_cases", "evaluate_case", "objectives", "point_figures", "constraints", "defaults"]

_SINE = {"maneuver_t_start": 1.0, "duration": 5.0}
"""A sine with dwell from 1 s, run 5 s: the 1.75 s criterion falls inside."""
TRAINING_SET = (("fmvss126_suv_mu05_a5.0", _SINE), ("fmvss126_suv_mu05_a6.5_right", _SINE),
                ("fmvss126_suv_mu05_a2.5", _SINE), ("fmvss126_sonata_mu08_a6.0", _SINE), ("pi2011_high", {}),
                ("bench_train_bit_sonata_snow", {}), ("bench_train_jturn_sonata_wet", {}),
                ("bench_train_sine_suv_snow", {"duration": 12.0}), ("bench_train_changing_mu_suv", {"duration": 22.0}),
                ("control_tune_bit_suv_snow_spin", {}), ("control_tune_bit_sonata_snow_spin", {}),
                ("fmvss126_sonata_mu05_a2.0", _SINE), ("fmvss126_asm_mu08_a2.0", _SINE),
                ("fmvss126_asm_mu08_a3.5_right", _SINE), ("fmvss126_asm_mu08_a5.0", _SINE),
                ("control_tune_bit_asm_snow_plough", {}), ("control_tune_straight_suv", {}))
"""``(scenario, overrides)`` of the training set (150 simulated seconds per seed)."""
TRAINING_SEEDS = (100, 101)
DEVELOPMENT_SET = (("fmvss126_suv_mu05_a6.0", _SINE), ("fmvss126_suv_mu05_a4.0_right", _SINE),
                   ("fmvss126_suv_mu05_a3.0_right", _SINE), ("pi2011_medium", {}), ("bench_dev_jturn_suv_ice", {}),
                   ("bench_dev_changing_mu_asm", {"duration": 14.0}), ("control_dev_bit_asm_ice_spin", {}),
                   ("control_dev_bit_sonata_snow_spin", {}), ("fmvss126_sonata_mu08_a4.0_right", _SINE),
                   ("fmvss126_sonata_mu08_a6.5_right", _SINE), ("fmvss126_track_mu08_a2.5_right", _SINE),
                   ("fmvss126_track_mu08_a4.0", _SINE), ("fmvss126_track_mu08_a5.5_right", _SINE),
                   ("control_dev_bit_track_snow_plough", {}), ("control_dev_straight_asm", {}))
"""``(scenario, overrides)`` of the development set (118 simulated seconds per seed)."""
DEVELOPMENT_SEEDS = (200, 201)
CONDITION = "sensors+mismatch"
STRAIGHT = ("control_tune_straight_suv", "control_dev_straight_asm")
"""The straight drives of the sets: the constraint, not the objectives."""
STRAIGHT_RMS_MAX = 50.0
"""[N m] the most RMS ``Mz_cmd`` a point may command on a straight drive (the control evaluation's bound)."""
EFFORT_CAP = 1.2
"""The most effort a point may spend, in multiples of the baseline ESC's on the same runs (the FMVSS runs' on the
mean over their cars and roads, a constraint; a set's, the choice's)."""

SEARCH_SPACE = {
    "q_beta": ("log", 1e8, 1e13),
    "q_gamma": ("log", 1e6, 1e11),
    "q_beta_mu_exponent": ("float", -3.0, 3.0),
    "q_gamma_mu_exponent": ("float", -3.0, 3.0),
    "tau_beta": ("float", 0.05, 0.6),
    "tau_gamma": ("float", 0.02, 0.4),
    "Mz_rate_max": ("log", 5e3, 2e5),
    "v_fade": ("float", 1.0, 10.0),
    "friction_source": ("int", 0, 1),
    "mu_floor": ("float", 0.1, 0.5),
    "feedforward": ("int", 0, 1),
    "f_ff": ("log", 0.5, 8.0),
    "deadband": ("float", 0.0, 0.06),
    "beta_feedback": ("int", 0, 2),
    "k_beta": ("float", 0.0, 40.0),
    "beta_limit_scale": ("float", 0.4, 1.5),
    "beta_limit_mu_max": ("float", 0.3, 2.0),
    "t_beta_lead": ("float", 0.0, 0.5),
    "k_integral": ("float", 0.0, 5.0),
    "k_understeer": ("float", 0.0, 40.0),
    "valid_gate": ("int", 0, 1),
    "beta_std_ref": ("float", 0.0, 0.1),
    "sideslip_priority": ("int", 0, 1),
}
"""What the study searches, ``name: (kind, low, high)`` (kind ``log``: log-uniform, ``float``, ``int``): the LQR's
weights and their friction schedule, its reference lags, the speed schedule's fade-in, the friction schedule
(follow ``mu_hat`` down to ``mu_floor``, or not), the command shaping (rate limit, band-limited
feed-forward) and the nonlinear parts (yaw-rate dead band, sideslip feedback beyond its reference only, sideslip
first, sideslip limiter with its bound, the friction above which the bound stops growing and its lead, yaw-rate
integral, understeer integral: :mod:`sideslip.control.dyc`) and the trust in an estimator (its ``valid`` fading the
sideslip feedback or not, the feedback weighted by its ``beta_hat_std``: no effect on the truth, so searched only
with an estimator as the source: :func:`search_space`).  ``q_N`` stays 1: the gains depend only on the weights' ratios."""
TRUST = ("valid_gate", "beta_std_ref")
"""The parameters of the trust in an estimator: they act on an estimator's ``valid`` and ``beta_hat_std``, not on the
truth."""

OBJECTIVES = ("rms_yaw_rate_error_deg_s", "effort_kNms", "max_abs_beta_deg")
"""What the study minimises, each the mean over a set's runs: yaw-rate tracking [deg/s], effort
``int |Mz_act| dt`` [kN m s], max ``|beta|`` [deg]."""


def as_sources(source=None) -> tuple:
    """``source`` - an estimator's name, ``"truth"`` or None (the truth), or a sequence of them - as a tuple of
    sources without repeats, None for the truth."""
    items = (source,) if source is None or isinstance(source, str) else tuple(source) or (None,)
    return tuple(dict.fromkeys(None if s in (None, "truth") else s for s in items))


def search_space(source=None) -> dict:
    """What a study with ``source`` (:func:`as_sources`) searches: :data:`SEARCH_SPACE`, on the truth alone
    without :data:`TRUST`.  A parameter that changes nothing would be drawn at random and written into the chosen
    file; unsearched, it stays at its shipped value there."""
    estimator = any(as_sources(source))
    return {k: v for k, v in SEARCH_SPACE.items() if estimator or k not in TRUST}


def defaults() -> dict:
    """The searched parameters' values in the shipped controller (``feedforward`` as the drivable profile takes
    its default 2: off, 0)."""
    cfg = LqrDycConfig()
    out = {name: getattr(cfg, name) for name in SEARCH_SPACE}
    out["feedforward"] = 1 if cfg.feedforward == 1 else 0
    return out


def tuning_cases(params: dict, maneuvers=TRAINING_SET, seeds=TRAINING_SEEDS, source=None,
                 controller: str = "LqrDycController") -> list:
    """The closed loops of one parameter point: every source x maneuver x seed, the ``controller`` with ``params``
    fed by each of ``source`` (:func:`as_sources`: estimators, hardened, or the truth)."""
    values = tuple(sorted(params.items()))
    return [ControlCase(name, CONDITION, seed, Source(f"{controller} / {s or 'truth'}", controller, s), values,
                        tuple(sorted(overrides.items())))
            for s in as_sources(source) for name, overrides in maneuvers for seed in seeds]


def evaluate_case(item) -> dict:
    """The figures of one closed loop (a job of the study): ``item`` is ``(case, fmu_dir)``; a run that fails
    returns ``{"error": message}``."""
    case, fmu_dir = item
    try:
        row = run_control_case((case, "library", fmu_dir))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return {"error": f"{case.scenario} seed {case.seed}: {type(exc).__name__}: {exc}"}
    source = case.source.estimator or "truth"
    if case.scenario in STRAIGHT:
        return {"straight": True, "rms_Mz_cmd": float(row["rms_Mz_cmd"]), "sim_seconds": float(row["sim_seconds"]),
                "wall_seconds": float(row["wall_seconds"]), "source": source}
    keep = ("max_abs_beta_deg", "rms_yaw_rate_error_deg_s", "rms_beta_error_deg", "effort_Nms", "saturated_pct",
            "rms_Mz_cmd", "rms_dMz_dt", "sim_seconds", "wall_seconds")
    out = {k: float(row[k]) for k in keep}
    out["source"] = source
    if row.get("yaw_stable") is not None:
        out["yaw_stable"] = bool(row["yaw_stable"])
        out["scenario"] = case.scenario
        if row["factor"] >= 5.0:                    # where FMVSS 126 asks for the lateral displacement
            out["lateral_1p07s"] = float(row["lateral_1p07s"])
    return out


def objectives(rows: list[dict]) -> dict:
    """The :data:`OBJECTIVES` and the study's other figures of one point's runs (means over the maneuvers unless
    named): ``worst_max_abs_beta_deg``, ``saturated_pct``, ``rms_dMz_dt``, ``fmvss_stable`` (FMVSS runs
    yaw-stable), ``fmvss_runs``, ``fmvss_lateral_m`` (the mean lateral displacement of the FMVSS runs at 5A and
    more, 0 without one) and its standard error ``fmvss_lateral_se_m`` (from the seeds' scatter alone:
    :func:`_seed_standard_error`), ``fmvss_max_abs_beta_deg`` (the mean max ``|beta|`` of the FMVSS runs, 0
    without one), ``fmvss_worst_max_abs_beta_deg`` (the largest over the FMVSS maneuvers of the seeds' mean max
    ``|beta|``, 0 without one), ``fmvss_effort_kNms`` (their mean effort, 0 without one),
    ``fmvss_family_effort_kNms`` (``{family: mean effort}`` of the FMVSS runs of each car on each road:
    :func:`.cases.fmvss_family`), ``straight_rms_Mz_cmd``
    (the largest over the straight drives, 0 without one), ``sim_seconds`` (every run)."""
    moving = [r for r in rows if not r.get("straight")]
    mean = lambda key: float(np.mean([r[key] for r in moving]))          # noqa: E731
    fmvss_runs = [r for r in moving if "yaw_stable" in r]
    fmvss = [r["yaw_stable"] for r in fmvss_runs]
    lateral = [r for r in moving if "lateral_1p07s" in r]
    out = {"rms_yaw_rate_error_deg_s": mean("rms_yaw_rate_error_deg_s"), "effort_kNms": mean("effort_Nms") / 1e3,
           "max_abs_beta_deg": mean("max_abs_beta_deg"),
           "worst_max_abs_beta_deg": float(max(r["max_abs_beta_deg"] for r in moving)),
           "saturated_pct": mean("saturated_pct"), "rms_dMz_dt": mean("rms_dMz_dt"),
           "fmvss_stable": int(sum(fmvss)), "fmvss_runs": len(fmvss),
           "fmvss_lateral_m": float(np.mean([r["lateral_1p07s"] for r in lateral] or [0.0])),
           "fmvss_lateral_se_m": _seed_standard_error(lateral, "lateral_1p07s"),
           "fmvss_max_abs_beta_deg": float(np.mean([r["max_abs_beta_deg"] for r in fmvss_runs] or [0.0])),
           "fmvss_worst_max_abs_beta_deg": max(_by_maneuver(fmvss_runs, "max_abs_beta_deg").values(), default=0.0),
           "fmvss_effort_kNms": float(np.mean([r["effort_Nms"] for r in fmvss_runs] or [0.0])) / 1e3,
           "fmvss_family_effort_kNms": {k: v / 1e3 for k, v in _by_maneuver(fmvss_runs, "effort_Nms",
                                                                              fmvss_family).items()},
           "straight_rms_Mz_cmd": float(max((r["rms_Mz_cmd"] for r in rows if r.get("straight")), default=0.0)),
           "sim_seconds": float(sum(r["sim_seconds"] for r in rows))}
    if not all(math.isfinite(out[k]) for k in (*OBJECTIVES, "straight_rms_Mz_cmd")):
        raise ValueError("a run gave a non-finite figure")
    return out


_WORST = {"fmvss_stable": min, "fmvss_runs": min, "fmvss_lateral_m": min, "fmvss_max_abs_beta_deg": max,
          "fmvss_worst_max_abs_beta_deg": max, "fmvss_effort_kNms": max, "straight_rms_Mz_cmd": max,
          "worst_max_abs_beta_deg": max,
          "fmvss_family_effort_kNms": lambda each: {k: max(e[k] for e in each) for k in each[0]}}
"""How :func:`point_figures` takes a constrained figure over the sources: the worst source's."""


def point_figures(runs: list[dict]) -> dict:
    """A point's figures from its runs on one or several sources (a run's ``source``): each source's
    :func:`objectives`; over the sources, the mean of each (the objectives: one point serves every source) but
    for the figures the constraints read and the worst case, which are the worst source's (:data:`_WORST`: a point
    within a constraint is within it on every source) and ``sim_seconds``, their sum."""
    groups: dict = {}
    for r in runs:
        groups.setdefault(r.get("source"), []).append(r)
    each = [objectives(g) for g in groups.values()]
    if len(each) == 1:
        return each[0]
    out = {k: float(np.mean([f[k] for f in each])) for k in each[0] if k not in _WORST}
    out.update({k: take([f[k] for f in each]) for k, take in _WORST.items()})
    out["sim_seconds"] = float(sum(f["sim_seconds"] for f in each))
    return out


def _by_maneuver(runs: list[dict], key: str, group=lambda name: name) -> dict:
    """The mean of ``key`` for each maneuver (a run's ``scenario``, the seeds' mean; runs without one: one maneuver)
    or each ``group(scenario)`` of them."""
    groups: dict = {}
    for r in runs:
        groups.setdefault(group(r.get("scenario") or ""), []).append(r[key])
    return {name: float(np.mean(v)) for name, v in groups.items()}


def _seed_standard_error(runs: list[dict], key: str) -> float:
    """The standard error of the mean of ``key`` over ``runs`` that the seeds alone make: each maneuver's (a run's
    ``scenario``) variance over its seeds, the maneuvers' means averaged (equal seeds per maneuver: the runs' mean).
    The spread between maneuvers (one car on two roads: a metre apart) is no uncertainty of the bar.  Runs without a
    scenario count as one maneuver; 0 without a maneuver run twice."""
    groups: dict = {}
    for r in runs:
        groups.setdefault(r.get("scenario"), []).append(r[key])
    var = [np.var(v, ddof=1) / len(v) for v in groups.values() if len(v) > 1]
    return float(math.sqrt(sum(var)) / len(groups)) if var else 0.0


def constraints(figures: dict, esc: dict | None = None) -> dict:
    """The study's constraints of a point's :func:`objectives` (feasible when none is above 0): ``straight``
    = ``straight_rms_Mz_cmd - STRAIGHT_RMS_MAX`` [N m], ``responsive`` = the ESC's ``fmvss_lateral_m`` (its
    :func:`objectives` on the same runs, ``esc``) less its standard error and the point's [m] (a bar measured on a
    few runs, which the seeds alone move), ``stable`` = the ESC's ``fmvss_stable`` less the point's [runs],
    ``sideslip`` = the point's ``fmvss_max_abs_beta_deg`` less the ESC's [deg], ``sideslip_worst`` = the point's
    ``fmvss_worst_max_abs_beta_deg`` less the ESC's [deg] (the maneuver where the point holds the most sideslip
    against the one where the ESC does: the means hide a car and road where a point does worse than the ESC) and
    ``effort`` = the mean over the FMVSS runs' families (:func:`.cases.fmvss_family`: a car on a road) of the point's
    effort over the ESC's, less :data:`EFFORT_CAP` (each car and road weighs the same: a mean over the runs is that
    of the car and road where the ESC spends most; a point of an older study, without the families: the point's
    ``fmvss_effort_kNms`` less :data:`EFFORT_CAP` times the ESC's [kN m s]); a figure not measured (no ESC, no such
    run) constrains nothing."""
    esc = esc or {}

    def below(key, scale=1.0):
        mine, bar = figures.get(key), esc.get(key)
        return scale * bar - mine if mine is not None and bar is not None else 0.0

    return {"straight": figures.get("straight_rms_Mz_cmd", 0.0) - STRAIGHT_RMS_MAX,
            "responsive": below("fmvss_lateral_m") - esc.get("fmvss_lateral_se_m", 0.0),
            "stable": float(below("fmvss_stable")), "sideslip": -below("fmvss_max_abs_beta_deg"),
            "sideslip_worst": -below("fmvss_worst_max_abs_beta_deg"), "effort": _effort_beyond_cap(figures, esc)}


def _effort_beyond_cap(figures: dict, esc: dict) -> float:
    """The ``effort`` constraint of :func:`constraints`."""
    mine, bar = figures.get("fmvss_family_effort_kNms"), esc.get("fmvss_family_effort_kNms")
    common = [k for k in mine or {} if k in (bar or {})]
    if common:
        return float(np.mean([mine[k] / max(bar[k], 1e-9) for k in common])) - EFFORT_CAP
    mine, bar = figures.get("fmvss_effort_kNms"), esc.get("fmvss_effort_kNms")
    return mine - EFFORT_CAP * bar if mine is not None and bar is not None else 0.0
