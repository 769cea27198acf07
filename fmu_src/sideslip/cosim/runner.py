"""Run a named scenario in closed loop: driver, plant, sensors, estimators, controller.

Estimators and controllers are FMUs of the registry (``role = "estimator"`` /
``"controller"``); each receives the scenario's vehicle and every scenario hint that matches
one of its parameters (``Ts``, ``mu``, ...), so adding an estimator to a run is naming it.
When several estimators run, the first one feeds the controller unless told otherwise.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

from ..fmi.build import DEFAULT_OUT
from ..fmi.registry import fmu_entry, fmu_names
from ..params import declared_fields
from .master import Component, CoSimulation, Results
from .metrics import estimate_metrics, format_table, scenario_summary
from .scenarios import Scenario, get_scenario

__all__ = ["scenario_components", "scenario_params", "run_scenario", "run_library", "RunOutput"]

PLANT, SENSORS, DRIVER = "VehiclePlant", "VehicleSensors", "ManeuverDriver"
TRUTH_SOURCE = {"beta": "beta_hat", "vx": "vx_hat"}
"""Plant truth -> controller input when the controller runs on the true sideslip (``control_source="truth"``)."""


_CALIBRATION = ("mag_inclination", "mag_declination")
"""Sensor parameters an estimator with a parameter of the same name takes over from the scenario."""


def scenario_params(config_class, scenario: Scenario) -> dict:
    """Parameters a model with ``config_class`` takes from the scenario: its vehicle, the Earth field
    of its magnetometer (a calibration, like the vehicle parameters) and its hints."""
    names = {f.name for f, _ in declared_fields(config_class)}
    params = {"vehicle": scenario.vehicle} if "vehicle" in names else {}
    if "vehicle_overrides" in names and scenario.vehicle_overrides:
        params["vehicle_overrides"] = scenario.vehicle_overrides
    params.update({k: v for k, v in scenario.sensors.items() if k in _CALIBRATION and k in names})
    params.update({k: v for k, v in scenario.hints.items() if k in names})
    return params


def _auto_params(fmu: str, scenario: Scenario) -> dict:
    """Parameters an estimator/controller FMU takes from the scenario (vehicle and hints)."""
    return scenario_params(fmu_entry(fmu).slave_class.config_class, scenario)


def estimator_instances(estimators) -> list[tuple[str, str]]:
    """``(instance, FMU name)`` of estimator specs ``"FMU"`` or ``"instance=FMU"``."""
    return [tuple(e.split("=", 1)) if "=" in e else (e, e) for e in estimators]


def scenario_components(scenario: Scenario, estimators=(), controller: str | None = None,
                        params: dict | None = None, control_source: str | None = None):
    """Components and explicit connections of a scenario run.

    Parameters
    ----------
    scenario : Scenario
    estimators : iterable of str
        Estimator FMU names (instance name = FMU name), or ``"instance=FMU"`` to run one FMU
        several times under different names (e.g. ``"srkf=Nguyen2012DACMRKF"``).
    controller : str, optional
        Controller FMU name (instance ``controller``).
    params : dict, optional
        ``{"instance.parameter": value}`` overrides of FMU parameters.
    control_source : str, optional
        Estimator instance feeding the controller (default: the first), or ``"truth"``: the
        plant's true ``beta`` and ``vx`` (the default without estimators).

    Returns
    -------
    list of Component, list of (str, str)
    """
    pairs = estimator_instances(estimators)
    estimators = [inst for inst, _ in pairs]
    known = set(fmu_names("estimator"))
    for _, fmu in pairs:
        if fmu not in known:
            raise KeyError(f"unknown estimator {fmu!r}; estimators: {', '.join(sorted(known)) or 'none yet'}")
    comps = [Component(DRIVER, "driver", scenario.driver_params()),
             Component(PLANT, "plant", scenario.plant_params()),
             Component(SENSORS, "sensors", scenario.sensor_params())]
    comps += [Component(fmu, inst, _auto_params(fmu, scenario)) for inst, fmu in pairs]
    connections = []
    if controller:
        if controller not in fmu_names("controller"):
            raise KeyError(f"unknown controller {controller!r}; controllers: {', '.join(fmu_names('controller'))}")
        comps.append(Component(controller, "controller", _auto_params(controller, scenario)))
        inputs = set(fmu_entry(controller).inputs)
        source = control_source or (estimators[0] if estimators else "truth")
        if not inputs & set(TRUTH_SOURCE.values()):
            pass                                     # the controller estimates for itself
        elif source == "truth":
            for truth, name in TRUTH_SOURCE.items():
                if name in inputs:
                    connections.append((f"plant.{truth}", f"controller.{name}"))
        elif source not in dict(pairs):
            raise KeyError(f"control source {source!r}: use 'truth' or one of the estimators {', '.join(estimators)}")
        elif len(estimators) > 1:
            for name in inputs & set(fmu_entry(dict(pairs)[source]).outputs):
                connections.append((f"{source}.{name}", f"controller.{name}"))
    for key, value in (params or {}).items():
        inst, _, name = key.partition(".")
        match = [c for c in comps if c.name == inst]
        if not match or not name:
            raise KeyError(f"parameter override {key!r}: use <instance>.<parameter> with instance one of "
                           + ", ".join(c.name for c in comps))
        match[0].parameters[name] = value
    return comps, connections


@dataclass
class RunOutput:
    """Results of :func:`run_scenario` and the metrics written to ``metrics.json``."""

    results: Results
    metrics: dict

    def table(self) -> str:
        """Metrics table of the estimators (empty string without estimators)."""
        return format_table(self.metrics["estimators"]) if self.metrics["estimators"] else ""


def run_scenario(scenario: str | Scenario, estimators=(), controller: str | None = None,
                 out_dir: str | Path | None = None, duration: float | None = None, step: float = 1e-3,
                 record_every: int = 1, fmu_dir: str | Path = DEFAULT_OUT, params: dict | None = None,
                 overrides: dict | None = None, control_source: str | None = None, progress=None,
                 master: str = "fmpy", scheme: str = "gauss-seidel") -> RunOutput:
    """Run a scenario and (optionally) write ``results.csv``, ``metrics.json``, ``sideslip.png``.

    Parameters
    ----------
    scenario : str or Scenario
        Registry name or object.
    estimators, controller, params, control_source
        See :func:`scenario_components`.
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
    master : {"fmpy", "libcosim"}
        The project's fmpy master, or DNV's libcosim (:mod:`sideslip.cosim.libcosim_master`;
        Jacobi scheme, every step recorded, rows from ``t = step``).
    scheme : {"gauss-seidel", "jacobi"}
        Coupling scheme of the fmpy master (libcosim is always Jacobi).
    """
    sc = get_scenario(scenario, **(overrides or {})) if isinstance(scenario, str) else scenario
    comps, conns = scenario_components(sc, estimators, controller, params, control_source)
    estimators = [inst for inst, _ in estimator_instances(estimators)]
    run_for = duration if duration is not None else sc.duration
    t0 = time.perf_counter()
    if master == "libcosim":
        from .libcosim_master import run_libcosim

        res = run_libcosim(comps, conns, duration=run_for, step=step, fmu_dir=fmu_dir)
    elif master == "fmpy":
        with CoSimulation(comps, conns, step=step, record_every=record_every, fmu_dir=fmu_dir, scheme=scheme) as sim:
            res = sim.run(run_for, progress=progress)
    else:
        raise ValueError(f"master must be 'fmpy' or 'libcosim', got {master!r}")
    wall = time.perf_counter() - t0
    metrics = {"scenario": {"name": sc.name, "description": sc.description, "source": sc.source,
                            "vehicle": sc.vehicle, "maneuver": sc.maneuver, "road_mu": sc.road_mu,
                            "road_bank": sc.road_bank, "notes": list(sc.notes)},
               "summary": scenario_summary(res),
               "estimators": {e: estimate_metrics(res, e) for e in estimators},
               "master": res.meta["master"], "scheme": res.meta["scheme"],
               "wall_time": wall, "simulation_wall_time": res.meta["wall_time"],
               "real_time_factor": res.meta["real_time_factor"], "us_per_step": res.meta["us_per_step"],
               "step": step, "components": res.meta["components"], "connections": res.meta["connections"],
               "unconnected_inputs": res.meta["unconnected_inputs"],
               "messages": res.meta["messages"][:200]}
    if out_dir is not None:
        from .plots import plot_sideslip

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        res.to_csv(out / "results.csv")
        (out / "metrics.json").write_text(json.dumps(metrics, indent=2))
        plot_sideslip(res, list(estimators), out / "sideslip.png", title=f"{sc.name}: {sc.description}")
    return RunOutput(res, metrics)


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
