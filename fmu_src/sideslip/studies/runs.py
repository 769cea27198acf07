"""Runs of a scenario: one closed loop of FMUs, many on the job runner, or the library loop without FMI.

* :func:`run_scenario` - a scenario's loop (:func:`~sideslip.cosim.assembly.scenario_components`)
  on the fmpy, the libcosim or the OMSimulator master, with the estimators' metrics and, optionally, the files
  ``results.csv``, ``metrics.json`` and ``sideslip.png``;
* :func:`run_jobs` - many such runs on :mod:`sideslip.studies.jobs` (the FMUs built once first);
* :func:`run_library` - the same loop with the library classes instead of FMUs.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..cosim.assembly import DRIVER, PLANT, SENSORS, estimator_instances, scenario_components
from ..cosim.master import CoSimulation
from ..cosim.results import Results
from ..fmi.build import DEFAULT_OUT, ensure_fmus
from ..scenarios import Scenario, get_scenario, scenario_params
from .jobs import map_ordered
from .metrics import command_metrics, estimate_metrics, format_command_table, format_table, scenario_summary

__all__ = ["run_scenario", "run_jobs", "run_library", "RunOutput"]


@dataclass
class RunOutput:
    """Results of :func:`run_scenario` and the metrics written to ``metrics.json``."""

    results: Results
    metrics: dict

    def table(self) -> str:
        """Metrics tables of the estimators and the controller (empty string without either)."""
        tables = [format_table(self.metrics["estimators"])] if self.metrics["estimators"] else []
        if "controller" in self.metrics:
            c = self.metrics["controller"]
            tables.append(format_command_table(f"{c['name']} ({c['source']})", c))
        return "\n\n".join(tables)


def run_scenario(scenario: str | Scenario, estimators=(), controller: str | None = None,
                 out_dir: str | Path | None = None, duration: float | None = None, step: float = 1e-3,
                 record_every: int = 1, fmu_dir: str | Path = DEFAULT_OUT, params: dict | None = None,
                 overrides: dict | None = None, control_source: str | None = None, progress=None,
                 master: str = "fmpy", scheme: str = "gauss-seidel", window: tuple | None = None,
                 formats: tuple = ("csv",)) -> RunOutput:
    """Run a scenario and (optionally) write ``results.csv``, ``metrics.json``, ``sideslip.png``.

    Parameters
    ----------
    scenario : str or Scenario
        Registry name or object.
    estimators, controller, params, control_source
        See :func:`~sideslip.cosim.assembly.scenario_components`.
    out_dir : path, optional
        Where to write the files; nothing is written when omitted.
    duration : float, optional
        Overrides the scenario duration [s].
    step : float
        Communication step [s].
    record_every : int
        Record every n-th step.
    overrides : dict, optional
        Scenario overrides (``maneuver_<key>``, ``sensor_<key>``, fields).
    master : {"fmpy", "libcosim", "omsimulator"}
        The project's fmpy master, DNV's libcosim (:mod:`sideslip.cosim.libcosim_master`) or
        OpenModelica's OMSimulator (:mod:`sideslip.cosim.omsimulator_master`, numeric parameters
        only); both Jacobi, every step recorded, rows from ``t = step``.
    scheme : {"gauss-seidel", "jacobi"}
        Coupling scheme of the fmpy master (libcosim is always Jacobi).
    window : (float, float), optional
        Time span [s] the metrics and the plot cover (the run and ``results.csv`` cover the whole duration).
    formats : tuple of {"csv", "mf4"}
        The files of the results: ``results.csv`` (with ``results.csv.units.json``) and ``results.mf4`` (MDF4,
        asammdf).

    Notes
    -----
    A run with a controller adds its figures (:func:`~sideslip.studies.metrics.command_metrics`) to
    ``metrics["controller"]`` and a panel to the plot.
    """
    sc = get_scenario(scenario, **(overrides or {})) if isinstance(scenario, str) else scenario
    comps, conns = scenario_components(sc, estimators, controller, params, control_source)
    estimators = [inst for inst, _ in estimator_instances(estimators)]
    run_for = duration if duration is not None else sc.duration
    t0 = time.perf_counter()
    if master == "libcosim":
        from ..cosim.libcosim_master import run_libcosim

        res = run_libcosim(comps, conns, duration=run_for, step=step, fmu_dir=fmu_dir)
    elif master == "omsimulator":
        from ..cosim.omsimulator_master import run_omsimulator

        res = run_omsimulator(comps, conns, duration=run_for, step=step, fmu_dir=fmu_dir)
    elif master == "fmpy":
        with CoSimulation(comps, conns, step=step, record_every=record_every, fmu_dir=fmu_dir, scheme=scheme) as sim:
            res = sim.run(run_for, progress=progress)
    else:
        raise ValueError(f"master must be 'fmpy', 'libcosim' or 'omsimulator', got {master!r}")
    wall = time.perf_counter() - t0
    scored = res.window(*window) if window else res
    metrics = {"scenario": {"name": sc.name, "description": sc.description, "source": sc.source,
                            "vehicle": sc.vehicle, "maneuver": sc.maneuver, "road_mu": sc.road_mu,
                            "road_bank": sc.road_bank, "notes": list(sc.notes)},
               "summary": scenario_summary(scored),
               "estimators": {e: estimate_metrics(scored, e) for e in estimators},
               "window": list(window) if window else None,
               "master": res.meta["master"], "scheme": res.meta["scheme"],
               "wall_time": wall, "simulation_wall_time": res.meta["wall_time"],
               "real_time_factor": res.meta["real_time_factor"], "us_per_step": res.meta["us_per_step"],
               "step": step, "components": res.meta["components"], "connections": res.meta["connections"],
               "unconnected_inputs": res.meta["unconnected_inputs"],
               "messages": res.meta["messages"][:200]}
    if controller:
        from ..control.base import yaw_moment_limit
        from ..vehicles import load_vehicle

        limit = yaw_moment_limit(load_vehicle(sc.vehicle, sc.vehicle_overrides))
        metrics["controller"] = {"name": controller, "source": control_source or (estimators[0] if estimators
                                                                                   else "truth"),
                                 **command_metrics(scored, limit)}
    if out_dir is not None:
        from .plots import plot_sideslip

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        if "csv" in formats:
            res.to_csv(out / "results.csv")
        if "mf4" in formats:
            res.to_mdf(out / "results.mf4")
        (out / "metrics.json").write_text(json.dumps(metrics, indent=2))
        plot_sideslip(scored, list(estimators), out / "sideslip.png", title=f"{sc.name}: {sc.description}",
                      controller="controller" if controller else None)
    return RunOutput(res, metrics)


def _job(args):
    """One closed-loop run in a worker: metrics plus the requested recorded fields."""
    scenario, estimators, overrides, params, fields, fmu_dir, duration, options = args
    run = run_scenario(scenario, estimators, fmu_dir=fmu_dir, overrides=overrides, params=params,
                       duration=duration, **options)
    res = run.results
    return run.metrics, {f: np.asarray(res[f], dtype=float) for f in ("time", *fields)}


def run_jobs(jobs, fmu_dir=DEFAULT_OUT, workers: int = 2, scheduler=None, as_published: bool = False) -> list:
    """Run ``(scenario, estimators, overrides, params, fields[, duration[, options]])`` jobs in parallel.

    ``options`` are more keyword arguments of :func:`run_scenario` (``controller``,
    ``control_source``).  The FMUs are built (if out of date) before the workers start.  ``as_published``
    gives every estimator ``consistency_check = false`` (a job's own ``params`` win): its
    ``valid`` is the method's own, as the papers' tables score it
    (:class:`~sideslip.estimators.profiles.ProfiledEstimator`).

    Returns
    -------
    list of (dict, dict)
        Per job, in order: the run's metrics and ``{field: array}`` of ``fields``.
    """
    names = {inst_fmu[1] for job in jobs for inst_fmu in estimator_instances(job[1])} | {PLANT, SENSORS, DRIVER}
    names |= {job[6]["controller"] for job in jobs if len(job) > 6 and job[6].get("controller")}
    ensure_fmus(sorted(names), fmu_dir)
    if as_published:
        jobs = [(*job[:3], {**_own_flags(job[1]), **(job[3] or {})}, *job[4:]) for job in jobs]
    args = [(*job[:5], str(fmu_dir), job[5] if len(job) > 5 else None, job[6] if len(job) > 6 else {})
            for job in jobs]
    return map_ordered(_job, args, workers, scheduler)


def _own_flags(estimators) -> dict:
    """``consistency_check = false`` for each estimator instance."""
    return {f"{inst}.consistency_check": False for inst, _ in estimator_instances(estimators)}


def run_library(scenario: str | Scenario, estimators=(), duration: float | None = None, step: float = 1e-3,
                overrides: dict | None = None, params: dict | None = None) -> dict:
    """The closed loop of :func:`run_scenario` with the library classes instead of FMUs (no FMI).

    Parameters
    ----------
    estimators : iterable of str or Estimator, or dict of name -> model
        Estimator class names of :data:`sideslip.estimators.ESTIMATORS` (configured from the
        scenario like the FMUs), ready instances (named by their class), or ready models by
        instance name.
    params : dict, optional
        ``{"<estimator>.<parameter>": value}`` overrides.

    Returns
    -------
    dict
        Arrays by ``<instance>.<signal>`` (instances ``driver``, ``plant``, ``sensors`` and
        the estimators), plus ``time``: the layout of :class:`Results`.
    """
    from ..estimators import ESTIMATORS
    from ..params import build
    from ..plant.driver import Driver, DriverConfig
    from ..plant.loop import run_loop
    from ..plant.sensors import SensorConfig, SensorSuite
    from ..plant.vehicle import PlantConfig, VehiclePlant

    sc = get_scenario(scenario, **(overrides or {})) if isinstance(scenario, str) else scenario
    observers = dict(estimators) if isinstance(estimators, dict) else {}
    for e in () if isinstance(estimators, dict) else estimators:
        if isinstance(e, str):
            if e not in ESTIMATORS:
                raise KeyError(f"unknown estimator {e!r}; estimators: {', '.join(sorted(ESTIMATORS))}")
            cls = ESTIMATORS[e]
            values = scenario_params(cls.config_class, sc)
            values.update({k.split(".", 1)[1]: v for k, v in (params or {}).items() if k.startswith(e + ".")})
            e = cls(build(cls.config_class, values))
        observers[type(e).__name__] = e
    driver = Driver(build(DriverConfig, sc.driver_params()))
    plant = VehiclePlant(build(PlantConfig, sc.plant_params()))
    sensors = SensorSuite(build(SensorConfig, sc.sensor_params()))
    raw = run_loop(plant, driver, duration if duration is not None else sc.duration, step, sensors, observers)
    out = {"time": raw.pop("time")}
    owner = {**{n: "driver" for n in driver.output_names}, **{n: "plant" for n in plant.output_names},
             **{n: "sensors" for n in sensors.output_names}}
    for key, value in raw.items():
        out[key if "." in key else f"{owner[key]}.{key}"] = value
    return out
