"""``sideslip tune``: a multi-objective search over the LQR's parameters with Optuna, resumable and shareable.

Optuna rather than a hand-written search: multi-objective TPE and NSGA-II samplers, and a journal storage (one
append-only file) that several ``sideslip tune`` processes, on this machine or on a shared file system, use
together, and that a stopped study goes on from.

A study (:func:`run_study`):

1. runs the baseline ESC on the training set (on the truth: the bar of the constraints), then asks the sampler
   for a batch of points of :data:`~sideslip.studies.control_eval.tuning.SEARCH_SPACE` (on the truth without the
   trust in an estimator: :func:`~sideslip.studies.control_eval.tuning.search_space`; the shipped parameters are
   the study's first point) and runs each on the training set
   (:data:`~sideslip.studies.control_eval.tuning.TRAINING_SET` x seeds, on each source) with the one job runner -
   a local pool or a Dask cluster, kept for the whole study; every run's figures are appended to ``runs.jsonl`` as
   it finishes and a point's objectives go to the storage as soon as its runs are in;
2. takes the Pareto front of the training objectives (yaw-rate tracking, effort, max ``|beta|``), runs up to
   ``dev_points`` of it, spread along the tracking axis, the points it was started from (``start``: e.g. another
   study's choice; TPE's fronts differ much between studies), the shipped point and the baseline ESC (on the truth:
   the evaluation's ``ESC / truth`` row) on the development set, and chooses what the LQR has to earn against the
   ESC: among the points with at most :data:`~sideslip.studies.control_eval.tuning.EFFORT_CAP` times the ESC's
   effort, at least as many FMVSS 126 runs yaw-stable and within the constraints
   (:func:`~sideslip.studies.control_eval.tuning.constraints`: the straight drive quiet, the FMVSS runs as
   responsive as the ESC's, within its standard error, with no more sideslip, on the mean and on the worst
   maneuver, and at most the same multiple of its effort), the smallest sum of yaw-rate error and max ``|beta|``,
   each over the ESC's (without such a point, among those keeping the FMVSS 126 runs stable: the least beyond the
   constraints - the sum of how far beyond each, as Optuna's samplers rank such points - then the smallest sum of
   all three ratios);
3. writes the chosen point as a parameter file (``chosen.json``, ``chosen.ssv``:
   :mod:`sideslip.fmi.param_file`; what the study did not search at the shipped values), every point
   (``trials.csv``), the Pareto-front plot (``pareto.png``) and ``summary.json`` (the study's throughput: simulated
   seconds per wall second).

A run stopped mid-study leaves its asked points running in the storage: the next run on this machine marks those
of processes that no longer exist failed and asks for the same points again (their finished runs come from
``runs.jsonl``).  The held-out figures are the control evaluation's, ``sideslip control --params chosen.json``.
"""
from __future__ import annotations

import json
import math
import os
import socket
import time
from pathlib import Path

import numpy as np

from ...fmi.build import DEFAULT_OUT
from ...fmi.param_file import write_param_file
from ...progress import progress_bar
from ...scenarios import get_scenario
from ..jobs import ResultLog, parallel_map, worker_pool
from .tuning import (DEVELOPMENT_SEEDS, DEVELOPMENT_SET, EFFORT_CAP, OBJECTIVES, SEARCH_SPACE, TRAINING_SEEDS,
                     TRAINING_SET, as_sources, constraints, defaults, evaluate_case, point_figures, search_space,
                     tuning_cases)

__all__ = ["run_study", "choose_point", "SAMPLERS", "STUDY_NAME"]

STUDY_NAME = "lqr"
SAMPLERS = ("tpe", "nsga2")
_FAMILIES = "fmvss_family_effort_kNms"
_OWNER = "owner"            # user attribute: host:pid of the process that asked for the point


def _optuna():
    try:
        import optuna
    except ImportError:
        raise RuntimeError("the tuning study needs Optuna: pip install 'sideslip-fmu[tune]'") from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def open_study(path, name: str = STUDY_NAME, sampler: str = "tpe", seed: int = 0, start=(), source=None):
    """The study ``name`` in the journal file ``path`` (created with the shipped point as its first point, then the
    points ``start``: parameter dicts, the searched parameters they lack at their shipped values; a point the
    study holds already is not asked again).

    The sampler's random state is ``seed`` plus the points the study already holds, so that a study that goes on
    draws new points rather than its first ones again."""
    optuna = _optuna()
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    Path(path).parent.mkdir(parents=True, exist_ok=True)
    storage = JournalStorage(JournalFileBackend(str(path)))
    try:
        held = len(optuna.load_study(study_name=name, storage=storage).trials)
    except KeyError:                                    # a new study
        held = 0
    seed += held
    if sampler == "tpe":
        chosen = optuna.samplers.TPESampler(seed=seed, multivariate=True, n_startup_trials=10)
    elif sampler == "nsga2":
        chosen = optuna.samplers.NSGAIISampler(seed=seed, population_size=16)
    else:
        raise ValueError(f"sampler {sampler!r}: use one of {', '.join(SAMPLERS)}")
    study = optuna.create_study(study_name=name, storage=storage,
                                directions=["minimize"] * len(OBJECTIVES), sampler=chosen, load_if_exists=True)
    if not study.trials:
        study.enqueue_trial(defaults())
    for point in start:
        study.enqueue_trial(start_point(point, source), skip_if_exists=True)
    return study


def start_point(values: dict, source=None) -> dict:
    """A parameter file's values as a point of the search space of a study with ``source`` (what it lacks at the
    shipped values; :func:`~sideslip.studies.control_eval.tuning.search_space`)."""
    space = search_space(source)
    return {k: v for k, v in {**defaults(), **values}.items() if k in space}


def _suggest(trial, source=None) -> dict:
    out = {}
    for name, (kind, lo, hi) in search_space(source).items():
        if kind == "int":
            out[name] = trial.suggest_int(name, lo, hi)
        else:
            out[name] = trial.suggest_float(name, lo, hi, log=kind == "log")
    return out


def _alive(owner: str) -> bool:
    """Whether the process ``host:pid`` may still run (always, for another host's)."""
    host, _, pid = owner.rpartition(":")
    if host != socket.gethostname():
        return True
    try:
        os.kill(int(pid), 0)
    except (ProcessLookupError, ValueError):
        return False
    except PermissionError:
        return True
    return True


def _release_stale(study) -> int:
    """Mark failed the running points of this machine's processes that are gone, and ask for them again."""
    optuna = _optuna()
    stale = [t for t in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,))
             if not _alive(t.user_attrs.get(_OWNER, ""))]
    for t in stale:
        study.tell(t.number, state=optuna.trial.TrialState.FAIL, skip_if_finished=True)
        study.enqueue_trial(t.params or t.system_attrs.get("fixed_params", {}))
    return len(stale)


def _sim_seconds(cases) -> float:
    return sum(dict(c.overrides).get("duration", get_scenario(c.scenario).duration) for c in cases)


def _evaluate_points(points: dict, maneuvers, seeds, source, pool, workers, log: ResultLog, fmu_dir, bar,
                     done=None, controllers=None) -> tuple[dict, float]:
    """Run every point's cases (``points``: key -> parameters; ``controllers``: key -> a controller other than the
    LQR, which runs on the truth; the LQR on ``source``) through the job runner, calling ``done(key, runs)`` as
    each point's runs are all in; returns ``({key: runs}, simulated seconds run)``."""
    cached = log.load()
    controllers = controllers or {}
    cases = {key: tuning_cases(p, maneuvers, seeds, None, controllers[key]) if key in controllers else
             tuning_cases(p, maneuvers, seeds, source) for key, p in points.items()}
    runs = {key: {} for key in points}
    waiting: dict[str, list] = {}
    for key, cs in cases.items():
        for c in cs:
            k = repr(c)
            if k in cached:
                runs[key][k] = cached[k]
            else:
                waiting.setdefault(k, []).append(key)
    finished = {}

    def complete(key):
        if len(runs[key]) == len(cases[key]) and key not in finished:
            finished[key] = [runs[key][repr(c)] for c in cases[key]]
            if done is not None:
                done(key, finished[key])

    for key in points:
        complete(key)
    jobs = {repr(c): (c, str(fmu_dir)) for cs in cases.values() for c in cs if repr(c) in waiting}
    sim = 0.0
    for item, result in parallel_map(evaluate_case, list(jobs.values()), workers, pool, progress=False):
        k = repr(item[0])
        log.append(k, result)
        run_for = _sim_seconds([item[0]])
        sim += run_for
        if bar is not None:
            bar.update(run_for)
        for key in waiting[k]:
            runs[key][k] = result
            complete(key)
    return finished, sim


def run_study(out, n_trials: int = 60, workers: int = 2, scheduler=None, source=None,
              sampler: str = "tpe", seed: int = 0, name: str = STUDY_NAME, dev_points: int = 10,
              training=TRAINING_SET, training_seeds=TRAINING_SEEDS, development=DEVELOPMENT_SET,
              development_seeds=DEVELOPMENT_SEEDS, fmu_dir=DEFAULT_OUT, progress: bool = True, start=()) -> dict:
    """Run (or go on with) a tuning study until it holds ``n_trials`` finished points; choose on the development
    set and write the files (module docstring).

    Parameters
    ----------
    out : path
        The study's folder (its storage ``journal.log``, ``runs.jsonl`` and the written files).
    n_trials : int
        Finished points the study should hold (those of earlier runs and of other processes count).
    workers : int
        Local processes (1: in this process).
    scheduler : str, optional
        A Dask scheduler's address, or ``"local"`` for a Dask cluster of ``workers`` processes here.
    source : str or sequence of str, optional
        The estimator that feeds the LQR (hardened profile), ``"truth"`` or None for the plant's truth, or several
        of them: each point runs on each (:func:`~sideslip.studies.control_eval.tuning.point_figures`).
    sampler : str
        ``tpe`` (multi-objective TPE) or ``nsga2``.
    start : sequence of dict
        Points the study asks first (e.g. another study's chosen parameters); they run on the development set too.

    Returns
    -------
    dict
        The summary written to ``summary.json``: ``chosen`` (trial, parameters, training and development
        objectives), ``shipped`` (the same for the shipped point), ``pareto`` (trial numbers), ``trials``,
        ``sim_seconds`` (the training runs this run made), ``wall_seconds`` and ``sim_per_wall`` (all it
        simulated, development runs included, per wall second) of this run, and the files written.
    """
    optuna = _optuna()
    out, source = Path(out), as_sources(source)
    study = open_study(out / "journal.log", name, sampler, seed, start, source)
    released = _release_stale(study)
    log = ResultLog(out / "runs.jsonl")
    complete_state = optuna.trial.TrialState.COMPLETE
    have = len(study.get_trials(deepcopy=False, states=(complete_state,)))
    per_point = _sim_seconds(tuning_cases({}, training, training_seeds, source))
    todo = max(n_trials - have, 0)
    bar = progress_bar(todo * per_point + (dev_points + 2) * _sim_seconds(
        tuning_cases({}, development, development_seeds, source)), "tune", "sim s",
        enabled=None if progress else False)
    t0, sim = time.perf_counter(), 0.0
    owner = f"{socket.gethostname()}:{os.getpid()}"
    with worker_pool(workers, scheduler) as pool:
        esc = _esc_figures(training, training_seeds, pool, workers, log, fmu_dir)
        while True:
            have = len(study.get_trials(deepcopy=False, states=(complete_state,)))
            if have >= n_trials:
                break
            failed = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.FAIL,))
            if len(failed) > max(n_trials, 10) + released:
                raise RuntimeError(f"{len(failed)} points failed, more than the study is to hold; the first: "
                                   + next((t.user_attrs["error"] for t in failed if "error" in t.user_attrs), "?"))
            batch = {}
            for _ in range(min(n_trials - have, max(workers, 1))):
                trial = study.ask()
                trial.set_user_attr(_OWNER, owner)
                batch[str(trial.number)] = (trial, _suggest(trial, source))

            def tell(key, runs):
                trial = batch[key][0]
                errors = [r["error"] for r in runs if "error" in r]
                if errors:
                    trial.set_user_attr("error", errors[0])
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
                    return
                try:
                    figures = point_figures(runs)
                except ValueError as exc:
                    trial.set_user_attr("error", str(exc))
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
                    return
                for k, v in figures.items():
                    trial.set_user_attr(k, v)
                for k, v in constraints(figures, esc).items():
                    trial.set_constraint(k, v)
                study.tell(trial, [figures[k] for k in OBJECTIVES])

            _, ran = _evaluate_points({k: p for k, (_, p) in batch.items()}, training, training_seeds, source, pool,
                                      workers, log, fmu_dir, bar, tell)
            sim += ran
        summary = _choose(study, out, source, development, development_seeds, dev_points, pool, workers, log,
                          fmu_dir, bar, start, esc)
    bar.close()
    wall = time.perf_counter() - t0
    ran = sim + summary["development_sim_seconds"]          # what this run simulated, for its throughput
    summary.update(study=name, sampler=sampler, source=_label(source), released_stale=released,
                   sim_seconds=sim, wall_seconds=wall, sim_per_wall=ran / wall if wall > 0 else math.nan,
                   workers="dask " + str(scheduler) if scheduler is not None else workers)
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    return summary


def _label(source: tuple) -> str:
    return ", ".join(s or "truth" for s in source)


def _esc_figures(maneuvers, seeds, pool, workers, log, fmu_dir) -> dict:
    """The baseline ESC's figures on a set, on the truth (its runs are kept in the log like the points')."""
    runs = _evaluate_points({"esc": {}}, maneuvers, seeds, None, pool, workers, log, fmu_dir, None,
                            controllers={"esc": "BaselineEsc"})[0]["esc"]
    errors = [r["error"] for r in runs if "error" in r]
    if errors:
        raise RuntimeError("the baseline ESC failed on the training set: " + errors[0])
    return point_figures(runs)


def _feasible(figures: dict, esc: dict) -> bool:
    return all(v <= 0.0 for v in constraints(figures, esc).values())


def choose_point(lqr: dict, esc: dict) -> tuple:
    """The development set's choice (module docstring) among the points' figures ``lqr`` (key -> figures) against
    the ESC's ``esc``: ``(key, {key: score}, {key: excess beyond the constraints}, whether a point was within the
    constraints and the effort cap)``."""
    ratio = {k: {o: s[o] / max(esc[o], 1e-9) for o in OBJECTIVES} for k, s in lqr.items()}
    stable = [k for k, s in lqr.items() if s["fmvss_stable"] >= esc["fmvss_stable"]] or list(lqr)
    stable = [k for k in stable if _feasible(lqr[k], esc)] or stable
    ok = [k for k in stable if lqr[k]["effort_kNms"] <= EFFORT_CAP * esc["effort_kNms"] and _feasible(lqr[k], esc)]
    excess = {k: _excess(lqr[k], esc) for k in stable}
    if ok:
        rank = {k: ratio[k]["rms_yaw_rate_error_deg_s"] + ratio[k]["max_abs_beta_deg"] for k in ok}
        return min(rank, key=rank.get), rank, excess, True
    rank = {k: sum(ratio[k].values()) for k in stable}  # the constraints first: the least beyond them, then the ratios
    return min(rank, key=lambda k: (excess[k], rank[k])), rank, excess, False


def _excess(figures: dict, esc: dict) -> float:
    """How far a point is beyond its constraints: the sum of the positive ones (0 within them all), as Optuna's
    samplers rank points beyond them."""
    return float(sum(max(v, 0.0) for v in constraints(figures, esc).values()))


def _choose(study, out: Path, source, development, seeds, dev_points: int, pool, workers, log, fmu_dir, bar,
            start=(), esc_training=None) -> dict:
    """The development-set choice among the Pareto front (and the ``start`` points) and the files (module
    docstring)."""
    optuna = _optuna()
    trials = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
    if not trials:
        raise RuntimeError("the study holds no finished point (every point failed: see trials.csv)")
    shipped_params = defaults()
    # a point of a study that did not search a parameter ran at its shipped value
    shipped = next((t for t in trials if all(t.params.get(k, v) == v for k, v in shipped_params.items())), None)
    # Optuna's front holds the points within the constraints; if none is, the front of them all
    front = sorted(study.best_trials or _pareto_front(trials), key=lambda t: t.values[0])
    picks = {front[int(round(i))].number for i in np.linspace(0, len(front) - 1, min(dev_points, len(front)))}
    wanted = [start_point(p, source) for p in start]
    picks = sorted(picks | {t.number for t in trials if any(t.params == p for p in wanted)})
    by_number = {t.number: t for t in trials}
    points = {str(n): by_number[n].params for n in picks}
    points["shipped"] = shipped_params
    points["esc"] = {}
    dev, ran = _evaluate_points(points, development, seeds, source, pool, workers, log, fmu_dir, bar,
                                controllers={"esc": "BaselineEsc"})
    failed = {k for k, runs in dev.items() if any("error" in r for r in runs)}
    scores = {k: point_figures(runs) for k, runs in dev.items() if k not in failed}
    if "esc" not in scores:
        raise RuntimeError("the baseline ESC failed on the development set: " + next(
            r["error"] for r in dev["esc"] if "error" in r))
    esc = scores["esc"]
    lqr = {k: s for k, s in scores.items() if k not in ("esc", "shipped")}
    if not lqr:
        raise RuntimeError("no point of the Pareto front ran on the development set")
    best, rank, excess, ok = choose_point(lqr, esc)
    chosen = by_number[int(best)]
    info = {"study": study.study_name, "trial": chosen.number, "source": _label(source),
            "training": {k: chosen.user_attrs.get(k) for k in (*OBJECTIVES, "fmvss_stable", "fmvss_runs",
                                                                "fmvss_lateral_m", "fmvss_max_abs_beta_deg",
                                                                "fmvss_worst_max_abs_beta_deg",
                                                                "fmvss_effort_kNms", _FAMILIES,
                                                                "straight_rms_Mz_cmd")},
            "development": scores[best], "shipped_development": scores.get("shipped"), "esc_development": esc,
            "within_effort_cap": bool(ok), "development_score": rank[best],
            "development_excess": excess[best]}
    params = {**defaults(), **chosen.params}          # what the study did not search, at the shipped values
    files = [write_param_file(out / "chosen.json", "LqrDycController", params, info),
             write_param_file(out / "chosen.ssv", "LqrDycController", params)]
    files.append(_write_trials(trials, out / "trials.csv"))
    files.append(pareto_plot(trials, front, chosen, shipped, out / "pareto.png", esc_training))
    return {"chosen": {"trial": chosen.number, "parameters": params, **info},
            "shipped": {"trial": shipped.number if shipped else None,
                        "training": {k: shipped.user_attrs.get(k) for k in OBJECTIVES} if shipped else None,
                        "development": scores.get("shipped")},
            "esc": {"development": esc, "training": esc_training},
            "pareto": [t.number for t in front], "development_scores": rank, "development": scores,
            "trials": len(trials),
            "development_sim_seconds": ran, "files": [str(f) for f in files]}


def _pareto_front(trials) -> list:
    """The points no other point is at least as good as in every objective and better in one (minimised): the
    front of every point when none is within the constraints (Optuna's own function for it is private)."""
    v = np.array([t.values for t in trials])
    return [t for t, x in zip(trials, v) if not np.any(np.all(v <= x, axis=1) & np.any(v < x, axis=1))]


def _write_trials(trials, path: Path) -> Path:
    import csv

    extra = ("worst_max_abs_beta_deg", "saturated_pct", "rms_dMz_dt", "fmvss_stable", "fmvss_runs",
             "fmvss_lateral_m", "fmvss_max_abs_beta_deg", "fmvss_worst_max_abs_beta_deg", "fmvss_effort_kNms",
             "straight_rms_Mz_cmd")
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["trial", *SEARCH_SPACE, *OBJECTIVES, *extra, _FAMILIES])
        for t in trials:
            w.writerow([t.number, *(t.params.get(k) for k in SEARCH_SPACE), *t.values,
                        *(t.user_attrs.get(k) for k in extra), json.dumps(t.user_attrs.get(_FAMILIES))])
    return path


def pareto_plot(trials, front, chosen, shipped, path: Path, esc: dict | None = None) -> Path:
    """Tracking against effort and against max ``|beta|`` of every point (those beyond a constraint as crosses; the
    ESC's training figures ``esc`` are the responsiveness bar), the Pareto front, the shipped and the chosen point
    (training objectives)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    v = np.array([t.values for t in trials])
    ok = np.array([_feasible(t.user_attrs, esc) for t in trials])
    f = np.array([t.values for t in front])
    labels = ("RMS yaw-rate error [deg/s]", "effort int |Mz| dt [kN m s]", "max |beta| [deg]")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, (i, j, c) in zip(axes, ((1, 0, 2), (2, 0, 1))):
        sc = ax.scatter(v[ok, i], v[ok, j], c=v[ok, c], s=14, cmap="viridis", alpha=0.6, label="points")
        if not ok.all():
            ax.scatter(v[~ok, i], v[~ok, j], marker="x", color="0.6", s=12,
                       label="beyond a constraint")
        ax.scatter(f[:, i], f[:, j], facecolors="none", edgecolors="k", s=40, label="Pareto front (3 objectives)")
        if shipped is not None:
            ax.plot(shipped.values[i], shipped.values[j], "s", color="tab:orange", ms=10, label="shipped")
        ax.plot(chosen.values[i], chosen.values[j], "r*", ms=16, label="chosen (development set)")
        fig.colorbar(sc, ax=ax, label=labels[c])
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):               # plain numbers on the log axes
            axis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
            axis.set_minor_formatter(FuncFormatter(lambda x, _: f"{x:g}" if f"{x:.0e}"[0] in "25" else ""))
        ax.set_xlabel(labels[i])
        ax.set_ylabel(labels[j])
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"LQR tuning study: {len(trials)} points, training set means")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
