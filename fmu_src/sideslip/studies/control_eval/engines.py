"""One closed loop of a case, in-process (the library) or with the FMUs (fmpy), and the cases in parallel."""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ...fmi.build import DEFAULT_OUT
from ...fmi.catalogue import fmu_spec
from ...params import build, declared_fields, format_assignments, parse_assignments
from ...plant.driver import Driver, DriverConfig
from ...plant.commonroad import CommonRoadConfig, CommonRoadPlant
from ...plant.loop import run_loop
from ...plant.sensors import SensorConfig, SensorSuite
from ...plant.vehicle import PlantConfig, VehiclePlant
from ...scenarios import scenario_duration
from ..accuracy import Case, Row, make_estimator, setup
from ..drives import OWN, vehicle_set
from ..jobs import map_ordered
from .cases import DURATION, FMVSS_FAMILY, PUBLISHED_VALUES, ControlCase, Source, scenario_mu, steer_times
from .measures import control_metrics, fmvss126_metrics


_FIELDS = ("plant.yaw_rate", "plant.beta", "plant.vx", "plant.X", "plant.Y", "plant.yaw", "plant.Mz_act",
           "driver.delta_f", "driver.delta_sw")


def _hardened(estimator: str) -> dict:
    """``{"profile": 1}`` for an estimator with a hardened profile (the papers' methods), else nothing."""
    from ...estimators import ESTIMATORS
    names = {f.name for f, _ in declared_fields(ESTIMATORS[estimator].config_class)}
    return {"profile": 1} if "profile" in names else {}


def _controller_values(case: ControlCase, s, sc) -> dict:
    """Parameters of the case's controller (without its vehicle): the case's on top of the defaults, the row's on
    top of them (what makes a row, e.g. ``friction_source = 1``, stays under a tuned parameter file)."""
    src = case.source
    values = {"mu": scenario_mu(sc), "yaw_rate_source": 1, **dict(case.params), **dict(src.params)}
    if src.controller == "StabilityController":
        values.update(estimator=src.estimator, estimator_profile=1)
    return values


def _library(case: ControlCase, s, duration: float) -> dict:
    from ...control.dyc import LqrDycController
    from ...control.esc import BaselineEsc
    from ...control.stability import StabilityController

    sc = s.scenario
    n = vehicle_set(case.plant)
    # on a CommonRoad car the driver knows it by its identified file (as the estimators and the controller do)
    driver = Driver(build(DriverConfig, sc.driver_params() if n is None else
                          {**sc.driver_params(), **{k: s.driver[k] for k in ("vehicle", "vehicle_overrides")}}))
    plant = (VehiclePlant(build(PlantConfig, {**s.plant, "wheel_slip_max": case.wheel_slip_max})) if n is None
             else CommonRoadPlant(build(CommonRoadConfig, {"vehicle_set": n, **s.plant})))
    sensors = SensorSuite(build(SensorConfig, s.sensors))
    src, chain, links = case.source, [], {}
    if src.controller:
        cls = {"LqrDycController": LqrDycController, "BaselineEsc": BaselineEsc,
               "StabilityController": StabilityController}[src.controller]
        ctl = cls(build(cls.config_class, _controller_values(case, s, sc)), vehicle=s.estimator_vehicle)
        wiring = {"beta_hat": "plant.beta", "vx_hat": "plant.vx", "yaw_rate_hat": "plant.yaw_rate", "mu_hat": "mu"}
        if src.estimator and src.controller != "StabilityController":
            est = make_estimator(Row(src.estimator, src.estimator, tuple(_hardened(src.estimator).items())), s)
            chain.append(("est", est, {"Mz_cmd": "controller.Mz_cmd"}))
            wiring = {"beta_hat": "est.beta_hat", "vx_hat": "est.vx_hat", "yaw_rate_hat": "est.yaw_rate_hat",
                      "beta_valid": "est.valid", "mu_hat": "est.mu_hat", "beta_std": "est.beta_hat_std"}
        chain.append(("controller", ctl, wiring))
        links = {"Mz_dyc": "controller.Mz_cmd"}
    # the CommonRoad model has no answer through a spin: the run ends there ("failure")
    raw = run_loop(plant, driver, duration, 1e-3, sensors, chain=chain, links=links, until_failure=n is not None)
    out = {"time": raw["time"]}
    if "failure" in raw:
        out["failure"] = raw["failure"]
    for key in _FIELDS:
        out[key] = raw[key.split(".", 1)[1]]
    out.update({k: v for k, v in raw.items() if k.startswith("controller.")})
    return out


def _fmpy(case: ControlCase, s, duration: float, fmu_dir) -> dict:
    from ..runs import run_scenario

    if case.plant != OWN:
        raise ValueError(f"the fmpy engine runs the project's plant; {case.plant} runs in the library engine")
    sc, src = s.scenario, case.source
    params = {**{f"sensors.{k}": v for k, v in s.sensors.items()}, **{f"plant.{k}": v for k, v in s.plant.items()},
              "plant.wheel_slip_max": case.wheel_slip_max}
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
    s = setup(Case(case.scenario, case.condition, case.seed, plant=case.plant), dict(case.overrides))
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
    s = setup(Case(case.scenario, case.condition, case.seed, plant=case.plant), dict(case.overrides))
    row = control_metrics(a, s.vehicle, scenario_mu(s.scenario))
    row["factor"] = None
    if "failure" in a:
        row["failure"] = a["failure"]
    if case.scenario.startswith("fmvss126_") and "_a" in case.scenario:
        row["factor"] = float(case.scenario.split("_a")[-1].split("_")[0])
        t_bos, t_cos, freq = steer_times(s.scenario)
        if t_cos + 1.75 <= a["time"][-1]:
            row.update(fmvss126_metrics(a, t_bos, t_cos, row["factor"], freq))
        elif "failure" in a:           # the plant's model gave up in a spin: the run fails the criteria
            row.update(yaw_rate_ratio_1s=math.inf, yaw_rate_ratio_1p75s=math.inf, lateral_1p07s=math.nan,
                       yaw_stable=False, responsive=False)
            row["pass"] = False
    row.update(wall_seconds=time.perf_counter() - t0, sim_seconds=float(a["time"][-1]))
    return row


def control_evaluation(cases, engine: str = "library", fmu_dir=DEFAULT_OUT, workers: int = 2, scheduler=None,
                       progress: bool = True, log=None) -> list[dict]:
    """Run cases (:func:`control_cases`) in parallel (:mod:`sideslip.studies.jobs`); per case, in order,
    the :func:`run_control_case` metrics with ``scenario``, ``condition``, ``seed`` and ``source``.  With ``log``
    (a :class:`~sideslip.studies.jobs.ResultLog`) each case's metrics go to disk as it finishes, and the cases the
    log already holds (same case, same engine) are not run again."""
    if engine == "fmpy":
        from ...fmi.build import ensure_fmus
        from ...cosim.assembly import DRIVER, PLANT, SENSORS
        names = {c.source.controller for c in cases if c.source.controller}
        names |= {c.source.estimator for c in cases
                  if c.source.estimator and c.source.controller != "StabilityController"}
        ensure_fmus(sorted(names | {DRIVER, PLANT, SENSORS}), fmu_dir)
    rows = map_ordered(run_control_case, [(c, engine, str(fmu_dir)) for c in cases], workers, scheduler, progress,
                       "control", weight=lambda item: scenario_duration(item[0].scenario), unit="sim s", log=log,
                       key=lambda item: repr((item[0], item[1])))
    return [{"scenario": c.scenario, "condition": c.condition_label, "seed": c.seed, "source": c.source.label, **r}
            for c, r in zip(cases, rows)]




def plot_example(out_dir, fmu_dir=DEFAULT_OUT, scenario: str = f"{FMVSS_FAMILY}_a5.0"):
    """Write ``control_split.png``: the command split into its parts on FMVSS 126 at 5A (``sensors+mismatch``,
    seed 0) for the LQR as published (the evaluation's published row), the drivable LQR with the band-limited
    feed-forward and without it (the default), and the baseline ESC, all on the true sideslip."""
    from pathlib import Path

    from ..plots import plot_command_split

    rows = {"LQR as published (feed-forward tau_ff 20 ms)": Source("a", "LqrDycController", None, PUBLISHED_VALUES),
            "LQR drivable, feed-forward on (f_ff 2 Hz)": Source("b", "LqrDycController", None, (("feedforward", 1),)),
            "LQR drivable (default: no feed-forward)": Source("c", "LqrDycController"),
            "baseline ESC": Source("d", "BaselineEsc")}
    runs = {label: simulate_control(ControlCase(scenario, "sensors+mismatch", 0, src), "library", fmu_dir)
            for label, src in rows.items()}
    return plot_command_split(runs, Path(out_dir) / "control_split.png",
                              f"{scenario}, sensors+mismatch, seed 0, true sideslip")
