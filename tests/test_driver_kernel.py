"""The driver's compiled step against its pure-Python reference, in the library and inside the FMU.

The C kernel (``plant/native/driver_kernel.c``) repeats the reference's path follower and speed controller
operation for operation: both give the same doubles (checked exactly on Linux x86-64, and to 1e-12 everywhere).
The drives cover an open path with a curve speed limit, a closed circuit, open-loop handwheel maneuvers that
coast, a brake in a turn that ends held at a standstill, and synthetic positions before, beside and beyond the
path's ends with the car reversing.
"""
from __future__ import annotations

import math
import pickle
import platform
import sys
import zipfile

import numpy as np
import pytest

from sideslip.params import build
from sideslip.plant import kernel
from sideslip.plant.driver import Driver, DriverConfig
from sideslip.plant.loop import run_loop
from sideslip.plant.vehicle import PlantConfig, VehiclePlant
from sideslip.scenarios import get_scenario

EXACT = platform.system() == "Linux" and platform.machine() in ("x86_64", "AMD64")


def _driver(scenario: str, compiled: int) -> Driver:
    return Driver(build(DriverConfig, {**get_scenario(scenario).driver_params(), "compiled": compiled}))


def _assert_same(got: np.ndarray, ref: np.ndarray) -> None:
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.maximum(1.0, np.abs(ref)).max()
    if EXACT:
        assert np.array_equal(got, ref)


def test_the_compiled_driver_step_is_built_with_the_library():
    assert kernel.available(), kernel.UNAVAILABLE
    assert Driver().compiled
    assert not Driver(DriverConfig(compiled=0)).compiled


# (scenario, seconds, what the drive must have reached: a check on the reference's outputs)
LOOPS = [
    ("bench_dlc_asm_80kmh", 10.0, lambda d, out: d._vlim is not None),                       # curve speed limit
    ("kim2016_track_40", 25.0, lambda d, out: d.plan.path.closed),                           # a closed circuit
    ("fmvss126_sonata_mu08_a6.5", 6.0, lambda d, out: np.ptp(out[:, 0]) > 0.1),               # open loop, coasting
    ("park2018_case5", 16.0, lambda d, out: out[-1, 2] == d._hold_torque() and out[-1, 8] == 0.0),  # held at rest
]


@pytest.mark.parametrize("scenario,duration,reached", LOOPS, ids=[c[0] for c in LOOPS])
def test_the_compiled_driver_gives_the_reference_doubles_in_the_closed_loop(scenario, duration, reached):
    runs = {}
    for compiled in (0, 1):
        driver = _driver(scenario, compiled)
        assert driver.compiled == bool(compiled)
        plant = VehiclePlant(build(PlantConfig, get_scenario(scenario).plant_params()))
        raw = run_loop(plant, driver, duration, 1e-3)
        runs[compiled] = np.column_stack([raw[name] for name in (*Driver.output_names, "vx", "X", "Y")])
    assert reached(driver, runs[0])
    _assert_same(runs[1], runs[0])


@pytest.mark.parametrize("scenario", ["bench_dlc_asm_80kmh", "kim2016_track_40"])
def test_the_compiled_driver_gives_the_reference_doubles_off_the_path_and_reversing(scenario):
    """Positions along the whole path and 30 m beyond both ends of an open one, up to 4 m beside it, headings off
    by up to 2.5 rad, the speed through zero to reversing, 20 ms steps (the handwheel reaches its bounds): every
    branch of the projection, the look-ahead and the limits."""
    rng = np.random.default_rng(7)
    drivers = [_driver(scenario, compiled) for compiled in (0, 1)]
    path = drivers[0].plan.path
    n = len(path.x)
    if path.closed:                                  # twice round
        k = np.arange(2 * n)
        i, over = k % n, np.zeros(k.size)
    else:                                            # 30 m before the start to 30 m past the end
        k = np.arange(-60, n + 60)
        i = np.clip(k, 0, n - 1)
        over = np.where(k < 0, k, np.where(k > n - 1, k - (n - 1), 0)) * 0.5     # along the end's heading
    X = path.x[i] + over * np.cos(path.psi[i]) + rng.uniform(-4.0, 4.0, k.size)
    Y = path.y[i] + over * np.sin(path.psi[i]) + rng.uniform(-4.0, 4.0, k.size)
    yaw = path.psi[i] + 2.5 * np.sin(k / 60.0) + rng.uniform(-0.1, 0.1, k.size)
    vx = 25.0 * np.cos(np.linspace(0.0, 1.2 * math.pi, k.size))
    outs = [[], []]
    for row in zip(vx, X, Y, yaw):
        for driver, out in zip(drivers, outs):
            driver.step(0.02, *row)
            out.append((*driver.outputs(), driver._idx, driver._integ))
    ref, got = np.array(outs[0]), np.array(outs[1])
    idx = ref[:, -2]
    assert (np.any(np.diff(idx) < -n // 2) if path.closed else idx.max() == n - 1)      # the wrap, or the end
    assert vx.min() < -10.0 and np.ptp(ref[:, 0]) > 1.0 and 0.7 in np.abs(ref[:, 0])
    _assert_same(got, ref)


def test_a_pickled_driver_runs_compiled():
    driver = _driver("bench_dlc_asm_80kmh", 1)
    truth = [(20.0 + 0.001 * k, 8.0 + 0.02 * k, 0.3, 0.01) for k in range(400)]
    for row in truth[:200]:
        driver.step(1e-3, *row)
    copy = pickle.loads(pickle.dumps(driver))
    assert copy.compiled
    for row in truth[200:]:
        driver.step(1e-3, *row)
        copy.step(1e-3, *row)
    assert copy.outputs() == driver.outputs()


def _fmu_run(fmu_dir, compiled: int) -> np.ndarray:
    from fmpy import simulate_fmu

    t = np.linspace(0.0, 6.0, 61)
    signals = np.array(list(zip(t, 22.0 - t, 22.0 * t - 0.5 * t * t, 0.8 * np.sin(t), 0.05 * np.sin(t))),
                       dtype=[("time", float), ("vx", float), ("X", float), ("Y", float), ("yaw", float)])
    res = simulate_fmu(str(fmu_dir / "ManeuverDriver.fmu"), stop_time=6.0, output_interval=1e-3,
                       start_values={"maneuver": "double_lane_change:v0=22,v=22", "compiled": compiled},
                       input=signals)
    return np.array([res[name] for name in res.dtype.names])


def test_the_driver_fmu_runs_compiled_and_gives_the_reference(fmu_dir):
    with zipfile.ZipFile(fmu_dir / "ManeuverDriver.fmu") as z:
        package = next(n.split("/")[1] for n in z.namelist() if n.endswith("/plant/driver.py"))
    compiled = _fmu_run(fmu_dir, 1)
    assert sys.modules[f"{package}.plant.kernel"].available(), sys.modules[f"{package}.plant.kernel"].UNAVAILABLE
    reference = _fmu_run(fmu_dir, 0)
    assert np.ptp(reference[1]) > 0.05                   # delta_f follows the path
    _assert_same(compiled, reference)
