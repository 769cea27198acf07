"""Simulated drives: a plant (the project's or the third-party one), the maneuver driver and the sensors.

A drive is the truth of a driver and a plant in closed loop (:func:`truth`, cached: the conditions and
seeds of a case that share it simulate it once) sampled by a sensor suite (:func:`sensed`), as the fmpy
master's Gauss-Seidel loop runs them.  Plants (:data:`PLANTS`):

* ``own`` - :class:`~sideslip.plant.vehicle.VehiclePlant` on the scenario's vehicle file;
* ``commonroad1`` .. ``commonroad3`` - :class:`~sideslip.plant.commonroad.CommonRoadPlant` on that published set,
  driven as a user drives a car: the driver (and later the estimators) know it by the vehicle file
  :data:`COMMONROAD_VEHICLES` derives from the set's geometry and mass and a calibration drive
  (:func:`calibration_drive`, :mod:`sideslip.studies.identify`), never by the set's own parameters.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..constants import GRAVITY
from ..params import build, format_assignments
from ..plant.commonroad import CommonRoadConfig, CommonRoadPlant, vehicle_parameters
from ..plant.driver import Driver, DriverConfig
from ..plant.loop import run_loop
from ..plant.maneuvers import maneuver_spec, parse_maneuver
from ..plant.sensors import SensorConfig, SensorSuite
from ..plant.vehicle import PlantConfig, VehiclePlant
from ..recording import Recording
from ..signals import SENSOR_INPUTS, SENSOR_OUTPUTS
from ..vehicles import VehicleParams

__all__ = ["OWN", "PLANTS", "COMMONROAD_VEHICLES", "Drive", "vehicle_set", "truth", "sensed", "commonroad_base",
           "calibration_maneuvers", "calibration_drive", "pac2002_axle_stiffness"]

OWN = "own"
COMMONROAD_VEHICLES = {1: "commonroad_ford_escort", 2: "commonroad_bmw_320i", 3: "commonroad_vw_vanagon"}
"""The bundled vehicle file of each CommonRoad set: geometry and mass from the set, the rest identified."""
PLANTS = (OWN, *(f"commonroad{n}" for n in COMMONROAD_VEHICLES))

COMMONROAD_TEMPLATE = "park2018_sonata"
"""The bundled car a CommonRoad set's vehicle file inherits what neither the set's geometry nor the calibration
drive gives (suspension, Magic Formula shape, drag): a mid-size sedan, as a user starts from a similar car."""


def vehicle_set(plant: str) -> int | None:
    """The CommonRoad set of a plant name, None for the own plant (ValueError for an unknown name)."""
    if plant == OWN:
        return None
    if plant not in PLANTS:
        raise ValueError(f"unknown plant {plant!r}; plants: {', '.join(PLANTS)}")
    return int(plant[len("commonroad"):])


@dataclass(frozen=True)
class Drive:
    """A closed loop of the driver and a plant: their parameter values as sorted items (hashable)."""

    plant: str
    driver: tuple
    plant_values: tuple
    duration: float


@lru_cache(maxsize=4)
def truth(drive: Drive, step: float = 1e-3) -> dict:
    """The driver and the plant of a drive simulated in closed loop (:func:`~sideslip.plant.loop.run_loop`).

    The CommonRoad model has no answer through a stop or a spin (:mod:`sideslip.plant.commonroad`): such a drive
    ends where its model fails, ``"failure"`` saying why."""
    driver = Driver(build(DriverConfig, dict(drive.driver)))
    values = dict(drive.plant_values)
    if vehicle_set(drive.plant) is None:
        return run_loop(VehiclePlant(build(PlantConfig, values)), driver, drive.duration, step)
    plant = CommonRoadPlant(build(CommonRoadConfig, {"vehicle_set": vehicle_set(drive.plant), **values}))
    return run_loop(plant, driver, drive.duration, step, until_failure=True)


def sensed(truth_run: dict, sensors: dict, step: float = 1e-3, name: str = "") -> Recording:
    """The sensors (:class:`~sideslip.plant.sensors.SensorConfig` values) sampling a truth at the end of every
    step; the truth's sideslip, velocity, yaw rate, lateral acceleration, roll and yaw are the reference."""
    suite = SensorSuite(build(SensorConfig, sensors))
    n = len(truth_run["time"])
    inputs = np.column_stack([truth_run[nm] for nm in SENSOR_INPUTS]).tolist()
    out = np.empty((n, len(SENSOR_OUTPUTS)))
    out[0] = suite.outputs()
    for k in range(1, n):
        suite.step(step, *inputs[k])
        out[k] = suite.outputs()
    signals = {nm: out[:, i] for i, nm in enumerate(SENSOR_OUTPUTS)}
    signals["mu"] = truth_run["mu"]
    reference = {nm: truth_run[nm] for nm in ("beta", "vx", "vy", "yaw_rate", "ay", "roll", "yaw", "bank_angle")}
    return Recording(truth_run["time"], signals, reference, name)


# ---------------------------------------------------------------------------------------- CommonRoad cars
def commonroad_base(vehicle_set_number: int) -> dict:
    """What a user knows of a CommonRoad set before a calibration drive, as values over
    :data:`COMMONROAD_TEMPLATE`: masses, CG position and height, tracks, rolling radius, drive and brake split
    (from the set's data sheet), and a yaw inertia by the rule ``I_zz = m l_f l_r``."""
    p = vehicle_parameters(vehicle_set_number)
    m = p.m_s + p.m_uf + p.m_ur
    wheelbase = p.a + p.b
    l_f = (p.m_s * p.a + p.m_ur * wheelbase) / m           # the set's a, b are the sprung mass's
    return {"m": round(m, 1), "m_s": round(p.m_s, 1), "m_uf": round(p.m_uf, 1), "m_ur": round(p.m_ur, 1),
            "l_f": round(l_f, 4), "l_r": round(wheelbase - l_f, 4), "l_fs": round(p.a, 4), "l_rs": round(p.b, 4),
            "t_f": round(p.T_f, 4), "t_r": round(p.T_r, 4), "h_cg": round(p.h_cg, 4), "R_w": p.R_w,
            "drive_split_front": float(p.T_se), "brake_split_front": float(p.T_sb),
            "I_zz": round(m * l_f * (wheelbase - l_f), 0)}


# ---------------------------------------------------------------------------------------- calibration
CALIBRATION_RADIUS = 20.0
"""[m] the calibration circle."""
CALIBRATION_SPEEDS = (6.0, 20.0)
"""[m/s] the circle's and the sweep's speed."""
CALIBRATION_LOW_SPEED = 15.0
"""[m/s] the low-friction sweep's speed (for about 1 m/s2)."""
CALIBRATION_LOW_MU = 0.3
"""The friction of the low-friction leg (the vehicle files' ``mu_lo``)."""


def calibration_maneuvers(vehicle: VehicleParams) -> dict:
    """The calibration drive of :mod:`sideslip.studies.identify` as maneuver specs by leg: the circle to the left
    and to the right, the sweep with a handwheel amplitude for about 3 m/s2 at its lowest frequency on this car
    (its wheelbase and steering ratio, an understeer gradient of 0.002 rad/(m/s2) assumed), and the sweep for about
    1 m/s2 on a low-friction surface (:data:`CALIBRATION_LOW_MU`)."""
    v_circle, v_sweep = CALIBRATION_SPEEDS
    amplitude = vehicle.steering_ratio * 3.0 * (vehicle.l / v_sweep ** 2 + 0.002)
    circle = dict(v0=v_circle, v=v_circle, lead_in=40.0, duration=40.0)
    sweep = dict(f_start=0.2, f_end=2.0, sweep_time=40.0, t_start=5.0, duration=48.0)
    low = vehicle.steering_ratio * 1.0 * (vehicle.l / CALIBRATION_LOW_SPEED ** 2 + 0.002)
    return {"circle_left": maneuver_spec("circle", radius=CALIBRATION_RADIUS, **circle),
            "circle_right": maneuver_spec("circle", radius=-CALIBRATION_RADIUS, **circle),
            "sweep": maneuver_spec("steer_sweep", v0=v_sweep, v=v_sweep, amplitude=round(amplitude, 4), **sweep),
            "sweep_low_friction": maneuver_spec("steer_sweep", v0=CALIBRATION_LOW_SPEED, v=CALIBRATION_LOW_SPEED,
                                                amplitude=round(low, 4), **sweep)}


def calibration_drive(plant: str, vehicle: str, vehicle_overrides: dict, vehicle_params: VehicleParams,
                      sensors: dict, tire_model: int = 0) -> dict:
    """The calibration drive on a plant, sampled by ``sensors``, one recording per leg (by name, the low-friction
    leg's ending in ``low_friction``).

    ``vehicle`` and ``vehicle_overrides`` are what the driver knows of the car (and, on the own plant, the plant's
    vehicle itself); ``vehicle_params`` the same loaded.
    """
    overrides = format_assignments(vehicle_overrides)
    out = {}
    for leg, spec in calibration_maneuvers(vehicle_params).items():
        v0 = parse_maneuver(spec).v0
        driver = {"vehicle": vehicle, "vehicle_overrides": overrides, "maneuver": spec,
                  "road_mu": str(CALIBRATION_LOW_MU if leg.endswith("low_friction") else 1.0)}
        if vehicle_set(plant) is None:
            values = {"vehicle": vehicle, "vehicle_overrides": overrides, "vx0": v0, "tire_model": tire_model}
        else:
            values = {"vx0": v0}
        drive = Drive(plant, tuple(sorted(driver.items())), tuple(sorted(values.items())),
                      parse_maneuver(spec).duration)
        out[leg] = sensed(truth(drive), {**sensors, "seed": sensors.get("seed", 0) + len(out)}, name=leg)
    return out


def pac2002_axle_stiffness(vehicle_set_number: int) -> tuple[float, float]:
    """[N/rad] the front and rear axle's cornering stiffness of a CommonRoad set's PAC2002 tires at the static
    loads (twice the slope of one tire's lateral force at zero slip and camber), the reference an identified
    stiffness is checked against."""
    import vehiclemodels.utils.tire_model as mf

    p = vehicle_parameters(vehicle_set_number)
    base = commonroad_base(vehicle_set_number)
    weight, wheelbase = base["m"] * GRAVITY, base["l_f"] + base["l_r"]
    loads = (0.5 * weight * base["l_r"] / wheelbase, 0.5 * weight * base["l_f"] / wheelbase)
    alpha = 1e-4
    return tuple(abs(mf.formula_lateral(alpha, 0.0, fz, p.tire)[0] - mf.formula_lateral(-alpha, 0.0, fz, p.tire)[0])
                 / alpha for fz in loads)

