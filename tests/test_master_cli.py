"""The fmpy master, metrics, plots and the CLI."""
import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pytest

from sideslip.cosim.assembly import Component, MasterError
from sideslip.cosim.master import CoSimulation
from sideslip.studies.metrics import estimate_metrics, format_table, scenario_summary
from sideslip.units import wrap_angle
from sideslip.cosim.assembly import scenario_components
from sideslip.studies.runs import run_library, run_scenario
from sideslip.scenarios import get_scenario
from sideslip.params import build
from sideslip.plant.driver import Driver, DriverConfig
from sideslip.plant.loop import run_loop
from sideslip.plant.sensors import SensorConfig, SensorSuite
from sideslip.plant.vehicle import PlantConfig, VehiclePlant


def test_fmu_closed_loop_equals_library_closed_loop(fmu_dir):
    """Same scenario, same Gauss-Seidel order: the FMUs under the master reproduce the
    library loop sample for sample (so the master adds nothing but transport)."""
    sc = get_scenario("park2018_case2", duration=3.0)
    comps, conns = scenario_components(sc)
    with CoSimulation(comps, conns, fmu_dir=fmu_dir) as sim:
        res = sim.run(3.0)
    lib = run_loop(VehiclePlant(build(PlantConfig, sc.plant_params())), Driver(build(DriverConfig, sc.driver_params())),
                   3.0, sensors=SensorSuite(build(SensorConfig, sc.sensor_params())))
    assert np.array_equal(res["time"], lib["time"])
    for inst, names in (("plant", VehiclePlant.output_names), ("driver", Driver.output_names),
                        ("sensors", SensorSuite.output_names)):
        for n in names:
            assert np.max(np.abs(res[f"{inst}.{n}"].astype(float) - lib[n])) <= 1e-12, f"{inst}.{n}"
    assert res.meta["unconnected_inputs"] == ["plant.Mz_dyc"]
    assert "driver.delta_f -> plant.delta_f" in res.meta["connections"]
    assert "driver.delta_f -> sensors.delta_f" in res.meta["connections"]
    assert res.data.dtype["sensors.gps_fresh"] == np.bool_


def test_record_every_and_csv(fmu_dir, tmp_path):
    comps, conns = scenario_components(get_scenario("pi2011_low"))
    with CoSimulation(comps, conns, fmu_dir=fmu_dir, record_every=10) as sim:
        res = sim.run(0.5)
    assert len(res.data) == 51 and res["time"][1] == pytest.approx(0.01)
    res.to_csv(tmp_path / "r.csv")
    header = (tmp_path / "r.csv").read_text().splitlines()[0].split(",")
    assert header[0] == "time" and "plant.beta" in header and "sensors.gps_valid" in header


def test_connection_errors_are_explicit(fmu_dir):
    comps = [Component("VehiclePlant", "p1"), Component("VehiclePlant", "p2"), Component("VehicleSensors", "s")]
    with pytest.raises(MasterError, match=r"s.ax could come from p1.ax, p2.ax"):
        CoSimulation(comps, fmu_dir=fmu_dir).setup()
    conns = [(f"p1.{n}", f"s.{n}") for n in SensorSuite.input_names if n != "delta_f"]
    with CoSimulation(comps, conns, fmu_dir=fmu_dir) as sim:
        res = sim.run(0.01)
    assert "s.delta_f" in res.meta["unconnected_inputs"]
    with pytest.raises(MasterError, match="no output 'nope'"):
        CoSimulation(comps, [("p1.nope", "s.ax")], fmu_dir=fmu_dir).setup()
    with pytest.raises(MasterError, match="parameters are:"):
        CoSimulation([Component("VehiclePlant", parameters={"mass": 3})], fmu_dir=fmu_dir).setup()
    with pytest.raises(MasterError, match="unique"):
        CoSimulation([Component("VehiclePlant"), Component("VehiclePlant")], fmu_dir=fmu_dir)


def test_master_reports_fmu_errors_with_their_messages(fmu_dir):
    comps = [Component("VehiclePlant", parameters={"vehicle_overrides": "m=-1"})]
    with pytest.raises(MasterError, match=r"parameter 'vehicle.m' = -1.0 is invalid"):
        CoSimulation(comps, fmu_dir=fmu_dir).setup()


_TWO_THREADS = """
import sys, threading
from pathlib import Path
from sideslip.cosim.assembly import Component
from sideslip.cosim.master import CoSimulation
fmus, out, errors = Path(sys.argv[1]), {}, []

def loop(k):
    try:
        comps = [Component(str(fmus / "ManeuverDriver.fmu"), "driver", {"vehicle": "pi2011_suv", "maneuver":
                           "sine_steer:v0=15,v=15,amplitude=1,frequency=0.5,cycles=1,t_start=0.1"}),
                 Component(str(fmus / "VehiclePlant.fmu"), "plant", {"vehicle": "pi2011_suv", "vx0": 15.0}),
                 Component(str(fmus / "VehicleSensors.fmu"), "sensors", {"seed": k}),
                 Component(str(fmus / "Kim2016SteeringEKF.fmu"), "est", {"vehicle": "pi2011_suv"})]
        with CoSimulation(comps, step=1e-3) as sim:
            out[k] = float(sim.run(0.5)["plant.beta"][-1])
    except Exception as exc:
        errors.append(repr(exc))
threads = [threading.Thread(target=loop, args=(k,)) for k in range(2)]
for t in threads:
    t.start()
for t in threads:
    t.join()
print(out, errors)
sys.exit(1 if errors or len(out) != 2 or out[0] != out[1] else 0)
"""


def test_two_loops_in_two_threads_of_a_fresh_process(fmu_dir):
    """The unpack cache is shared by the threads of a process (without its lock: a segfault in 4 of 4 runs)."""
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", _TWO_THREADS, str(fmu_dir)], capture_output=True, text=True,
                              timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr[-2000:]


def test_profile_mode_times_each_component(fmu_dir):
    comps, conns = scenario_components(get_scenario("pi2011_low"))
    with CoSimulation(comps, conns, fmu_dir=fmu_dir) as sim:
        res = sim.run(0.5, profile=True)
    assert set(res.meta["profile"]) == {"driver", "plant", "sensors"}
    assert all(len(v) == 5 and min(v) > 0 for v in res.meta["profile"].values())


@pytest.mark.parametrize("scheme", ["gauss-seidel", "jacobi"])
def test_boolean_inputs_are_set_when_they_change(fmu_dir, scheme):
    """A Boolean input keeps its value until it is set again (FMI 2.0): the master sets the estimator's GNSS flags at
    the first step and at each change only, and the estimate is the library loop's, which is given every value."""
    sc = get_scenario("park2018_case2", duration=2.0)
    comps, conns = scenario_components(sc, ["SideslipFusion"])
    calls = {}
    with CoSimulation(comps, conns, fmu_dir=fmu_dir, scheme=scheme) as sim:
        for inst in sim._instances:
            fn = inst._fn["fmi2SetBoolean"]

            def counted(*args, _fn=fn, _name=inst.name):
                calls[_name] = calls.get(_name, 0) + 1
                return _fn(*args)
            inst._fn["fmi2SetBoolean"] = counted
        res = sim.run(2.0)
    flags = np.column_stack([res["sensors.gps_fresh"], res["sensors.gps_valid"]])
    seen = flags[1:] if scheme == "gauss-seidel" else flags[:-1]      # what the estimator is given at each step
    changes = int(np.count_nonzero(np.any(seen[1:] != seen[:-1], axis=1)))
    assert changes > 50                                               # the fix flag: on and off at 50 Hz
    assert calls == {"SideslipFusion": 1 + changes}
    if scheme == "gauss-seidel":
        lib = run_library(sc, ["SideslipFusion"], duration=2.0)
        for name in ("beta_hat", "vx_hat", "yaw_hat", "gps_delay_hat"):
            assert np.max(np.abs(res[f"SideslipFusion.{name}"] - lib[f"SideslipFusion.{name}"])) <= 1e-12, name


# ---------------------------------------------------------------- metrics
def _synthetic(beta_err=0.01):
    t = np.arange(0, 10, 0.01)
    beta = 0.05 * np.sin(t)
    return {"time": t, "plant.vx": np.full_like(t, 10.0), "plant.vy": 10 * np.tan(beta), "plant.beta": beta,
            "plant.yaw_rate": 0.1 * np.cos(t), "plant.ay": np.ones_like(t), "est.beta_hat": beta + beta_err,
            "est.valid": t > 1.0, "driver.delta_f": np.zeros_like(t)}


def test_estimate_metrics_on_known_errors():
    m = estimate_metrics(_synthetic(0.01), "est")
    assert m["beta_hat"]["rms"] == pytest.approx(math.degrees(0.01))
    assert m["beta_hat"]["max"] == pytest.approx(math.degrees(0.01))
    peak = np.max(np.abs(0.05 * np.sin(np.arange(0, 10, 0.01))))
    assert m["beta_hat"]["norm_max_pct"] == pytest.approx(100 * 0.01 / peak)      # Pi 2011 eq 48
    assert m["valid"] == pytest.approx(0.9, abs=0.002) and m["coverage"] == 1.0
    assert "beta RMS" in format_table({"est": m})
    assert scenario_summary(_synthetic())["max_abs_beta_deg"] == pytest.approx(math.degrees(peak))


def test_angle_errors_wrap():
    assert wrap_angle(np.array([3 * math.pi / 2, -3 * math.pi / 2, math.pi]))== pytest.approx([-math.pi / 2, math.pi / 2, math.pi])
    data = _synthetic(0.0)
    data["est.beta_hat"] = data["plant.beta"] + 2 * math.pi
    assert estimate_metrics(data, "est")["beta_hat"]["max"] == pytest.approx(0.0, abs=1e-9)


def test_low_speed_samples_are_not_evaluated():
    data = _synthetic(0.01)
    data["plant.vx"][:500] = 0.5
    data["plant.vy"][:500] = 0.0
    data["est.beta_hat"][:500] = 1.0              # garbage while standing still
    m = estimate_metrics(data, "est")
    assert m["coverage"] == pytest.approx(0.5) and m["beta_hat"]["max"] == pytest.approx(math.degrees(0.01))


def test_samples_the_estimator_calls_invalid_are_not_evaluated():
    data = _synthetic(0.01)
    data["est.beta_hat"][:100] = 1.0              # garbage before the estimator is valid (t <= 1 s)
    m = estimate_metrics(data, "est")
    assert m["beta_hat"]["max"] == pytest.approx(math.degrees(0.01)) and m["samples"] == 899


def test_sub_estimates_are_scored_like_beta_hat():
    data = _synthetic(0.01)
    data["est.beta_hat_bicycle"] = data["plant.beta"] - 0.02
    m = estimate_metrics(data, "est")
    assert m["beta_hat_bicycle"]["rms"] == pytest.approx(math.degrees(0.02)) and "beta_hat_std" not in m


# ---------------------------------------------------------------- runner and CLI
def test_run_scenario_writes_results_metrics_and_plot(fmu_dir, tmp_path):
    out = run_scenario("nguyen2012_cornering", duration=1.0, out_dir=tmp_path, fmu_dir=fmu_dir)
    assert (tmp_path / "results.csv").stat().st_size > 0 and (tmp_path / "sideslip.png").stat().st_size > 10_000
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert m["scenario"]["name"] == "nguyen2012_cornering" and m["real_time_factor"] > 0
    assert out.metrics["summary"]["final_speed"] == pytest.approx(20 / 3.6, abs=0.05)


def test_cli_smoke_run(fmu_dir, tmp_path):
    cmd = [sys.executable, "-m", "sideslip", "--fmu-dir", str(fmu_dir), "run", "--scenario", "pi2011_medium",
           "--duration", "1.0", "--out", str(tmp_path / "o"), "--set", "road_mu=0.4"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "scenario pi2011_medium" in proc.stdout and "x real time" in proc.stdout
    m = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert m["scenario"]["road_mu"] == "0.4"
    proc = subprocess.run([sys.executable, "-m", "sideslip", "list"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "park2018_case5" in proc.stdout and "VehiclePlant" in proc.stdout
    proc = subprocess.run([sys.executable, "-m", "sideslip", "--fmu-dir", str(fmu_dir), "run", "--scenario",
                           "nope"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "list scenarios" in proc.stderr and "Traceback" not in proc.stderr


def test_cli_run_names_the_sensor_offsets_and_what_the_estimators_assume(fmu_dir, tmp_path):
    cmd = [sys.executable, "-m", "sideslip", "--fmu-dir", str(fmu_dir), "run", "--scenario", "park2018_case2",
           "--duration", "0.5", "--out", str(tmp_path / "o"), "--set", "sensor_ax_bias=0",
           "--estimator", "nguyen=Nguyen2012DACMRKF", "--estimator", "Park2018Observer"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "sensor offsets: ay 0.15 m/s2, yaw_rate 0.00873 rad/s\n" in proc.stdout     # ax set to 0
    assert "  nguyen: as published (profile 0): an offset-free yaw rate" in proc.stdout
    assert "Park2018Observer:" not in proc.stdout                 # compensates its offsets: nothing to say


def test_cli_bench_json(fmu_dir):
    proc = subprocess.run([sys.executable, "-m", "sideslip", "--fmu-dir", str(fmu_dir), "bench", "--json",
                           "--duration", "0.3", "--repeats", "1"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    b = json.loads(proc.stdout)
    assert set(b["fmus"]) >= {"VehiclePlant", "VehicleSensors", "ManeuverDriver"}
    assert b["closed_loop"]["real_time_factor"] > 0
    assert b["five_fmu_loop"]["components"][-2:] == ["SideslipFusion", "LqrDycController"]
    assert b["fmus"]["OpenLoopKinematic"]["x_floor"] == 1.0 and b["five_fmu_loop"]["x_floor"] > 3.0
    assert set(b["instantiation_s"]) == {"BaselineEsc", "LqrDycController", "StabilityController"}


@pytest.mark.parametrize("text,expected", [("false", False), ("0", False), ("off", False), ("true", True),
                                           ("yes", True)])
def test_boolean_parameters_given_as_text_mean_what_they_say(fmu_dir, text, expected):
    with CoSimulation([Component("Kim2016SteeringEKF", "kim", {"fault_latch": text})], fmu_dir=fmu_dir) as sim:
        (inst,) = sim._instances
        var = inst.vars["fault_latch"]
        assert inst.slave.getBoolean([var.valueReference]) == [expected]


def test_boolean_parameter_with_an_unknown_word_is_refused(fmu_dir):
    with pytest.raises(MasterError, match="fault_latch"):
        with CoSimulation([Component("Kim2016SteeringEKF", "kim", {"fault_latch": "maybe"})], fmu_dir=fmu_dir):
            pass


def test_loop_breakdown_splits_each_fmus_step_into_its_parts(fmu_dir):
    from sideslip.studies.speed import FIVE_FMU_LOOP, loop_breakdown

    b = loop_breakdown(0.3, fmu_dir)
    assert list(b) == ["ManeuverDriver", "VehiclePlant", "VehicleSensors", *FIVE_FMU_LOOP]
    for fmu, parts in b.items():
        inner = parts["fmi_call_and_ports"] + parts["checks"] + parts["model_step"] + parts["outputs"]
        assert parts["model_step"] > 0 and parts["outputs"] > 0, fmu
        assert inner == pytest.approx(parts["total"], rel=0.2), fmu
    assert b["VehiclePlant"]["model_step"] > b["VehicleSensors"]["model_step"]


def test_the_programs_whose_instructions_bench_counts_run():
    """``bench --instructions`` counts these programs under valgrind; here they run as they are."""
    from sideslip.studies import speed

    for code in (speed._PLANT_STEPS, speed._DRIVER_STEPS, speed._CONTROLLER_STEPS, speed._FUSION_STEPS):
        subprocess.run([sys.executable, "-c", code, "30"], check=True, capture_output=True)


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_callgrind_counts_the_instructions_of_a_loop():
    from sideslip.studies.speed import _instructions

    code = "import sys\nx = 0\nfor i in range(int(sys.argv[1])):\n    x += i * i\n"
    per_iteration = (_instructions(code, (60000,)) - _instructions(code, (10000,))) / 50000
    assert 20 < per_iteration < 2000
