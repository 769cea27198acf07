"""What a tuning study of the LQR searches and scores: its parameters, the maneuver sets, the objectives.

The sets are disjoint from the control evaluation's (:data:`~sideslip.studies.control_eval.SCENARIOS`, the FMVSS 126
runs on the SUV at mu 0.8, seeds 0 and 1), which is the study's test set:

* **training** (:data:`TRAINING_SET`, seeds :data:`TRAINING_SEEDS`): what the optimiser sees - FMVSS 126 at mu 0.5,
  Pi 2011's sine steer on mu 0.8 at 80 km/h (the SUV), the estimator benchmark's training brake in a turn on snow
  and J-turn on a wet road (Sonata), its sine steer on snow (SUV);
* **development** (:data:`DEVELOPMENT_SET`, seeds :data:`DEVELOPMENT_SEEDS`): where the Pareto front's points are
  compared with the baseline ESC and one is chosen - FMVSS 126 at mu 0.5 at other amplitudes, Pi 2011's sine
  steer on mu 0.5 at 60 km/h, the benchmark's development J-turn on ice (SUV) and friction drop (small car).

All under ``sensors+mismatch`` (sensor errors; the plant on Magic Formula tires and the controller's vehicle
perturbed from the plant's).  A run's figures are those of the control evaluation
(:func:`~sideslip.studies.control_eval.control_metrics`).
"""
from __future__ import annotations

import math

import numpy as np

from ...control.dyc import LqrDycConfig
from .cases import ControlCase, Source
from .engines import run_control_case

__all__ = ["TRAINING_SET", "TRAINING_SEEDS", "DEVELOPMENT_SET", "DEVELOPMENT_SEEDS", "CONDITION", "SEARCH_SPACE",
           "OBJECTIVES", "tuning_cases", "evaluate_case", "objectives", "defaults"]

_SINE = {"maneuver_t_start": 1.0, "duration": 5.0}
"""A sine with dwell from 1 s, run 5 s: the 1.75 s criterion falls inside."""
TRAINING_SET = (("fmvss126_suv_mu05_a5.0", _SINE), ("fmvss126_suv_mu05_a6.5_right", _SINE), ("pi2011_high", {}),
                ("bench_train_bit_sonata_snow", {}), ("bench_train_jturn_sonata_wet", {}),
                ("bench_train_sine_suv_snow", {"duration": 12.0}))
"""``(scenario, overrides)`` of the training set (56 simulated seconds per seed)."""
TRAINING_SEEDS = (100, 101)
DEVELOPMENT_SET = (("fmvss126_suv_mu05_a6.0", _SINE), ("fmvss126_suv_mu05_a4.0_right", _SINE), ("pi2011_medium", {}),
                   ("bench_dev_jturn_suv_ice", {}), ("bench_dev_changing_mu_asm", {"duration": 14.0}))
"""``(scenario, overrides)`` of the development set (46 simulated seconds per seed)."""
DEVELOPMENT_SEEDS = (200, 201)
CONDITION = "sensors+mismatch"

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
}
"""What the study searches, ``name: (kind, low, high)`` (kind ``log``: log-uniform, ``float``, ``int``): the LQR's
weights and their friction schedule, its reference lags, the speed schedule's fade-in, the friction schedule
(follow ``mu_hat`` down to ``mu_floor``, or not), and the command shaping (rate limit, band-limited
feed-forward).  ``q_N`` stays 1: the gains depend only on the weights' ratios."""

OBJECTIVES = ("rms_yaw_rate_error_deg_s", "effort_kNms", "max_abs_beta_deg")
"""What the study minimises, each the mean over a set's runs: yaw-rate tracking [deg/s], effort
``int |Mz_act| dt`` [kN m s], max ``|beta|`` [deg]."""


def defaults() -> dict:
    """The searched parameters' values in the shipped controller (``feedforward`` as the drivable profile takes
    its default 2: off, 0)."""
    cfg = LqrDycConfig()
    out = {name: getattr(cfg, name) for name in SEARCH_SPACE}
    out["feedforward"] = 1 if cfg.feedforward == 1 else 0
    return out


def tuning_cases(params: dict, maneuvers=TRAINING_SET, seeds=TRAINING_SEEDS, source: str | None = None,
                 controller: str = "LqrDycController") -> list:
    """The closed loops of one parameter point: every maneuver x seed, the ``controller`` with ``params`` fed by
    ``source`` (an estimator, hardened; None: the truth)."""
    row = Source(f"{controller} / {source or 'truth'}", controller, source)
    values = tuple(sorted(params.items()))
    return [ControlCase(name, CONDITION, seed, row, values, tuple(sorted(overrides.items())))
            for name, overrides in maneuvers for seed in seeds]


def evaluate_case(item) -> dict:
    """The figures of one closed loop (a job of the study): ``item`` is ``(case, fmu_dir)``; a run that fails
    returns ``{"error": message}``."""
    case, fmu_dir = item
    try:
        row = run_control_case((case, "library", fmu_dir))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return {"error": f"{case.scenario} seed {case.seed}: {type(exc).__name__}: {exc}"}
    keep = ("max_abs_beta_deg", "rms_yaw_rate_error_deg_s", "rms_beta_error_deg", "effort_Nms", "saturated_pct",
            "rms_Mz_cmd", "rms_dMz_dt", "sim_seconds", "wall_seconds")
    out = {k: float(row[k]) for k in keep}
    if row.get("yaw_stable") is not None:
        out["yaw_stable"] = bool(row["yaw_stable"])
    return out


def objectives(rows: list[dict]) -> dict:
    """The :data:`OBJECTIVES` and the study's other figures of one point's runs (means unless named):
    ``worst_max_abs_beta_deg``, ``saturated_pct``, ``rms_dMz_dt``, ``fmvss_stable`` (FMVSS runs yaw-stable),
    ``fmvss_runs``, ``sim_seconds``."""
    mean = lambda key: float(np.mean([r[key] for r in rows]))          # noqa: E731
    fmvss = [r["yaw_stable"] for r in rows if "yaw_stable" in r]
    out = {"rms_yaw_rate_error_deg_s": mean("rms_yaw_rate_error_deg_s"), "effort_kNms": mean("effort_Nms") / 1e3,
           "max_abs_beta_deg": mean("max_abs_beta_deg"),
           "worst_max_abs_beta_deg": float(max(r["max_abs_beta_deg"] for r in rows)),
           "saturated_pct": mean("saturated_pct"), "rms_dMz_dt": mean("rms_dMz_dt"),
           "fmvss_stable": int(sum(fmvss)), "fmvss_runs": len(fmvss),
           "sim_seconds": float(sum(r["sim_seconds"] for r in rows))}
    if not all(math.isfinite(out[k]) for k in OBJECTIVES):
        raise ValueError("a run gave a non-finite figure")
    return out
