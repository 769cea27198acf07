"""Closed-loop evaluation of the yaw-moment controllers under realistic sensors and model mismatch.

Every case is a scenario under one of the estimator benchmark's conditions (:data:`CONDITIONS`:
``sensors`` - automotive-grade sensor errors, ``sensors+mismatch`` - those plus the plant on Magic
Formula tires and the estimators' *and the controller's* vehicle perturbed from the plant's;
:mod:`sideslip.studies.benchmark`) with a seed, run in closed loop for every row of
:data:`SOURCES`: no control; the LQR (published and drivable profiles) on the true sideslip; the
LQR on each hardened estimator; the StabilityController (estimator and LQR in one model); the
baseline ESC on the truth and on the best two hardened estimators.

Scenarios (:data:`SCENARIOS`): FMVSS 126 sine with dwell on the SUV, 1.5A-6.5A both directions
(:data:`FMVSS_FAMILY`); brake in a turn on packed snow (``park2018_case5``); acceleration in a turn
(``park2018_case3``); a low-speed launch into a turn (``control_launch_turn_sonata``); a long straight
drive (``bench_straight_sonata_long``, its first 40 s: 10 -> 30 m/s); a sine steer while the friction
drops from 0.9 to 0.4 and returns (``bench_changing_mu_sonata``).

* FMVSS 126 (49 CFR 571.126 S5.2, S7.7, S7.11): the yaw rate 1.00 s and 1.75 s after the
  completion of steer must be below 35 % and 20 % of the first yaw-rate peak after the steering
  wheel changes sign; for amplitudes of 5A and more the lateral displacement of the CG 1.07 s
  after the beginning of steer, perpendicular to the initial heading, must be at least 1.83 m.
  A row passes a seed when it passes at every amplitude where the uncontrolled car fails.
* Every run (:func:`control_metrics`): max ``|beta|``, RMS yaw-rate and sideslip tracking errors
  against the reference model of :mod:`sideslip.control.reference` (computed from the driver's
  steering and the plant's speed, so that runs without a controller have a reference too), effort
  ``int |Mz_act| dt``, the share of time saturated, RMS and max of ``d(Mz_cmd)/dt``, the RMS of
  ``Mz_cmd`` and the largest moment against the driver's steering during the launch - all while
  ``v > v_min``.

Two engines run the same cases: ``library`` (the models in one process, :func:`sideslip.plant.loop.run_loop`;
the default, about 6 times faster) and ``fmpy`` (the FMUs, :func:`sideslip.studies.runs.run_scenario`),
which agree (tests/test_stability_control.py).
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from ..bicycle import BicycleModel
from ..control.base import yaw_moment_limit
from ..control.dyc import LqrDycConfig
from ..control.reference import ReferenceModel
from ..fmi.build import DEFAULT_OUT
from ..fmi.catalogue import fmu_spec
from ..params import build, declared_fields, format_assignments, parse_assignments
from ..plant.driver import Driver, DriverConfig
from ..plant.loop import run_loop
from ..plant.maneuvers import parse_maneuver
from ..plant.sensors import SensorConfig, SensorSuite
from ..plant.vehicle import PlantConfig, VehiclePlant
from ..scenarios import FMVSS_FACTORS
from ..vehicles import VehicleParams
from .benchmark import PAPER_METHODS, Case, Row, make_estimator, setup
from .jobs import map_ordered

__all__ = ["CONDITIONS", "FMVSS_FAMILY", "SCENARIOS", "QUICK_FACTORS", "Source", "SOURCES", "ControlCase",
           "control_cases", "with_controller_params", "plot_example",
           "steer_times", "scenario_mu", "fmvss126_metrics", "control_metrics", "simulate_control", "run_control_case",
           "control_evaluation", "summarise", "format_control_evaluation", "TUNING_MANEUVERS", "evaluate_weights"]

CONDITIONS = ("sensors", "sensors+mismatch")
FMVSS_FAMILY = "fmvss126_suv_mu08"
SCENARIOS = ("park2018_case5", "park2018_case3", "control_launch_turn_sonata", "bench_straight_sonata_long",
             "bench_changing_mu_sonata")
DURATION = {"bench_straight_sonata_long": 40.0}
"""Scenarios run shorter than defined [s] (the straight drive: 10 s at 10 m/s, 0.8 m/s2 to 30 m/s, 5 s at it)."""
LAUNCH = "control_launch_turn_sonata"
_DEG = 180.0 / math.pi


@dataclass(frozen=True)
class Source:
    """One row: a controller fed by the truth or an estimator (hardened profile), or no control."""

    label: str
    controller: str | None = None          #: FMU name of the controller, None for no control
    estimator: str | None = None           #: estimator name, None for the plant's truth
    params: tuple = ()                     #: ((name, value), ...) of the controller on top of its defaults


BEST_TWO = ("Yoon2014DualKF", "Kim2016SteeringEKF")
"""The two hardened estimators with the smallest mean sideslip error on the benchmark (docs/benchmark.md)."""

SOURCES = (
    Source("none"),
    Source("LQR published / truth", "LqrDycController", None, (("control_profile", 0),)),
    Source("LQR / truth", "LqrDycController"),
    *(Source(f"LQR / {e}", "LqrDycController", e) for e in PAPER_METHODS),
    Source("LQR / SideslipFusion", "LqrDycController", "SideslipFusion"),
    Source(f"StabilityController ({BEST_TWO[0]})", "StabilityController", BEST_TWO[0]),
    Source("StabilityController (SideslipFusion)", "StabilityController", "SideslipFusion"),
    Source("ESC / truth", "BaselineEsc"),
    *(Source(f"ESC / {e}", "BaselineEsc", e) for e in BEST_TWO),
)
"""The rows of the evaluation."""


@dataclass(frozen=True)
class ControlCase:
    """A scenario under a condition with a seed, for one row."""

    scenario: str
    condition: str
    seed: int
    source: Source
    params: tuple = ()                     #: controller parameter overrides (tuning)
    overrides: tuple = ()                  #: scenario overrides


QUICK_FACTORS = (3.5, 5.0, 6.5)
"""FMVSS 126 amplitudes of ``--quick``: the first the uncontrolled SUV fails, the first with the
displacement criterion, the largest."""


def with_controller_params(case: ControlCase, params) -> ControlCase:
    """The case with the controller parameters ``params`` (``(name, value)`` pairs) its controller has."""
    if not case.source.controller:
        return case
    names = {f.name for f, _ in declared_fields(fmu_spec(case.source.controller).config_class)}
    return dataclasses.replace(case, params=case.params + tuple((k, v) for k, v in params if k in names))


def fmvss_names(factors=FMVSS_FACTORS, directions=("", "_right"), family: str = FMVSS_FAMILY) -> list[str]:
    """Scenario names of the FMVSS 126 runs."""
    return [f"{family}_a{f:.1f}{d}" for f in factors for d in directions]


def control_cases(sources=SOURCES, conditions=CONDITIONS, seeds=2, factors=FMVSS_FACTORS, directions=("", "_right"),
                  scenarios=SCENARIOS) -> list[ControlCase]:
    """Every scenario x condition x seed x row."""
    names = [*fmvss_names(factors, directions), *scenarios]
    return [ControlCase(n, c, s, src) for n in names for c in conditions for s in range(seeds) for src in sources]


def steer_times(scenario) -> tuple[float, float, float]:
    """Beginning of steer, completion of steer [s] and sine frequency [Hz] of a sine-with-dwell scenario
    (from its maneuver, so that overrides such as ``maneuver_t_start`` are followed)."""
    man = parse_maneuver(scenario.maneuver)
    return man.t_start, man.completion_of_steer, man.frequency


def scenario_mu(scenario) -> float:
    """Friction of a scenario for the controller: its ``mu`` hint, else its road friction (of a time table
    ``"t0:v0, t1:v1, ..."``, the highest: the controller is set for the road at its best)."""
    if "mu" in scenario.hints:
        return float(scenario.hints["mu"])
    return max(float(item.rpartition(":")[2]) for item in str(scenario.road_mu).split(","))


def fmvss126_metrics(a: dict, t_bos: float, t_cos: float, factor: float, frequency: float = 0.7) -> dict:
    """FMVSS 126 yaw-stability and responsiveness measures of one sine-with-dwell run.

    Parameters
    ----------
    a : dict
        Arrays ``time``, ``plant.yaw_rate``, ``plant.X``, ``plant.Y``, ``plant.yaw``,
        ``driver.delta_sw``.
    t_bos, t_cos : float
        Beginning and completion of steer [s].
    factor : float
        Amplitude in multiples of A (the displacement criterion applies from 5A).
    frequency : float
        Frequency of the sine [Hz] (0.7 in S7.7).
    """
    t, r, dsw = a["time"], a["plant.yaw_rate"], a["driver.delta_sw"]
    i_bos, i_cos = np.searchsorted(t, t_bos), np.searchsorted(t, t_cos)
    # direction of the first half-wave: handwheel at its first peak (a quarter period after the
    # beginning of steer) against the handwheel at the beginning (the driver may hold a small trim)
    first = np.sign(np.interp(t_bos + 0.25 / frequency, t, dsw) - np.interp(t_bos, t, dsw))
    i_rev = i_bos + int(np.argmax(np.sign(dsw[i_bos:i_cos]) == -first))   # steering wheel changes sign
    window = r[i_rev:i_cos + 1]
    peak = float(window[np.argmax(np.abs(window))])
    r100 = float(np.interp(t_cos + 1.00, t, r)) / peak
    r175 = float(np.interp(t_cos + 1.75, t, r)) / peak
    x0, y0, yaw0 = (float(np.interp(t_bos, t, a[k])) for k in ("plant.X", "plant.Y", "plant.yaw"))
    x1, y1 = (float(np.interp(t_bos + 1.07, t, a[k])) for k in ("plant.X", "plant.Y"))
    lateral = first * (-(x1 - x0) * math.sin(yaw0) + (y1 - y0) * math.cos(yaw0))
    yaw_ok = r100 < 0.35 and r175 < 0.20
    lat_ok = lateral >= 1.83 or factor < 5.0
    return {"yaw_rate_ratio_1s": r100, "yaw_rate_ratio_1p75s": r175, "lateral_1p07s": float(lateral),
            "yaw_stable": bool(yaw_ok), "responsive": bool(lat_ok), "pass": bool(yaw_ok and lat_ok)}


def control_metrics(a: dict, vehicle: VehicleParams, mu: float, Mz_max: float | None = None, v_min: float = 5.0,
                    Ts: float = 1e-3) -> dict:
    """Tracking, effort and smoothness of one run.

    Parameters
    ----------
    a : dict
        Arrays ``time``, ``plant.{vx,beta,yaw_rate,Mz_act}``, ``driver.delta_f`` and, with a
        controller, ``controller.Mz_cmd``.
    vehicle : VehicleParams
        The plant's vehicle (the reference model's; the motors' limit).
    mu : float
        Friction of the reference model.
    Mz_max : float, optional
        The controller's limit (default: the vehicle's motors).

    Returns
    -------
    dict
        ``max_abs_beta_deg``, ``rms_yaw_rate_error_deg_s``, ``rms_beta_error_deg``, ``effort_Nms``
        (``int |Mz_act| dt``), ``max_abs_Mz``, ``saturated_pct``, ``rms_Mz_cmd``, ``rms_dMz_dt`` and
        ``max_dMz_dt`` [N m/s], ``max_counter_Mz_launch`` (the largest moment against the driver's
        steering while the car accelerates to 95 % of its top speed) - all while ``v > v_min``.
    """
    cfg = LqrDycConfig()
    model = BicycleModel.from_vehicle(vehicle, mu, nominal=True)
    ref = ReferenceModel(model, cfg.tau_beta, cfg.tau_gamma, Ts, mu)
    vx, delta = a["plant.vx"], a["driver.delta_f"]
    beta_ref, gamma_ref = np.empty_like(vx), np.empty_like(vx)
    for k, (d, v) in enumerate(zip(delta.tolist(), vx.tolist())):
        beta_ref[k], gamma_ref[k] = ref.step(d, max(v, v_min))
    mask = vx > v_min
    mz_act = np.abs(a["plant.Mz_act"])
    dt = float(a["time"][1] - a["time"][0])
    cmd = np.asarray(a.get("controller.Mz_cmd", np.zeros_like(vx)), dtype=float)
    rate = np.diff(cmd, prepend=cmd[0]) / dt
    limit = Mz_max or yaw_moment_limit(vehicle)
    launch = np.arange(len(vx)) < int(np.argmax(vx >= 0.95 * vx.max()))
    steer = np.abs(delta) > 0.005
    counter = -np.sign(delta) * cmd
    rms = lambda x: float(np.sqrt(np.mean(x ** 2))) if x.size else 0.0          # noqa: E731
    return {"max_abs_beta_deg": float(np.max(np.abs(a["plant.beta"][mask])) * _DEG),
            "rms_yaw_rate_error_deg_s": rms((a["plant.yaw_rate"] - gamma_ref)[mask]) * _DEG,
            "rms_beta_error_deg": rms((a["plant.beta"] - beta_ref)[mask]) * _DEG,
            "effort_Nms": float(mz_act.sum() * dt), "max_abs_Mz": float(mz_act.max()),
            "saturated_pct": 100.0 * float(np.mean(np.abs(cmd[mask]) >= 0.999 * limit)),
            "rms_Mz_cmd": rms(cmd[mask]), "rms_dMz_dt": rms(rate[mask]), "max_dMz_dt": float(np.max(np.abs(rate))),
            "max_counter_Mz_launch": float(max(0.0, np.max(counter[launch & steer], initial=0.0)))}


# ---------------------------------------------------------------------------------------- one case
_FIELDS = ("plant.yaw_rate", "plant.beta", "plant.vx", "plant.X", "plant.Y", "plant.yaw", "plant.Mz_act",
           "driver.delta_f", "driver.delta_sw")


def _hardened(estimator: str) -> dict:
    """``{"profile": 1}`` for an estimator with a hardened profile (the papers' methods), else nothing."""
    from ..estimators import ESTIMATORS
    names = {f.name for f, _ in declared_fields(ESTIMATORS[estimator].config_class)}
    return {"profile": 1} if "profile" in names else {}


def _controller_values(case: ControlCase, s, sc) -> dict:
    """Parameters of the case's controller (without its vehicle)."""
    src = case.source
    values = {"mu": scenario_mu(sc), "yaw_rate_source": 1, **dict(src.params), **dict(case.params)}
    if src.controller == "StabilityController":
        values.update(estimator=src.estimator, estimator_profile=1)
    return values


def _library(case: ControlCase, s, duration: float) -> dict:
    from ..control.dyc import LqrDycController
    from ..control.esc import BaselineEsc
    from ..control.stability import StabilityController

    sc = s.scenario
    driver = Driver(build(DriverConfig, sc.driver_params()))
    plant = VehiclePlant(build(PlantConfig, s.plant))
    sensors = SensorSuite(build(SensorConfig, s.sensors))
    src, chain, links = case.source, [], {}
    if src.controller:
        cls = {"LqrDycController": LqrDycController, "BaselineEsc": BaselineEsc,
               "StabilityController": StabilityController}[src.controller]
        ctl = cls(build(cls.config_class, _controller_values(case, s, sc)), vehicle=s.estimator_vehicle)
        wiring = {"beta_hat": "plant.beta", "vx_hat": "plant.vx", "yaw_rate_hat": "plant.yaw_rate"}
        if src.estimator and src.controller != "StabilityController":
            est = make_estimator(Row(src.estimator, src.estimator, tuple(_hardened(src.estimator).items())), s)
            chain.append(("est", est, {"Mz_cmd": "controller.Mz_cmd"}))
            wiring = {"beta_hat": "est.beta_hat", "vx_hat": "est.vx_hat", "yaw_rate_hat": "est.yaw_rate_hat",
                      "beta_valid": "est.valid"}
        chain.append(("controller", ctl, wiring))
        links = {"Mz_dyc": "controller.Mz_cmd"}
    raw = run_loop(plant, driver, duration, 1e-3, sensors, chain=chain, links=links)
    out = {"time": raw["time"]}
    for key in _FIELDS:
        out[key] = raw[key.split(".", 1)[1]]
    out.update({k: v for k, v in raw.items() if k.startswith("controller.")})
    return out


def _fmpy(case: ControlCase, s, duration: float, fmu_dir) -> dict:
    from .runs import run_scenario

    sc, src = s.scenario, case.source
    params = {**{f"sensors.{k}": v for k, v in s.sensors.items()}, **{f"plant.{k}": v for k, v in s.plant.items()}}
    diff = {k: v for k, v in dataclasses.asdict(s.estimator_vehicle).items()
            if dataclasses.asdict(s.vehicle)[k] != v}
    overrides = format_assignments({**parse_assignments(sc.vehicle_overrides, "vehicle_overrides"), **diff})
    estimators = []
    if src.controller:
        params.update({f"controller.{k}": v for k, v in _controller_values(case, s, sc).items()})
        params["controller.vehicle_overrides"] = overrides
        if src.estimator and src.controller != "StabilityController":
            estimators = [src.estimator]
            params.update({f"{src.estimator}.{k}": v for k, v in _hardened(src.estimator).items()})
            params[f"{src.estimator}.vehicle_overrides"] = overrides
    fields = _FIELDS + tuple(f"controller.{n}" for n in (fmu_spec(src.controller).outputs if src.controller else ()))
    source = estimators[0] if estimators else ("truth" if src.controller else None)
    run = run_scenario(sc, estimators, src.controller, duration=duration, fmu_dir=fmu_dir, params=params,
                       control_source=source)
    return {"time": np.asarray(run.results["time"], dtype=float),
            **{f: np.asarray(run.results[f], dtype=float) for f in fields}}


def simulate_control(case: ControlCase, engine: str = "library", fmu_dir=DEFAULT_OUT) -> dict:
    """The arrays of one closed loop (``time`` and ``plant.*``, ``driver.*``, ``controller.*`` fields)."""
    s = setup(Case(case.scenario, case.condition, case.seed), dict(case.overrides))
    duration = s.scenario.duration if case.overrides else DURATION.get(case.scenario, s.scenario.duration)
    if engine == "library":
        return _library(case, s, duration)
    if engine == "fmpy":
        return _fmpy(case, s, duration, fmu_dir)
    raise ValueError(f"engine {engine!r}: use 'library' or 'fmpy'")


def run_control_case(item) -> dict:
    """Metrics of one case: ``item`` is ``(case, engine, fmu_dir)`` (a job of :func:`control_evaluation`).

    Returns
    -------
    dict
        :func:`control_metrics`, plus the FMVSS 126 measures for a sine with dwell, ``factor`` (its
        amplitude in multiples of A, else None), ``wall_seconds`` and ``sim_seconds``.
    """
    case, engine, fmu_dir = item
    t0 = time.perf_counter()
    a = simulate_control(case, engine, fmu_dir)
    s = setup(Case(case.scenario, case.condition, case.seed), dict(case.overrides))
    row = control_metrics(a, s.vehicle, scenario_mu(s.scenario))
    row["factor"] = None
    if case.scenario.startswith("fmvss126_") and "_a" in case.scenario:
        row["factor"] = float(case.scenario.split("_a")[-1].split("_")[0])
        t_bos, t_cos, freq = steer_times(s.scenario)
        if t_cos + 1.75 <= a["time"][-1]:
            row.update(fmvss126_metrics(a, t_bos, t_cos, row["factor"], freq))
    row.update(wall_seconds=time.perf_counter() - t0, sim_seconds=float(a["time"][-1]))
    return row


def control_evaluation(cases, engine: str = "library", fmu_dir=DEFAULT_OUT, workers: int = 2, scheduler=None,
                       progress: bool = True) -> list[dict]:
    """Run cases (:func:`control_cases`) in parallel (:mod:`sideslip.studies.jobs`); per case, in order,
    the :func:`run_control_case` metrics with ``scenario``, ``condition``, ``seed`` and ``source``."""
    if engine == "fmpy":
        from ..fmi.build import ensure_fmus
        from ..cosim.assembly import DRIVER, PLANT, SENSORS
        names = {c.source.controller for c in cases if c.source.controller}
        names |= {c.source.estimator for c in cases
                  if c.source.estimator and c.source.controller != "StabilityController"}
        ensure_fmus(sorted(names | {DRIVER, PLANT, SENSORS}), fmu_dir)
    rows = map_ordered(run_control_case, [(c, engine, str(fmu_dir)) for c in cases], workers, scheduler, progress,
                       "closed loops")
    return [{"scenario": c.scenario, "condition": c.condition, "seed": c.seed, "source": c.source.label, **r}
            for c, r in zip(cases, rows)]


def plot_example(out_dir, fmu_dir=DEFAULT_OUT, scenario: str = f"{FMVSS_FAMILY}_a5.0"):
    """Write ``control_split.png``: the command split into its parts on FMVSS 126 at 5A (``sensors+mismatch``,
    seed 0) for the LQR as published, the drivable LQR with the band-limited feed-forward and without it
    (the default), and the baseline ESC, all on the true sideslip."""
    from pathlib import Path

    from .plots import plot_command_split

    rows = {"LQR as published (feed-forward tau_ff 20 ms)": Source("a", "LqrDycController", None,
                                                                  (("control_profile", 0),)),
            "LQR drivable, feed-forward on (f_ff 2 Hz)": Source("b", "LqrDycController", None, (("feedforward", 1),)),
            "LQR drivable (default: no feed-forward)": Source("c", "LqrDycController"),
            "baseline ESC": Source("d", "BaselineEsc")}
    runs = {label: simulate_control(ControlCase(scenario, "sensors+mismatch", 0, src), "library", fmu_dir)
            for label, src in rows.items()}
    return plot_command_split(runs, Path(out_dir) / "control_split.png",
                              f"{scenario}, sensors+mismatch, seed 0, true sideslip")


# ---------------------------------------------------------------------------------------- tables
_MEANS = ("max_abs_beta_deg", "rms_yaw_rate_error_deg_s", "rms_beta_error_deg", "effort_Nms", "saturated_pct",
          "rms_Mz_cmd", "rms_dMz_dt", "max_dMz_dt", "max_counter_Mz_launch")


def summarise(rows: list[dict]) -> dict:
    """Aggregate over seeds: ``{condition: {scenario_or_family: {source: {...}}}}``.

    Every metric is given as ``[mean, min, max]`` over the seeds.  The FMVSS family entry of a row
    holds ``passes`` (seeds where it passes every amplitude at which the uncontrolled car fails, in
    the same condition and seed), ``seeds``, ``failed`` (amplitudes failed in some seed), the worst
    yaw-rate ratios and smallest displacement, and the other metrics' worst (max |beta|, saturated,
    max rate) or mean values over the runs.
    """
    out: dict = {}
    fam_runs: dict = {}
    for r in rows:
        if r["factor"] is not None and "pass" in r:
            fam = r["scenario"].split("_a")[0]
            fam_runs.setdefault((r["condition"], fam, r["source"], r["seed"]), []).append(r)
        else:
            out.setdefault(r["condition"], {}).setdefault(r["scenario"], {}).setdefault(r["source"], []).append(r)
    for cond, scen in out.items():
        for name, by_src in scen.items():
            for src, rs in by_src.items():
                by_src[src] = {k: [float(np.mean(v)), float(np.min(v)), float(np.max(v))]
                               for k in _MEANS for v in [[x[k] for x in rs]]}
    none_fails = {(c, f, s): {r["scenario"].split(f + "_")[1] for r in rs if not r["pass"]}
                  for (c, f, src, s), rs in fam_runs.items() if src == "none"}
    fams: dict = {}
    for (cond, fam, src, seed), rs in sorted(fam_runs.items(), key=lambda kv: kv[0][3]):
        failed = {r["scenario"].split(fam + "_")[1] for r in rs if not r["pass"]}
        must = none_fails.get((cond, fam, seed), set())
        e = fams.setdefault((cond, fam, src), {"passes": 0, "seeds": 0, "failed": set(), "runs": []})
        e["seeds"] += 1
        e["passes"] += int(not (failed & must)) if src != "none" else int(not failed)
        e["failed"] |= failed
        e["runs"] += rs
    for (cond, fam, src), e in fams.items():
        rs = e.pop("runs")
        e["failed"] = sorted(e["failed"], key=lambda n: (float(n.split("_")[0][1:]), n))
        e.update(yaw_rate_ratio_1s=max(r["yaw_rate_ratio_1s"] for r in rs),
                 yaw_rate_ratio_1p75s=max(r["yaw_rate_ratio_1p75s"] for r in rs),
                 lateral_1p07s=min((r["lateral_1p07s"] for r in rs if r["factor"] >= 5.0), default=float("nan")),
                 **{k: max(r[k] for r in rs) for k in ("max_abs_beta_deg", "saturated_pct", "max_dMz_dt")},
                 **{k: float(np.mean([r[k] for r in rs])) for k in
                    ("rms_yaw_rate_error_deg_s", "rms_beta_error_deg", "effort_Nms", "rms_dMz_dt")})
        out.setdefault(cond, {}).setdefault(fam, {})[src] = e
    return out


def _mmm(v, fmt="{:.2f}") -> str:
    mean, lo, hi = v
    return fmt.format(mean) + (f" ({fmt.format(lo)}-{fmt.format(hi)})" if hi - lo > 1e-9 else "")


def format_control_evaluation(summary: dict) -> str:
    """Markdown tables of :func:`summarise` (mean over seeds, the range in brackets)."""
    out = []
    for cond, scen in summary.items():
        for name, rows in scen.items():
            if name.startswith("fmvss126_"):
                out += [f"**FMVSS 126 sine with dwell, {name}, {cond}** (every amplitude 1.5A-6.5A, both directions; "
                        "worst values over amplitudes and seeds)", "",
                        "| row | passes where uncontrolled fails | r(1.00 s) | r(1.75 s) | lateral 1.07 s [m] | "
                        "max abs beta [deg] | RMS yaw-rate err [deg/s] | RMS beta err [deg] | effort [kN m s] | "
                        "saturated [%] | RMS dMz/dt [kN m/s] | max dMz/dt [kN m/s] | failed |",
                        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
                for src, r in rows.items():
                    passes = f"{r['passes']} of {r['seeds']} seeds" if src != "none" else (
                        f"passes all in {r['passes']} of {r['seeds']}")
                    failed = ", ".join(r["failed"][:6]) + (" ..." if len(r["failed"]) > 6 else "")
                    out.append(f"| {src} | {passes} | {100 * r['yaw_rate_ratio_1s']:.1f} % | "
                               f"{100 * r['yaw_rate_ratio_1p75s']:.1f} % | {r['lateral_1p07s']:.2f} | "
                               f"{r['max_abs_beta_deg']:.1f} | {r['rms_yaw_rate_error_deg_s']:.2f} | "
                               f"{r['rms_beta_error_deg']:.2f} | {r['effort_Nms'] / 1e3:.2f} | "
                               f"{r['saturated_pct']:.1f} | {r['rms_dMz_dt'] / 1e3:.1f} | "
                               f"{r['max_dMz_dt'] / 1e3:.1f} | {failed} |")
                out.append("")
                continue
            launch = name == LAUNCH
            out += [f"**{name}, {cond}** (mean over seeds, range in brackets)", "",
                    "| row | max abs beta [deg] | RMS yaw-rate err [deg/s] | RMS beta err [deg] | effort [kN m s] | "
                    "saturated [%] | RMS Mz_cmd [N m] | RMS dMz/dt [kN m/s] | max dMz/dt [kN m/s] |"
                    + (" max Mz against the steer, launch [N m] |" if launch else ""),
                    "|---|---:|---:|---:|---:|---:|---:|---:|---:|" + ("---:|" if launch else "")]
            for src, r in rows.items():
                out.append(f"| {src} | {_mmm(r['max_abs_beta_deg'])} | {_mmm(r['rms_yaw_rate_error_deg_s'])} | "
                           f"{_mmm(r['rms_beta_error_deg'])} | {r['effort_Nms'][0] / 1e3:.2f} | "
                           f"{_mmm(r['saturated_pct'], '{:.1f}')} | {_mmm(r['rms_Mz_cmd'], '{:.0f}')} | "
                           f"{r['rms_dMz_dt'][0] / 1e3:.2f} | {r['max_dMz_dt'][0] / 1e3:.1f} |"
                           + (f" {_mmm(r['max_counter_Mz_launch'], '{:.0f}')} |" if launch else ""))
            out.append("")
    return "\n".join(out)


# ---------------------------------------------------------------------------------------- tuning
TUNING_MANEUVERS = (("fmvss126_suv_mu08_a5.0", {"maneuver_t_start": 1.0, "duration": 5.0}),
                    ("fmvss126_suv_mu08_a6.5_right", {"maneuver_t_start": 1.0, "duration": 5.0}),
                    ("fmvss126_suv_mu05_a6.5", {"maneuver_t_start": 1.0, "duration": 5.0}))
"""The LQR tuning set: three 5-second sine-with-dwell runs (steer from 1 s, so that the 1.75 s
criterion falls inside the 5 s), left and right, mu 0.8 and 0.5."""


def evaluate_weights(item: dict) -> dict:
    """One point of an LQR tuning study: closed loops of FMUs on a maneuver set under realistic sensors.

    Parameters
    ----------
    item : dict
        ``q_beta``, ``q_gamma``, ``q_N`` and optionally ``maneuvers`` (``(scenario, overrides)``
        pairs, default :data:`TUNING_MANEUVERS`), ``source`` (an estimator name, default
        None: the truth), ``condition`` (default ``sensors+mismatch``), ``seed`` (0), ``fmu_dir``,
        ``duration`` (overrides every maneuver's), ``engine`` (``fmpy``, the default, or ``library``).

    Returns
    -------
    dict
        Means over the maneuvers of the :func:`control_metrics` values, ``fmvss_passes`` (how
        many maneuvers meet the FMVSS 126 yaw-rate criteria), ``sim_seconds`` and ``wall_seconds``.
    """
    t0 = time.perf_counter()
    params = tuple((k, item[k]) for k in ("q_beta", "q_gamma", "q_N"))
    est = item.get("source")
    source = Source(f"LQR / {est or 'truth'}", "LqrDycController", est)
    rows = []
    for name, overrides in item.get("maneuvers", TUNING_MANEUVERS):
        overrides = dict(overrides)
        if item.get("duration"):
            overrides["duration"] = item["duration"]
        case = ControlCase(name, item.get("condition", "sensors+mismatch"), item.get("seed", 0), source, params,
                           tuple(overrides.items()))
        rows.append(run_control_case((case, item.get("engine", "fmpy"), item.get("fmu_dir", str(DEFAULT_OUT)))))
    out = {k: float(np.mean([r[k] for r in rows])) for k in _MEANS}
    out.update(fmvss_passes=int(sum(r.get("yaw_stable", False) for r in rows)),
               sim_seconds=float(sum(r["sim_seconds"] for r in rows)), wall_seconds=time.perf_counter() - t0)
    return out
