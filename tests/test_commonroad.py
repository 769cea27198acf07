"""The third-party plant: CommonRoad's multi-body model under the plant contract, against the model called
directly, on a steady circle, and as an FMU (equal to the library, in a closed loop through fmpy)."""
import math

import numpy as np
import pytest

from conftest import assert_save_restore_repeats
from sideslip.constants import GRAVITY
from sideslip.plant.commonroad import CommonRoadConfig, CommonRoadPlant, tire_forces, vehicle_parameters
from vehiclemodels.init_mb import init_mb
from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb
from vehiclemodels.vehicle_parameters import setup_vehicle_parameters


def _steer(t: float) -> float:
    return 0.04 * math.sin(2.0 * math.pi * 0.5 * t) if t > 0.2 else 0.0


@pytest.mark.parametrize("vehicle_set", [1, 2, 3])
def test_the_plant_integrates_the_published_model_exactly(vehicle_set):
    """Golden values: the plant without the adapter's torques, on mu 1 and a flat road, against RK4 of
    ``vehicle_dynamics_mb`` called directly with the package's own parameter object, 2 s of a sine steer."""
    cfg = CommonRoadConfig(vehicle_set=vehicle_set, vx0=18.0, steer_tau=0.02)
    plant = CommonRoadPlant(cfg)
    p = setup_vehicle_parameters(vehicle_id=vehicle_set)
    p.steering.v_min, p.steering.v_max = -cfg.steer_rate_max, cfg.steer_rate_max
    x = init_mb([0.0, 0.0, 0.0, 18.0, 0.0, 0.0, 0.0], p)

    def f(s, delta):
        return vehicle_dynamics_mb(list(s), [(delta - s[2]) / cfg.steer_tau, 0.0], p)

    h = 1e-3
    for k in range(2000):
        delta = _steer(k * h)
        plant.step(h, delta, 0.0, 0.0, 0.0, 1.0)
        k1 = f(x, delta)
        k2 = f([a + 0.5 * h * b for a, b in zip(x, k1)], delta)
        k3 = f([a + 0.5 * h * b for a, b in zip(x, k2)], delta)
        k4 = f([a + h * b for a, b in zip(x, k3)], delta)
        x = [a + h / 6.0 * (b1 + 2.0 * (b2 + b3) + b4) for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4)]
        x[4] = math.pi - (math.pi - x[4]) % (2.0 * math.pi)
    assert plant.n_substeps == 1
    assert np.max(np.abs(np.array(plant.x) - np.array(x))) <= 1e-12
    out = plant.output_dict()
    assert out["vx"] == x[3] and out["vy"] == x[10] and out["yaw_rate"] == x[5] and out["X"] == x[0]
    assert abs(out["beta"]) > 0.001 and abs(out["yaw_rate"]) > 0.05      # the car turned


def test_the_tire_evaluation_is_the_models_own():
    """The axle forces reported are the model's: their sum is the lateral force its three bodies' equations carry,
    and their yaw moment its yaw acceleration."""
    plant = CommonRoadPlant(CommonRoadConfig(vehicle_set=2, vx0=22.0))
    for k in range(1500):
        plant.step(1e-3, _steer(k * 1e-3 + 0.7), 200.0, 0.0, 0.0, 0.8)
    x, p = plant.x, plant.params
    t = tire_forces(x, p)
    f = vehicle_dynamics_mb(list(x), [0.0, 0.0], p)
    d, r, vx = x[2], x[5], x[3]
    lateral = (t.fy[0] + t.fy[1]) * math.cos(d) + (t.fx[0] + t.fx[1]) * math.sin(d) + t.fy[2] + t.fy[3]
    bodies = p.m_s * (f[10] + r * vx) + p.m_uf * (f[15] + r * vx) + p.m_ur * (f[20] + r * vx)
    assert lateral == pytest.approx(bodies, rel=1e-9) and abs(lateral) > 500.0
    yaw = ((t.fy[0] + t.fy[1]) * p.a * math.cos(d) + (t.fx[0] + t.fx[1]) * p.a * math.sin(d)
           + (t.fy[1] - t.fy[0]) * 0.5 * p.T_f * math.sin(d) + (t.fx[0] - t.fx[1]) * 0.5 * p.T_f * math.cos(d)
           + (t.fx[2] - t.fx[3]) * 0.5 * p.T_r - (t.fy[2] + t.fy[3]) * p.b)
    assert yaw == pytest.approx(f[5] * p.I_z, rel=1e-9)                 # I_xz_s = 0 in the published sets
    out = plant.output_dict()
    assert out["Fy_f"] + out["Fy_r"] == pytest.approx(lateral, rel=1e-12)
    assert out["ay"] == pytest.approx(math.cos(-x[6]) * lateral / p.m + math.sin(-x[6]) * GRAVITY, rel=1e-9)


def _steady_circle(vehicle_set: int, delta: float, v: float = 20.0) -> dict:
    plant = CommonRoadPlant(CommonRoadConfig(vehicle_set=vehicle_set, vx0=v))
    for _ in range(6000):
        torque = 3000.0 * (v - plant.output_dict()["vx"])           # speed held by the rear/front drive
        plant.step(1e-3, delta, max(torque, 0.0), max(-torque, 0.0))
    return plant.output_dict()


@pytest.mark.parametrize("vehicle_set", [1, 2, 3])
def test_a_steady_circles_understeer_gradient_is_its_slip_angles(vehicle_set):
    """On a steady circle at 20 m/s the steering beyond the geometric angle is the rear minus the front slip angle,
    ``delta - L / R = alpha_r - alpha_f``; its slope over 0.15-0.45 g is the understeer gradient.  The Ford
    Escort (front-heavy, front drive) understeers; the BMW 320i is near neutral (camber and compliance)."""
    p = vehicle_parameters(vehicle_set)
    L = p.a + p.b
    rows = []
    for delta in (0.01, 0.03):
        o = _steady_circle(vehicle_set, delta)
        ay = o["vx"] * o["yaw_rate"]
        excess = delta - L * o["yaw_rate"] / o["vx"]
        assert excess == pytest.approx(o["alpha_r"] - o["alpha_f"], abs=2e-4)      # small-angle kinematics
        # the body-fixed accelerometer reads the circle's acceleration and, tilted by the roll, gravity's share
        assert o["ay"] == pytest.approx(math.cos(o["roll"]) * ay + math.sin(o["roll"]) * GRAVITY, rel=0.02)
        assert o["roll"] > 0.0 and o["Fz_fr"] > o["Fz_fl"] and o["omega_fr"] > o["omega_fl"]   # a left turn
        rows.append((ay, excess))
    gradient = (rows[1][1] - rows[0][1]) / (rows[1][0] - rows[0][0])       # rad per m/s2
    expected = {1: (3e-4, 8e-4), 2: (-2e-4, 1e-4), 3: (0.5e-4, 3e-4)}[vehicle_set]
    assert expected[0] < gradient < expected[1], gradient


def test_friction_bank_and_the_yaw_moment_request():
    def run(steps=1500, **u):
        plant = CommonRoadPlant(CommonRoadConfig(vehicle_set=2, vx0=20.0))
        for k in range(steps):
            plant.step(1e-3, **u)
        return plant

    # the friction scales the tires' peak: a steer that takes 0.75 g on a dry road saturates at about 0.4 g on 0.4
    dry, icy = run(3000, delta_f=0.05, mu=1.0), run(3000, delta_f=0.05, mu=0.4)
    a_dry = abs(dry.output_dict()["vx"] * dry.output_dict()["yaw_rate"])
    a_icy = abs(icy.output_dict()["vx"] * icy.output_dict()["yaw_rate"])
    assert a_icy < 0.45 * GRAVITY < 0.7 * GRAVITY < a_dry
    # a bank, left side up, pulls the car to the right and the accelerometer reads the tires' g sin(bank)
    bank = run(1000, bank_angle=0.05).output_dict()
    assert bank["vy"] < -0.005 and bank["ay"] == pytest.approx(GRAVITY * math.sin(0.05), rel=0.25)
    assert bank["roll"] > 0.05
    # Mz_dyc: the motors' torque difference, limited and lagged, turns the car left
    plain, yawed = run(1000).output_dict(), run(1000, Mz_dyc=1000.0).output_dict()
    assert yawed["Mz_act"] == pytest.approx(1000.0, rel=1e-6) and yawed["yaw_rate"] > plain["yaw_rate"] + 0.02
    capped = run(200, Mz_dyc=1e5).output_dict()
    p = vehicle_parameters(2)                      # the motors' largest torque difference times track / radius
    assert capped["Mz_act"] == pytest.approx(CommonRoadConfig().motor_T_max * p.T_f / p.R_w, rel=1e-3)
    # braking down to walking speed: the car decelerates by the brake torque, no wheel spins backward
    stop = run(2400, T_brake=3000.0).output_dict()
    assert 1.0 < stop["vx"] < 3.0 and min(stop[f"omega_{w}"] for w in ("fl", "fr", "rl", "rr")) >= 0.0


def test_bad_inputs_and_parameters_are_refused():
    with pytest.raises(ValueError, match="vehicle_set"):
        CommonRoadConfig(vehicle_set=4)
    plant = CommonRoadPlant(CommonRoadConfig(vx0=10.0))
    with pytest.raises(ValueError, match="finite"):
        plant.step(1e-3, float("nan"))


# ---------------------------------------------------------------- the FMU
def test_the_fmu_equals_the_library_and_restores_its_state(harness):
    params = dict(vehicle_set=3, vx0=15.0, motor_axle=1)
    fmu = harness("CommonRoadPlant")
    fmu.init(**params)
    lib = CommonRoadPlant(CommonRoadConfig(**params))
    assert fmu.outputs() == pytest.approx(list(lib.outputs()), abs=1e-12)
    for k in range(1200):
        t = k * 1e-3
        u = dict(delta_f=_steer(t), T_drive=300.0, T_brake=0.0, Mz_dyc=500.0 * math.sin(3.0 * t), mu=0.8,
                 bank_angle=0.01, F_wind_y=20.0, M_wind_z=-5.0)
        assert fmu.step(**u) == 0
        lib.step(1e-3, **u)
    assert np.max(np.abs(np.array(fmu.outputs()) - np.array(lib.outputs()))) <= 1e-9

    def drive():
        out = []
        for k in range(300):
            fmu.step(delta_f=0.02, T_drive=100.0, mu=1.0)
            out.append(fmu.outputs())
        return out
    assert_save_restore_repeats(fmu, drive)


def test_a_closed_loop_with_the_projects_driver_and_sensors_through_fmpy(fmu_dir):
    from sideslip.cosim.assembly import Component
    from sideslip.cosim.master import CoSimulation

    components = [
        Component("ManeuverDriver", "driver", {"vehicle": "park2018_sonata",
                                               "maneuver": "sine_steer:v0=20,v=20,amplitude=1.0,frequency=0.5,"
                                                           "cycles=2,t_start=1"}),
        Component("CommonRoadPlant", "plant", {"vehicle_set": 2, "vx0": 20.0}),
        Component("VehicleSensors", "sensors", {"seed": 2}),
        Component("SideslipFusion", "estimator", {"vehicle": "park2018_sonata"}),
    ]
    with CoSimulation(components, step=1e-3, fmu_dir=fmu_dir) as sim:
        res = sim.run(6.0)
    beta, speed = np.asarray(res["plant.beta"]), np.asarray(res["plant.vx"])
    assert np.max(np.abs(beta)) > math.radians(0.3) and np.all(np.abs(speed - 20.0) < 2.0)
    assert np.all(np.isfinite(np.asarray(res["estimator.beta_hat"])))
