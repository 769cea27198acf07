"""The estimator benchmark: every estimator on every case, a case being a scenario under a condition.

Protocol
--------
A *case* is a benchmark scenario (:data:`sideslip.scenarios.BENCHMARK_TEST`, or the training set
:data:`~sideslip.scenarios.BENCHMARK_TRAINING` that the hardened estimators were tuned on) under
one of four *conditions*, with a seed that draws everything random about it:

* ``nominal`` - the scenario as defined: clean sensors, the plant on Dugoff tires, the
  estimators on the plant's own vehicle file;
* ``sensors`` - automotive-grade sensor errors (:func:`sensor_errors`): gyro offsets up to
  +-0.6 deg/s with a slow random walk on the yaw rate, accelerometer offsets up to +-0.25 m/s2,
  datasheet noise, GPS velocity at 10 Hz with 0.1 s delay and 0.05-0.1 m/s noise, a steering
  offset, a rolling-radius error, a site's magnetic inclination the estimators do not know;
  the car drives from the first sample (no standstill to calibrate at);
* ``mismatch`` - the plant on Magic Formula tires and the estimators' vehicle perturbed from the
  plant's (:func:`vehicle_mismatch`): cornering stiffness -30 % or +30 % (and +-10 % per axle),
  mass +-10 %, yaw inertia +-15 %, CG +-5 cm;
* ``sensors+mismatch`` - both (the headline).

Each case is simulated once (driver, plant and sensors of the library, 1 ms), and every estimator
row runs on the recorded sensor signals (:func:`sideslip.recording.replay`): without a
controller the estimators do not act on the plant, so this equals running them in the loop.
Rows: predict-zero (``beta_hat = 0``), the textbook linear bicycle Kalman filter
(:class:`~sideslip.estimators.baselines.LinearBicycleObserver`), the open-loop kinematic
integration, and every method of the papers.  The estimators get what a user would give them:
the (perturbed) vehicle, their own default sample period and settings, no friction hint as a
parameter (Park 2018's friction *input* carries the road's, as from an upstream friction
estimator), and the magnetometer calibration of their defaults in the ``sensors`` conditions.

Metrics per row and case (:mod:`sideslip.studies.metrics`), over the samples where the car moves faster than
:data:`~sideslip.studies.metrics.MOVING_SPEED`, whether the
estimator says ``valid`` or not (so that it cannot improve its score by declaring the hard parts,
or a long start-up, not valid; an estimator that is not yet sure should output its prior, zero): RMS and maximum sideslip error and predict-zero's RMS on the same samples; the RMS
while ``valid`` (and predict-zero's on those samples); the share of moving samples it is valid
(``valid``) and the time to its first valid sample; the consistency of ``beta_hat_std`` (RMS error
over RMS reported std, the mean NEES and the share of samples within 1.96 std, 95 % for a
consistent estimator); the longest stretch it is valid while more than 3 deg off, and how often its filter failed numerically and was restarted
(:attr:`~sideslip.estimators.base.Estimator.restarts`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..estimators import ESTIMATORS
from ..params import build, declared_fields
from ..plant.sensors import SensorConfig
from ..plant.vehicle import PlantConfig
from ..recording import LogError, Recording, read_log, recorded_speed, replay
from ..scenarios import BENCHMARK_DEVELOPMENT, BENCHMARK_TEST, BENCHMARK_TRAINING, Scenario, get_scenario
from ..units import DEG, wrap_angle
from ..vehicles import VehicleParams, load_vehicle
from .jobs import map_ordered
from .drives import COMMONROAD_VEHICLES, OWN, Drive, sensed, truth, vehicle_set
from .metrics import score, scored_samples, valid_share
from .real_drive import REAL, VEHICLE, is_real_drive, real_drive

__all__ = ["CONDITIONS", "RECORDED", "OFF_DEG", "SPLIT_PLANTS", "OFF_PLANT_CONDITION", "Row", "ROWS",
           "PAPER_METHODS", "Case", "cases", "log_case", "sensor_errors", "road_draw", "vehicle_mismatch", "setup", "record", "simulate", "make_estimator",
           "row_metrics", "run_case", "select_rows", "with_params", "sensor_overrides", "run_benchmark"]

CONDITIONS = ("nominal", "sensors", "mismatch", "sensors+mismatch", REAL)
RECORDED = "recorded"
"""The condition of a case that is a recorded drive (:func:`log_case`)."""
OFF_DEG = 3.0
"""[deg] an error beyond which the estimator should not say ``valid`` for long."""
SPLIT_PLANTS = {"training": (OWN, "commonroad1"), "development": (OWN, "commonroad2"), "test": (OWN, "commonroad3")}
"""The plants of each set: the own plant and one CommonRoad car, each car in one set only."""
OFF_PLANT_CONDITION = "sensors+mismatch"
"""The one condition of a case on a CommonRoad car: the sensors' errors drawn, and the vehicle the estimators get
is the car's identified file, a mismatch by construction (it is never the plant's own parameters)."""
CROWN_MANEUVERS = ("straight", "lane_change", "double_lane_change", "slalom")
"""Maneuvers on a straight road, where a crowned road can be drawn (a circle or an open-loop turn leaves the road's
line)."""


@dataclass(frozen=True)
class Row:
    """One line of the leaderboard: an estimator class with parameter values, or a reference."""

    label: str
    estimator: str | None            #: a name of sideslip.estimators.ESTIMATORS, None for predict-zero
    params: tuple = ()               #: ((name, value), ...) on top of its defaults
    kind: str = "method"             #: "reference" or "method"


PAPER_METHODS = ("Park2018Observer", "Kim2016SteeringEKF", "Yoon2014DualKF", "Pi2011FuzzyEKF", "Nguyen2012DACMRKF")

ROWS = (
    Row("predict-zero", None, kind="reference"),
    Row("LinearBicycleObserver", "LinearBicycleObserver", kind="reference"),
    Row("OpenLoopKinematic", "OpenLoopKinematic", kind="reference"),
    *(Row(f"{name}/published", name, (("profile", 0),)) for name in PAPER_METHODS),
    *(Row(f"{name}/hardened", name, (("profile", 1),)) for name in PAPER_METHODS),
    Row("SideslipFusion/EKF", "SideslipFusion", (("formulation", 0),)),
    Row("SideslipFusion/IMM", "SideslipFusion", (("formulation", 1),)),
    Row("SideslipFusion/in-vehicle", "SideslipFusion", (("use_gnss", False),)),
)
"""The rows of the benchmark."""


@dataclass(frozen=True)
class Case:
    """A scenario under a condition with a seed, or a recorded drive (condition :data:`RECORDED`: the
    scenario is the log's path, ``log_map`` its column map and ``vehicle`` the estimators' vehicle)."""

    scenario: str
    condition: str
    seed: int = 0
    log_map: str | None = None
    vehicle: str | None = None
    sensors: tuple = ()          #: ((name, value), ...) of SensorConfig replacing the condition's (sensor_overrides)
    plant: str = OWN             #: sideslip.studies.drives.PLANTS

    @property
    def name(self) -> str:
        where = self.scenario if self.plant == OWN else f"{self.scenario}@{self.plant}"
        return f"{where}/{self.condition}/{self.seed}"


def log_case(path: str, log_map: str | None = None, vehicle: str | None = None) -> Case:
    """A benchmark case of a recorded drive (a CSV log with a reference sideslip)."""
    return Case(str(path), RECORDED, 0, log_map, vehicle)


def cases(scenarios=None, conditions=CONDITIONS, seeds=5, training: bool = False,
          development: bool = False, sensors: dict | None = None, plants=None) -> list[Case]:
    """Every scenario x condition x seed on every plant of the set (the test set by default, or the training or the
    development set; :data:`SPLIT_PLANTS`), with ``sensors`` (:func:`sensor_overrides`) replacing those sensor values
    of every case.  ``plants`` keeps some of the set's plants: ``own`` or ``commonroad`` (its car in this set).
    A CommonRoad car runs :data:`OFF_PLANT_CONDITION` only."""
    split = "training" if training else "development" if development else "test"
    chosen = {"training": BENCHMARK_TRAINING, "development": BENCHMARK_DEVELOPMENT, "test": BENCHMARK_TEST}[split]
    real = {"training": "stanford2014_train", "development": "stanford2014_dev", "test": "stanford2014_test"}[split]
    names = scenarios or [s.name for s in chosen] + [real]
    for c in conditions:
        if c not in CONDITIONS:
            raise ValueError(f"unknown condition {c!r}; conditions: {', '.join(CONDITIONS)}")
    kinds = set(plants or ("own", "commonroad"))
    if kinds - {"own", "commonroad"}:
        raise ValueError(f"unknown plant {sorted(kinds - {'own', 'commonroad'})[0]!r}; plants: own, commonroad")
    fixed = tuple(sensor_overrides(sensors).items())
    out = []
    for plant in SPLIT_PLANTS[split]:
        if ("own" if plant == OWN else "commonroad") not in kinds:
            continue
        for n in names:
            if plant != OWN and is_real_drive(n):
                continue
            # a real drive has one condition, its own sensors; a simulated scenario every other
            out += [Case(n, c, s, sensors=fixed, plant=plant) for c in conditions
                    if (c == REAL) == is_real_drive(n) and (plant == OWN or c == OFF_PLANT_CONDITION)
                    for s in range(seeds)]
    return out


def sensor_overrides(values: dict | None) -> dict:
    """:class:`~sideslip.plant.sensors.SensorConfig` values checked and converted (a user's sensor noise, rate or
    delay in place of what a condition draws); a name or value out of range raises
    :class:`~sideslip.params.ParameterError` naming it."""
    if not values:
        return {}
    config = build(SensorConfig, values)
    return {name: getattr(config, name) for name in values}


def _rng(case: Case, what: str) -> np.random.Generator:
    """A generator for one aspect of a case, the same whatever else is drawn."""
    key = [case.seed, *(ord(ch) for ch in f"{case.scenario}/{what}")]
    return np.random.default_rng(key)


# ---------------------------------------------------------------------------------------- conditions
def sensor_errors(case: Case) -> dict:
    """Automotive-grade sensor errors of a case (SensorConfig values), drawn from its seed."""
    r = _rng(case, "sensors")
    return dict(
        yaw_rate_bias=math.radians(r.uniform(-0.6, 0.6)), yaw_rate_bias_drift=math.radians(0.1),
        roll_rate_bias=math.radians(r.uniform(-0.6, 0.6)),
        ax_bias=r.uniform(-0.25, 0.25), ay_bias=r.uniform(-0.25, 0.25),
        ax_sigma=0.05, ay_sigma=0.05, yaw_rate_sigma=math.radians(0.1), roll_rate_sigma=math.radians(0.1),
        gps_rate=10.0, gps_delay=0.1, gps_vel_sigma=r.uniform(0.05, 0.1),
        steer_bias=r.uniform(-0.003, 0.003), wheel_radius_error=r.uniform(-0.01, 0.01),
        mag_inclination=math.radians(r.uniform(55.0, 72.0)), mag_sigma=0.01,
    )


def vehicle_mismatch(vehicle: VehicleParams, case: Case) -> VehicleParams:
    """The estimators' vehicle of a case: cornering stiffness -30 % or +30 % (and +-10 % per axle),
    mass +-10 %, yaw inertia +-15 %, CG +-5 cm, drawn from its seed."""
    r = _rng(case, "vehicle")
    common = 0.7 if r.random() < 0.5 else 1.3
    kf, kr = common * r.uniform(0.9, 1.1), common * r.uniform(0.9, 1.1)
    km, kz, dcg = r.uniform(0.9, 1.1), r.uniform(0.85, 1.15), r.uniform(-0.05, 0.05)
    v = vehicle
    return v.with_overrides({
        "C_f_nominal": v.C_f_nominal * kf, "C_r_nominal": v.C_r_nominal * kr,
        "C_f_nominal_lo": v.C_f_nominal_lo * kf, "C_r_nominal_lo": v.C_r_nominal_lo * kr,
        "m": v.m * km, "m_s": v.m_s * km, "m_uf": v.m_uf * km, "m_ur": v.m_ur * km, "I_zz": v.I_zz * kz,
        "l_f": v.l_f + dcg, "l_r": v.l_r - dcg, "l_fs": v.l_fs + dcg, "l_rs": v.l_rs - dcg})


def road_draw(case: Case, scenario: Scenario) -> dict:
    """The road of a case with sensor errors, as the driver's parameters: a crossfall of 0-3 % to either side added to
    the scenario's bank, or, on a straight road (:data:`CROWN_MANEUVERS`) with even odds, a crowned road falling
    0.5-3 % to each side of the lane line left of the start (a lane change crosses it), drawn from its seed."""
    r = _rng(case, "road")
    crowned = r.random() < 0.5
    slope = math.atan(r.uniform(0.0, 0.03))
    side = 1.0 if r.random() < 0.5 else -1.0
    if crowned and scenario.maneuver.partition(":")[0].strip() in CROWN_MANEUVERS:
        return {"road_crown": max(slope, math.atan(0.005))}
    return {"road_bank": f"{float(scenario.road_bank) + side * slope:.10g}"}


@dataclass
class CaseSetup:
    """What a case is made of."""

    scenario: Scenario
    plant: dict
    sensors: dict
    vehicle: VehicleParams           #: the plant's (on a CommonRoad car: the car's identified file, what is known)
    estimator_vehicle: VehicleParams
    calibrated_field: bool           #: estimators get the sensors' Earth field
    driver: dict = None              #: the driver's parameters (the scenario's, with the drawn road)


def setup(case: Case, overrides: dict | None = None) -> CaseSetup:
    """The scenario (with ``overrides``), driver, plant and sensor parameters and the estimators' vehicle of a case
    (of a recorded drive: the vehicle named by the case, or None for each estimator's own default)."""
    if case.condition == RECORDED:
        return CaseSetup(None, {}, {}, None, load_vehicle(case.vehicle) if case.vehicle else None, False)
    if case.condition == REAL:                 # the derived sensors of a real drive (sideslip.studies.real_drive)
        vehicle = load_vehicle(VEHICLE)
        sensors = {"seed": 1000 + case.seed, **sensor_errors(case), **dict(case.sensors)}
        return CaseSetup(None, {}, sensors, vehicle, vehicle, False)
    sc = get_scenario(case.scenario, **(overrides or {}))
    sensors = {**sc.sensor_params(), "seed": 1000 + case.seed}
    driver = sc.driver_params()
    noisy = "sensors" in case.condition
    if noisy:
        sensors.update(sensor_errors(case))
        driver.update(road_draw(case, sc))
    sensors.update(case.sensors)
    n = vehicle_set(case.plant)
    if n is not None:                          # a CommonRoad car, known by its identified file
        known = load_vehicle(COMMONROAD_VEHICLES[n])
        driver.update(vehicle=COMMONROAD_VEHICLES[n], vehicle_overrides="")
        return CaseSetup(sc, {"vx0": sc.initial_speed}, sensors, known, known, False, driver)
    plant = dict(sc.plant_params())
    vehicle = build(PlantConfig, plant).vehicle_params()
    estimator_vehicle = vehicle
    if "mismatch" in case.condition:
        plant["tire_model"] = 1
        estimator_vehicle = vehicle_mismatch(vehicle, case)
    return CaseSetup(sc, plant, sensors, vehicle, estimator_vehicle, not noisy, driver)


# ---------------------------------------------------------------------------------------- one case
def record(scenario: str, sensors: dict, tire_model: int = 0, step: float = 1e-3, name: str = "",
           driver: dict | None = None, plant: str = OWN, plant_values: dict | None = None) -> Recording:
    """Driver, plant and sensors of a scenario, as the fmpy master's Gauss-Seidel loop runs them: the sensors
    (:class:`~sideslip.plant.sensors.SensorConfig` values ``sensors``) sample the plant's truth at the end of
    every step (:mod:`sideslip.studies.drives`), so the truth of a scenario on one plant and road is simulated once
    and sampled by the sensors of each condition and seed.  ``driver`` and ``plant_values`` replace the scenario's
    driver and plant parameters (default: its own, the plant on ``tire_model``)."""
    sc = get_scenario(scenario)
    values = plant_values if plant_values is not None else {**sc.plant_params(), "tire_model": tire_model}
    drive = Drive(plant, tuple(sorted((driver or sc.driver_params()).items())), tuple(sorted(values.items())),
                  sc.duration)
    return sensed(truth(drive, step), sensors, step, name or scenario)


def simulate(case: Case, step: float = 1e-3) -> Recording:
    """The recorded drive of a case (:func:`record` with its road, plant and sensors; a real drive's slice with its
    derived sensors)."""
    s = setup(case)
    if case.condition == REAL:
        return real_drive(case.scenario, s.sensors)
    return record(case.scenario, s.sensors, step=step, name=case.name, driver=s.driver, plant=case.plant,
                  plant_values=s.plant)


def make_estimator(row: Row, s: CaseSetup):
    """The estimator of a row configured for a case (see module docstring)."""
    cls = ESTIMATORS[row.estimator]
    values = dict(row.params)
    names = {f.name for f, _ in declared_fields(cls.config_class)}
    if s.calibrated_field:
        values.update({k: v for k, v in s.sensors.items() if k in ("mag_inclination", "mag_declination") and k in names})
    config = build(cls.config_class, values)
    return cls(config, vehicle=s.estimator_vehicle)


def _longest(mask: np.ndarray, dt: float) -> float:
    """Longest run of True [s]."""
    if not mask.any():
        return 0.0
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return float((edges[1::2] - edges[::2]).max() * dt)


def row_metrics(rec: Recording, beta_hat, std, valid) -> dict:
    """Metrics of one row on one recorded case (module docstring): every moving sample scored, the valid ones
    beside (:func:`~sideslip.studies.metrics.score`)."""
    t = rec.time
    dt = float(t[1] - t[0])
    speed = recorded_speed(rec)
    moving = scored_samples(speed)
    ok = scored_samples(speed, valid, valid_only=True)
    beta = rec.reference["beta"]
    err = wrap_angle(np.asarray(beta_hat) - beta) * DEG
    std = np.asarray(std) * DEG
    out = {"valid": valid_share(valid, moving),
           "time_to_valid": float(t[np.argmax(ok)] - t[np.argmax(moving)]) if ok.any() else float("nan"),
           "max_abs_beta": float(np.abs(beta[moving]).max() * DEG) if moving.any() else 0.0,
           "moving_s": float(moving.sum() * dt)}
    nan = float("nan")
    if not moving.any():
        return {**out, **dict.fromkeys(("rms", "max", "zero_rms", "rms_valid", "zero_rms_valid", "std_ratio", "nees",
                                        "coverage95", "not_valid_when_worse"), nan), "off_while_valid": 0.0}
    beta_deg = beta * DEG
    every, on_valid = score(err, beta_deg, moving), score(err, beta_deg, ok)
    worse = moving & (np.abs(err) > np.abs(beta) * DEG)
    out.update(rms=every["rms"], max=every["max"], zero_rms=every["zero_rms"], rms_valid=on_valid["rms"],
               zero_rms_valid=on_valid["zero_rms"], off_while_valid=_longest(ok & (np.abs(err) > OFF_DEG), dt),
               not_valid_when_worse=float(np.mean(~ok[worse])) if worse.any() else nan)
    if np.isfinite(std).all():                   # predict-zero reports no uncertainty
        e, s = err[moving], np.maximum(std[moving], 1e-9)
        out.update(std_ratio=every["rms"] / float(np.sqrt(np.mean(s ** 2))), nees=float(np.mean((e / s) ** 2)),
                   coverage95=float(np.mean(np.abs(e) <= 1.96 * s)))
    else:
        out.update(std_ratio=nan, nees=nan, coverage95=nan)
    return out


def run_case(case: Case, rows=ROWS, traces: bool = False) -> dict:
    """Simulate a case and score every row on it.

    Returns
    -------
    dict
        ``case``, ``scenario``, ``condition``, ``seed``, ``mu_min``, ``wall_s``, ``rows``:
        ``{label: metrics}`` and, with ``traces``, decimated ``time``, ``beta`` and each row's
        ``beta_hat`` [deg] for the plots.
    """
    t0 = time.perf_counter()
    s = setup(case)
    rec = read_log(case.scenario, case.log_map).on_grid(1e-3) if case.condition == RECORDED else simulate(case)
    if "beta" not in rec.reference:
        raise LogError(f"{rec.source}: no reference sideslip (a column 'beta' or a [reference.beta] map entry) "
                       "to score the estimators against")
    mu = rec.signals.get("mu")
    out = {"case": case.name, "scenario": case.scenario, "condition": case.condition, "seed": case.seed,
           "plant": case.plant, "duration_s": rec.duration,
           "mu_min": float(np.min(mu)) if mu is not None else float("nan"), "rows": {}}
    if traces:
        out["traces"] = {"time": rec.time[::20].tolist(), "beta": (rec.reference["beta"][::20] * DEG).tolist()}
    grids = {}
    for row in rows:
        if row.estimator is None:
            n = len(rec.time)
            beta_hat, std, valid, at = np.zeros(n), np.full(n, np.nan), np.ones(n), rec
        else:
            estimator = make_estimator(row, s)
            # stepped at its own sample period: equal to 1 ms steps with the inputs held (module docstring)
            step = max(round(estimator.Ts / 1e-3) * 1e-3, 1e-3)
            at = grids.setdefault(step, rec if step == 1e-3 else rec.on_grid(step))
            res = replay(estimator, at)
            beta_hat, std, valid = res["beta_hat"], res["beta_hat_std"], res["valid"]
        out["rows"][row.label] = row_metrics(at, beta_hat, std, valid)
        out["rows"][row.label]["restarts"] = 0 if row.estimator is None else estimator.restarts
        if traces:
            every = max(1, int(round(0.02 / float(at.time[1] - at.time[0]))))
            out["traces"][row.label] = {"time": at.time[::every].tolist(),
                                        "beta_hat": np.where(np.asarray(valid)[::every] > 0.5,
                                                             np.asarray(beta_hat)[::every] * DEG, np.nan).tolist()}
    out["wall_s"] = time.perf_counter() - t0
    return out


def _scenario_job(job) -> list[dict]:
    """The cases of one scenario on one plant (one worker simulates each of its truths once)."""
    case_list, rows = job
    return [run_case(c, rows, traces=c.seed == 0) for c in case_list]


def select_rows(names=None) -> tuple:
    """The rows whose label or estimator is one of ``names`` (all rows for None), predict-zero always
    (every score is relative to it)."""
    if not names:
        return ROWS
    known = {r.label for r in ROWS} | {r.estimator for r in ROWS if r.estimator}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"unknown estimator {unknown[0]!r}; rows: {', '.join(r.label for r in ROWS)}")
    return tuple(r for r in ROWS if r.estimator is None or r.label in names or r.estimator in names)


def with_params(rows, params: dict | None) -> tuple:
    """``rows`` with the estimator parameter values ``params`` on every row whose estimator has them (on top of the
    row's own); a name no row's estimator has raises ValueError, a value out of range
    :class:`~sideslip.params.ParameterError`."""
    if not params:
        return tuple(rows)
    out, used = [], set()
    for row in rows:
        if row.estimator is None:
            out.append(row)
            continue
        config_class = ESTIMATORS[row.estimator].config_class
        names = {f.name for f, _ in declared_fields(config_class)}
        mine = {k: v for k, v in params.items() if k in names}
        if mine:
            config = build(config_class, {**dict(row.params), **mine})
            row = Row(row.label, row.estimator, row.params + tuple((k, getattr(config, k)) for k in mine), row.kind)
            used.update(mine)
        out.append(row)
    unknown = [k for k in params if k not in used]
    if unknown:
        raise ValueError(f"no selected row's estimator has a parameter {unknown[0]!r}")
    return tuple(out)


def _simulated_seconds(case: Case) -> float:
    """How long a case drives [s] (the progress bar's measure of work)."""
    from .real_drive import SLICES

    if case.scenario in SLICES:
        t0, t1 = SLICES[case.scenario]
        return t1 - t0
    try:
        return get_scenario(case.scenario).duration
    except ValueError:                 # a recorded drive: a log's path
        return 60.0


def run_benchmark(case_list, rows=ROWS, workers: int = 2, scheduler=None, progress: bool = True) -> list[dict]:
    """Run cases in parallel on :mod:`sideslip.studies.jobs`, one job per scenario and plant; results in the
    cases' order, with traces kept for seed 0."""
    by_scenario: dict[tuple, list] = {}
    for c in case_list:
        by_scenario.setdefault((c.scenario, c.plant), []).append(c)
    done = {}
    jobs = [(group, tuple(rows)) for group in by_scenario.values()]
    for group in map_ordered(_scenario_job, jobs, workers, scheduler, progress, "benchmark",
                             weight=lambda job: sum(_simulated_seconds(c) for c in job[0]), unit="sim s"):
        done.update({r["case"]: r for r in group})
    return [done[c.name] for c in case_list]
