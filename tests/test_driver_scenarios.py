"""Maneuvers, reference paths, the driver and the scenario registry."""
import math

import numpy as np
import pytest

from sideslip.scenarios import SCENARIOS, fmvss126_reference_angle, get_scenario, scenario_names
from sideslip.params import ParameterError, build
from sideslip.plant import paths as P
from sideslip.plant.driver import Driver, DriverConfig
from sideslip.plant.loop import run_loop
from sideslip.plant.maneuvers import MANEUVERS, TimeTable, maneuver_spec, parse_maneuver
from sideslip.plant.sensors import SensorConfig
from sideslip.plant.vehicle import PlantConfig, VehiclePlant

RAD_PER_DEG = math.pi / 180


# ---------------------------------------------------------------- paths
def test_closed_track_is_about_3_km_with_several_radii():
    track = P.closed_track()
    assert track.length == pytest.approx(3000.0, abs=1.0)
    assert math.hypot(track.x[-1] - track.x[0], track.y[-1] - track.y[0]) < 1.0       # closes
    radii = 1.0 / np.abs(track.kappa[np.abs(track.kappa) > 1e-3])
    for r in (40.0, 60.0, 80.0, 120.0, 150.0):
        assert np.any(np.abs(radii - r) < 0.5), r
    assert track.psi[-1] - track.psi[0] == pytest.approx(2 * math.pi, abs=0.02)       # one counter-clockwise lap


def test_iso3888_double_lane_change_geometry():
    path = P.offset_path(50.0, P.iso3888_dlc_offsets(3.5), tail=50.0)
    x, y = path.x, path.y
    assert np.all(y[x <= 50.0 + 15.0] == 0.0)                        # entry lane
    assert np.all(np.abs(y[(x >= 95.0) & (x <= 120.0)] - 3.5) < 1e-12)  # offset lane
    assert np.all(y[x >= 145.0] == 0.0)                              # exit lane


def test_path_projection_follows_progress_and_interpolates():
    path = P.arc_chain([(100.0, math.inf), (50.0, 20.0)], ds=0.5)
    idx, s = path.project(40.2, 0.3, hint=0)
    assert s == pytest.approx(40.0, abs=0.5)
    x, y = path.point_at(25.25)
    assert (x, y) == pytest.approx((25.25, 0.0))


# ---------------------------------------------------------------- maneuvers
def test_sine_with_dwell_timing_and_amplitude():
    man = parse_maneuver(maneuver_spec("sine_with_dwell", A=0.5, factor=3.0, t_start=2.0))
    plan = man.plan(None)
    f = 0.7
    assert man.amplitude == pytest.approx(1.5)
    assert plan.steer_sw(2.0 + 0.25 / f) == pytest.approx(1.5)               # first peak, left
    assert plan.steer_sw(2.0 + 0.75 / f) == pytest.approx(-1.5)              # second peak
    assert plan.steer_sw(2.0 + 0.75 / f + 0.49) == pytest.approx(-1.5)       # dwell
    assert plan.steer_sw(man.completion_of_steer) == pytest.approx(0.0, abs=1e-12)
    assert man.completion_of_steer == pytest.approx(2.0 + 1 / f + 0.5)
    capped = parse_maneuver(maneuver_spec("sine_with_dwell", A=1.0, factor=6.5))
    assert capped.amplitude == pytest.approx(270 * RAD_PER_DEG)                      # FMVSS 126 cap


def test_every_maneuver_parses_with_defaults_and_builds_a_plan():
    vehicle = VehiclePlant(PlantConfig()).vehicle
    for name in MANEUVERS:
        plan = parse_maneuver(name).plan(vehicle)
        assert plan.path.length > 0 and plan.v_ref(0.0) >= 0


@pytest.mark.parametrize("spec,name", [
    ("warp_speed", "maneuver"),
    ("sine_steer:frequency=-1", "maneuver sine_steer: frequency"),
    ("sine_steer:freq=1", "maneuver sine_steer: freq"),
    ("circle:radius=2", "maneuver circle: radius"),
])
def test_bad_maneuver_specs_name_the_parameter(spec, name):
    with pytest.raises(ParameterError) as e:
        parse_maneuver(spec)
    assert e.value.name == name


def test_time_table():
    tab = TimeTable("0:0, 1:10, 3:10, 4:0")
    assert [tab(t) for t in (-1, 0.5, 2, 3.5, 9)] == [0, 5, 10, 5, 0]
    assert TimeTable("0.8")(12.0) == 0.8
    for bad in ("a", "1:2, 0:3", "1:nan"):
        with pytest.raises(ParameterError):
            TimeTable(bad, "road_mu")


# ---------------------------------------------------------------- driver
def test_path_follower_and_speed_controller_track_a_lane_change():
    spec = maneuver_spec("lane_change", v0=15.0, v=15.0, lead_in=40.0, offset=3.5, length=40.0, duration=10.0)
    driver = Driver(DriverConfig(vehicle="park2018_sonata", maneuver=spec))
    res = run_loop(VehiclePlant(PlantConfig(vehicle="park2018_sonata", vx0=15.0)), driver, 10.0)
    path = driver.plan.path
    lateral = [abs(y - np.interp(x, path.x, path.y)) for x, y in zip(res["X"], res["Y"])]
    assert max(lateral) < 0.4
    assert np.max(np.abs(res["vx"] - 15.0)) < 0.2
    assert res["Y"][-1] == pytest.approx(3.5, abs=0.1)


def test_driver_launches_from_standstill_and_holds_the_brake():
    spec = maneuver_spec("straight", v0=0.0, v=10.0, t_go=2.0, accel=2.0, duration=12.0)
    driver = Driver(DriverConfig(vehicle="kim2016_asm", maneuver=spec))
    res = run_loop(VehiclePlant(PlantConfig(vehicle="kim2016_asm")), driver, 12.0)
    assert np.all(res["T_brake"][res["time"] < 2.0] > 0) and np.all(res["T_drive"][res["time"] < 2.0] == 0)
    assert res["vx"][res["time"] < 2.0].max() < 1e-3
    assert res["vx"][-1] == pytest.approx(10.0, abs=0.1)


def test_driver_emits_road_and_wind_tables():
    cfg = DriverConfig(road_mu="0:0.8, 2:0.8, 2.5:0.3", road_bank="0.05", wind_force="0:0, 1:100")
    d = Driver(cfg)
    for _ in range(3000):
        d.step(1e-3, 20.0, 0.0, 0.0, 0.0)
    o = d.output_dict()
    assert (o["mu"], o["bank_angle"], o["F_wind_y"]) == pytest.approx((0.3, 0.05, 100.0))
    with pytest.raises(ParameterError, match="road_mu"):
        DriverConfig(road_mu="2.0")


def test_driver_state_pickles_and_resumes_identically():
    import pickle

    d = Driver(DriverConfig(maneuver=maneuver_spec("track", v0=10.0, v=15.0, duration=50.0)))
    for k in range(500):
        d.step(1e-3, 10.0, k * 0.01, 0.0, 0.0)
    clone = pickle.loads(pickle.dumps(d))
    for k in range(500, 700):
        d.step(1e-3, 10.0, k * 0.01, 0.0, 0.0)
        clone.step(1e-3, 10.0, k * 0.01, 0.0, 0.0)
        assert d.outputs() == clone.outputs()


# ---------------------------------------------------------------- scenarios
REQUIRED = (["park2018_case%d" % i for i in range(1, 6)]
            + [f"yoon2014_{m}_{r}{b}" for m in ("slc", "dlc", "slalom", "jturn") for r in ("asphalt", "ice")
               for b in ("", "_banked")]
            + ["pi2011_high", "pi2011_medium", "pi2011_low", "nguyen2012_lanechange", "nguyen2012_cornering",
               "kim2016_track_40", "kim2016_track_80", "fmvss126_suv_mu05_a5.0"])


def test_every_required_scenario_is_registered():
    assert set(REQUIRED) <= set(scenario_names())


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scenario_configs_validate(name):
    sc = get_scenario(name)
    build(DriverConfig, sc.driver_params())
    build(PlantConfig, sc.plant_params())
    build(SensorConfig, sc.sensor_params())
    assert sc.source and sc.notes and sc.duration > 0


def test_scenarios_follow_their_papers():
    yoon = get_scenario("yoon2014_dlc_ice_banked")
    assert yoon.sensors["gps_delay"] == 0.4 and yoon.sensors["gps_rate"] == 5.0
    assert yoon.sensors["ax_bias"] == 0.5 and yoon.sensors["yaw_rate_bias"] == pytest.approx(2 * RAD_PER_DEG)
    assert float(yoon.road_mu) == 0.3 and float(yoon.road_bank) == pytest.approx(5.71 * RAD_PER_DEG)
    assert float(get_scenario("yoon2014_slc_asphalt_banked").road_bank) == pytest.approx(8.53 * RAD_PER_DEG)
    park = get_scenario("park2018_case5")
    assert park.vehicle == "park2018_sonata" and float(park.road_mu) == 0.3
    assert park.sensors["gps_rate"] == 20.0 and park.sensors["imu_rate"] == 100.0
    assert all(park.sensors[k] != 0 for k in ("ax_bias", "ay_bias", "yaw_rate_bias", "wheel_radius_error"))
    assert get_scenario("nguyen2012_cornering").sensors["gps_rate"] == 5.0
    assert get_scenario("kim2016_track_80").sensors["ay_sigma"] == 1.0
    for name, mu, v in (("pi2011_high", 0.8, 22.22), ("pi2011_medium", 0.5, 16.67), ("pi2011_low", 0.2, 11.11)):
        sc = get_scenario(name)
        assert float(sc.road_mu) == mu and sc.initial_speed == pytest.approx(v)


def test_scenario_overrides_and_errors():
    sc = get_scenario("pi2011_high", duration=2, maneuver_amplitude=0.5, sensor_seed=9, road_mu="0.7")
    assert sc.duration == 2.0 and parse_maneuver(sc.maneuver).amplitude == 0.5
    assert sc.sensors["seed"] == 9 and sc.road_mu == "0.7"
    with pytest.raises(ParameterError, match="scenario"):
        get_scenario("no_such_scenario")
    with pytest.raises(ParameterError):
        get_scenario("pi2011_high", maneuver_nonsense=1)


def test_fmvss126_reference_angle_gives_0p3g():
    a = fmvss126_reference_angle("pi2011_suv", 0.5)
    assert 20 * RAD_PER_DEG < a < 80 * RAD_PER_DEG
    sc = get_scenario("fmvss126_suv_mu05_a5.0")
    assert parse_maneuver(sc.maneuver).A == pytest.approx(a)


def test_the_sonata_family_is_the_sonatas_own_and_spins_uncontrolled_at_2a_on_mu05():
    from sideslip.studies.control_eval.measures import fmvss126_metrics
    sc = get_scenario("fmvss126_sonata_mu05_a2.0", maneuver_t_start=1.0, duration=5.0)
    man = parse_maneuver(sc.maneuver)
    assert sc.vehicle == "park2018_sonata" and man.A == pytest.approx(fmvss126_reference_angle("park2018_sonata", 0.5))
    res = run_loop(VehiclePlant(build(PlantConfig, sc.plant_params())), Driver(build(DriverConfig, sc.driver_params())),
                   sc.duration)
    arrays = {"time": res["time"], **{f"plant.{k}": res[k] for k in ("yaw_rate", "X", "Y", "yaw")},
              "driver.delta_sw": res["delta_sw"]}
    m = fmvss126_metrics(arrays, man.t_start, man.completion_of_steer, 2.0)
    assert not m["yaw_stable"] and m["yaw_rate_ratio_1s"] > 0.5


def test_path_follower_steers_smoothly_on_a_circle():
    """Regression: projecting onto path samples instead of segments made the look-ahead point
    jump by the sample spacing, a 36 Hz steering sawtooth (v / ds) in a steady turn."""
    spec = maneuver_spec("circle", v0=5.0, v=9.0, t_go=2.0, accel=1.0, radius=25.0, lead_in=10.0)
    res = run_loop(VehiclePlant(PlantConfig(vehicle="park2018_sonata", vx0=5.0)),
                   Driver(DriverConfig(vehicle="park2018_sonata", maneuver=spec)), 21.0)
    steady = slice(18000, 21000)
    assert np.ptp(res["delta_f"][steady]) < 2e-4
    assert np.ptp(res["ay"][steady]) < 0.03


@pytest.mark.parametrize("name", sorted(SCENARIOS) + ["fmvss126_suv_mu05_a6.5_right"])
def test_every_scenario_starts_cleanly(name):
    """Half a second of every scenario through the library loop: finite outputs, the initial
    speed as configured, sensors producing data."""
    from sideslip.plant.sensors import SensorSuite

    sc = get_scenario(name)
    res = run_loop(VehiclePlant(build(PlantConfig, sc.plant_params())), Driver(build(DriverConfig, sc.driver_params())),
                   0.5, sensors=SensorSuite(build(SensorConfig, sc.sensor_params())))
    assert all(np.all(np.isfinite(v)) for v in res.values())
    assert res["vx"][0] == pytest.approx(sc.initial_speed)
    assert res["mu"][-1] == pytest.approx(TimeTable(sc.road_mu)(0.5))
