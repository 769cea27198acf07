"""The built FMUs through fmpy: modelDescription quality, FMU = library, state, reset, bad inputs/params."""
import math
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from sideslip.fmi.build import build_fmus
from sideslip.fmi.catalogue import CATALOGUE
from sideslip.plant.driver import Driver, DriverConfig
from sideslip.plant.sensors import SensorConfig, SensorSuite
from sideslip.plant.vehicle import PlantConfig, VehiclePlant
from sideslip.signals import SIGNALS

from conftest import FmuHarness, assert_save_restore_repeats

FMUS = sorted(CATALOGUE)
PLANT_FMUS = ["VehiclePlant", "VehicleSensors", "ManeuverDriver"]
RNG = np.random.default_rng(0)


# ---------------------------------------------------------------- modelDescription
@pytest.mark.parametrize("name", FMUS)
def test_fmpy_validate_reports_no_problem(fmu_dir, name):
    assert validate_fmu(str(fmu_dir / f"{name}.fmu")) == []


@pytest.mark.parametrize("name", FMUS)
def test_ports_equal_the_catalogue(fmu_dir, name):
    md = read_model_description(str(fmu_dir / f"{name}.fmu"))
    entry = CATALOGUE[name]
    ins = [v for v in md.modelVariables if v.causality == "input"]
    outs = [v for v in md.modelVariables if v.causality == "output"]
    assert [v.name for v in ins] == list(entry.inputs)
    assert [v.name for v in outs] == list(entry.outputs)
    for v in ins + outs:
        sig = SIGNALS[v.name]
        assert v.type == sig.kind and v.description == sig.description
        if v.type == "Real":
            assert v.unit == sig.unit and v.declaredType.name == sig.quantity
            assert float(v.min) == sig.min and float(v.max) == sig.max
            assert float(v.start) == sig.start


@pytest.mark.parametrize("name", FMUS)
def test_model_description_quality_bar(fmu_dir, name):
    md = read_model_description(str(fmu_dir / f"{name}.fmu"))
    cs = md.coSimulation
    assert cs.needsExecutionTool is False and cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    assert md.defaultExperiment is not None and md.defaultExperiment.stepSize == "0.001"
    assert md.description and {u.name for u in md.unitDefinitions}
    for v in md.modelVariables:
        assert v.description, v.name
        if v.type == "Real":
            assert v.unit and v.declaredType is not None, v.name
            assert v.min is not None and v.max is not None, v.name
        if v.causality == "parameter":
            assert v.variability in ("fixed", "tunable") and v.initial == "exact", v.name
        if v.causality == "output":
            assert v.initial == "exact" and v.start is not None, v.name
    for unknown in md.outputs:
        assert unknown.dependencies == [], unknown.variable.name


def test_shim_is_installed(fmu_dir):
    import zipfile

    names = zipfile.ZipFile(fmu_dir / "VehiclePlant.fmu").namelist()
    assert "binaries/linux64/VehiclePlant.so" in names and "binaries/linux64/pythonfmu_export.so" in names
    (package,) = {n.split("/")[1] for n in names if re.match(r"resources/sideslip_[0-9a-f]{12}/", n)}
    assert f"resources/{package}/plant/vehicle.py" in names and f"resources/{package}/vehicles/pi2011_suv.toml" in names
    assert f"resources/sideslip_plant_fmu_{package[-12:]}.py" in names          # the wrapper of the same build
    # bytecode: only the bundled package's (validated by the sources' hashes, fmi/build.py)
    pycs = [n for n in names if "__pycache__" in n]
    assert pycs and all(n.startswith(f"resources/{package}/") and n.endswith(".pyc") for n in pycs)


# ---------------------------------------------------------------- FMU equals library
def _plant_inputs(k):
    t = k * 1e-3
    return dict(delta_f=0.05 * math.sin(1.3 * t), T_drive=300.0 + 200 * math.sin(0.7 * t), T_brake=0.0,
                Mz_dyc=400.0 * math.sin(2.0 * t), mu=0.7, bank_angle=0.02, F_wind_y=50.0, M_wind_z=-20.0)


def test_plant_fmu_equals_library(harness):
    params = dict(vehicle="nguyen2012_coms", vx0=8.0, vehicle_overrides="I_zz=260")
    fmu = harness("VehiclePlant")
    fmu.init(**params)
    lib = VehiclePlant(PlantConfig(**params))
    assert fmu.outputs() == pytest.approx(list(lib.outputs()), abs=1e-12)
    for k in range(1500):
        u = _plant_inputs(k)
        assert fmu.step(**u) == 0
        lib.step(1e-3, **u)
        assert np.max(np.abs(np.array(fmu.outputs()) - np.array(lib.outputs()))) <= 1e-12


def test_sensors_fmu_equals_library(harness):
    params = dict(seed=4, gps_rate=10.0, gps_delay=0.2, mag_dist_count=2, mag_dist_horizon=2.0,
                  steer_fault="offset", steer_fault_time=1.0, steer_fault_offset=0.02)
    fmu = harness("VehicleSensors")
    fmu.init(**params)
    lib = SensorSuite(SensorConfig(**params))
    names = SensorSuite.input_names
    for k in range(2000):
        truth = [0.1 * k % 3, 0.5, 0.02, 0.01, 0.03, 40.0, 41.0, 39.0, 40.5, 11.0, 0.2, 0.001 * k, 0.01]
        assert fmu.step(**dict(zip(names, truth))) == 0
        lib.step(1e-3, *truth)
        assert fmu.outputs() == list(lib.outputs())


def test_driver_fmu_equals_library(harness):
    params = dict(vehicle="kim2016_asm", maneuver="double_lane_change:v0=15,v=15,lead_in=20",
                  road_mu="0:1, 3:0.5")
    fmu = harness("ManeuverDriver")
    fmu.init(**params)
    lib = Driver(DriverConfig(**params))
    assert fmu.outputs() == pytest.approx(list(lib.outputs()), abs=1e-12)
    for k in range(3000):
        x = 15.0 * k * 1e-3
        y = 0.002 * k
        fmu.step(vx=15.0, X=x, Y=y, yaw=0.01)
        lib.step(1e-3, 15.0, x, y, 0.01)
        assert fmu.outputs() == list(lib.outputs())


# ---------------------------------------------------------------- state, reset, instances
@pytest.mark.parametrize("name,params", [
    ("VehiclePlant", dict(vx0=15.0)),
    ("VehicleSensors", dict(seed=3, gps_delay=0.3, mag_dist_count=2, mag_dist_horizon=3.0)),
    ("ManeuverDriver", dict(maneuver="track:v0=10,v=12")),
])
def test_save_restore_and_serialisation_continue_identically(harness, name, params):
    fmu = harness(name)
    fmu.init(**params)
    ins = [v.name for v in fmu.md.modelVariables if v.causality == "input" and v.type == "Real"]

    def drive(n, k0):
        out = []
        for k in range(k0, k0 + n):
            fmu.step(**{nm: 0.01 * ((k * (i + 3)) % 17) + (10.0 if nm == "vx" else 0.0) for i, nm in enumerate(ins)})
            out.append(fmu.outputs())
        return out

    drive(700, 0)
    assert_save_restore_repeats(fmu, lambda: drive(500, 700))


def test_reset_gives_a_fresh_instance(harness):
    a = harness("VehiclePlant", "a")
    a.init(vx0=12.0)
    for k in range(300):
        a.step(**_plant_inputs(k))
    a.fmu.reset()
    a.t = 0.0
    a.init(vx0=12.0)
    b = harness("VehiclePlant", "b")
    b.init(vx0=12.0)
    for k in range(300):
        a.step(**_plant_inputs(k))
        b.step(**_plant_inputs(k))
        assert a.outputs() == b.outputs()


def test_two_instances_are_independent(harness):
    a, b = harness("VehiclePlant", "a"), harness("VehiclePlant", "b")
    a.init(vehicle="pi2011_suv", vx0=20.0)
    b.init(vehicle="kim2016_asm", vx0=10.0)
    ref_a = VehiclePlant(PlantConfig(vehicle="pi2011_suv", vx0=20.0))
    ref_b = VehiclePlant(PlantConfig(vehicle="kim2016_asm", vx0=10.0))
    for k in range(500):
        u = _plant_inputs(k)
        a.step(**u)
        ref_a.step(1e-3, **u)
        u["delta_f"] = -u["delta_f"]
        b.step(**u)
        ref_b.step(1e-3, **u)
    assert a.outputs() == list(ref_a.outputs()) and b.outputs() == list(ref_b.outputs())


# ---------------------------------------------------------------- bad inputs and parameters
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_nan_or_inf_input_is_held_with_fmi2ok_a_warning_per_episode_and_a_count(harness, bad):
    """OMSimulator and fmusim stop on fmi2Warning: a held input is fmi2OK, a logStatusWarning message
    at the start of each bad episode (at most one per second per input, the rest counted) and the
    output inputs_held."""
    fmu = harness("VehiclePlant")
    fmu.init(vx0=15.0)
    for k in range(10):
        fmu.step(delta_f=0.02)
    assert fmu.step(delta_f=bad, mu=bad) == 0                   # fmi2OK, no crash
    assert all(math.isfinite(v) for v in fmu.outputs()) and fmu.get("inputs_held") == [2.0]
    held = [(s, c, m) for (s, m), c in zip(fmu.messages, fmu.categories) if "'delta_f'" in m]
    assert held == [(1, "logStatusWarning", held[0][2])] and "holding the last valid value 0.02" in held[0][2]
    for k in range(50):                                         # the same episode: not logged again
        assert fmu.step(delta_f=bad) == 0
    assert all(math.isfinite(v) for v in fmu.outputs())
    fmu.step(delta_f=0.01, mu=1.0)                              # the episodes end
    assert fmu.get("inputs_held") == [0.0]
    fmu.step(delta_f=bad)                                       # a new one 0.05 s later: counted, not logged
    for k in range(1000):
        fmu.step(delta_f=0.01)
    fmu.step(delta_f=bad)                                       # a third, 1 s later: logged with the count
    delta = [m for s, m in fmu.messages if "'delta_f'" in m]
    assert len(delta) == 2 and "(1 more episode since the last report)" in delta[1]


def test_out_of_range_input_is_clamped_with_fmi2ok_and_a_warning(harness):
    fmu = harness("VehiclePlant")
    fmu.init(vx0=15.0)
    assert fmu.step(mu=5.0) == 0
    assert any("'mu' = 5 outside [0.05, 1.5]" in m for s, m in fmu.messages if s == 1)
    assert fmu.get("inputs_held") == [1.0]


@pytest.mark.parametrize("name,params,param_name,allowed", [
    ("VehiclePlant", dict(vehicle_overrides="m=-5"), "vehicle.m", "(0, 100000] kg"),
    ("VehiclePlant", dict(vehicle_overrides="l_f=0, l_r=0"), "vehicle.l_f", "(0, 10] m"),
    ("VehiclePlant", dict(vehicle="no_such_car"), "vehicle", "pi2011_suv"),
    ("VehiclePlant", dict(v_min=-1.0), "v_min", "(0.05, 5] m/s"),
    ("VehicleSensors", dict(gps_rate=0.0), "gps_rate", "[0.1, 100] Hz"),
    ("VehicleSensors", dict(gps_outages="9-3"), "gps_outages", "start < end"),
    ("ManeuverDriver", dict(maneuver="sine_steer:frequency=0"), "maneuver sine_steer: frequency", "(0, 10] Hz"),
])
def test_bad_parameter_gives_fmi2error_naming_it(harness, name, params, param_name, allowed):
    fmu = harness(name)                 # logging off: errors must still be reported
    fmu.fmu.setupExperiment(startTime=0.0)
    fmu.fmu.enterInitializationMode()
    fmu.set(**params)
    with pytest.raises(FMICallException) as e:
        fmu.fmu.exitInitializationMode()
    assert e.value.status == 3                                   # fmi2Error, not fmi2Fatal
    errors = [m for s, m in fmu.messages if s == 3]
    assert errors and f"parameter '{param_name}'" in errors[0] and allowed in errors[0]
    with pytest.raises(FMICallException) as e:
        fmu.fmu.doStep(0.0, 1e-3)
    assert e.value.status == 3


def test_setting_an_output_or_fixed_parameter_late_is_refused(harness):
    fmu = harness("VehiclePlant")
    fmu.init()
    for name in ("vx0", "vx"):                                  # a fixed parameter after init, an output
        with pytest.raises(FMICallException) as e:
            fmu.fmu.setReal([fmu.vars[name].valueReference], [30.0])
        assert e.value.status == 3                              # fmi2Error
    assert fmu.get("vx0", "vx") == [0.0, 0.0]
    errors = [m for s, m in fmu.messages if s == 3]
    assert "fixed parameter 'vx0' cannot change" in errors[0] and "'vx' is an output" in errors[1]


def test_port_fast_path_and_python_path_agree(harness):
    """The shim serves all-port get/set calls from the shared buffer; a call mixing a port with a
    parameter goes through pythonfmu.  Both must see the same values."""
    fmu = harness("VehiclePlant")
    fmu.init(vx0=10.0)
    vr_delta, vr_vx, vr_vx0 = (fmu.vars[n].valueReference for n in ("delta_f", "vx", "vx0"))
    fmu.fmu.setReal([vr_delta], [0.03])                          # fast path
    assert fmu.fmu.getReal([vr_delta, vr_vx0]) == [0.03, 10.0]   # through Python
    fmu.step()
    fast = fmu.fmu.getReal([vr_vx])[0]
    slow = fmu.fmu.getReal([vr_vx, vr_vx0])[0]
    assert fast == slow


# ---------------------------------------------------------------- packaging
def test_fmu_runs_from_its_own_resources_in_a_fresh_process(fmu_dir, tmp_path):
    """Separate interpreter whose sys.path lacks the source tree: the FMU must import the
    sideslip package bundled in its resources (a packaging error cannot hide behind ours)."""
    script = textwrap.dedent(f"""
        import sys
        sys.path[:] = [p for p in sys.path if "fmu_src" not in p and p not in ("", ".")]
        from fmpy import simulate_fmu
        res = simulate_fmu({str(fmu_dir / 'VehiclePlant.fmu')!r}, stop_time=0.5, output_interval=0.1,
                           start_values={{"vx0": 12.0, "vehicle": "park2018_sonata"}},
                           input=None, fmi_call_logger=None)
        assert "sideslip" not in sys.modules
        (pkg,) = [m for name, m in sys.modules.items() if name.startswith("sideslip_") and "." not in name
                  and not name.endswith("_fmu") and not name.count("_fmu_")]
        print("SIDESLIP_FROM", pkg.__file__)
        print("VX", res["vx"][-1])
    """)
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"/resources/sideslip_[0-9a-f]{12}/__init__.py", proc.stdout)
    vx = float(proc.stdout.split("VX")[1])
    assert 11.0 < vx < 12.0


def test_build_without_a_compiler_keeps_the_plain_binary(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("CC", raising=False)
    messages = []
    (path,) = build_fmus(["VehiclePlant"], tmp_path / "plain", force=True, log=messages.append)
    assert any("no C compiler" in m for m in messages) and any("no mingw-w64 cross compiler" in m for m in messages)
    import zipfile
    names = zipfile.ZipFile(path).namelist()
    assert "binaries/linux64/pythonfmu_export.so" not in names and "binaries/win64/pythonfmu_export.dll" not in names
    fmu = FmuHarness(path, "plain")
    try:
        fmu.init(vx0=10.0)
        lib = VehiclePlant(PlantConfig(vx0=10.0))
        for k in range(200):
            fmu.step(**_plant_inputs(k))
            lib.step(1e-3, **_plant_inputs(k))
        assert fmu.outputs() == list(lib.outputs())
    finally:
        fmu.close()


def test_parallel_builds_of_the_same_fmu_build_it_once_and_never_expose_a_partial_file(tmp_path):
    """Tuning studies start workers that all ensure the same FMUs: the build lock serialises them."""
    import subprocess
    import sys
    import zipfile

    code = ("import sys; from sideslip.fmi.build import build_fmus; "
            "build_fmus(['OpenLoopKinematic'], sys.argv[1], log=lambda m: print(m, flush=True))")
    procs = [subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], stdout=subprocess.PIPE, text=True)
             for _ in range(2)]
    logs = [p.communicate(timeout=120)[0] for p in procs]
    assert all(p.returncode == 0 for p in procs)
    assert sum("OpenLoopKinematic: built" in log for log in logs) == 1
    assert sum("OpenLoopKinematic: up to date" in log for log in logs) == 1
    assert zipfile.ZipFile(tmp_path / "OpenLoopKinematic.fmu").testzip() is None
    assert not list(tmp_path.glob("*.part"))


def test_requirements_are_bundled_for_pythonfmu_deploy(fmu_dir):
    """resources/requirements.txt lists what the FMU imports (derived, not hand-written) with the
    project's version ranges, and `pythonfmu deploy` accepts it."""
    import zipfile

    def reqs(name):
        text = zipfile.ZipFile(fmu_dir / f"{name}.fmu").read("resources/requirements.txt").decode()
        return {line.split("<")[0].split(">")[0].split("=")[0].strip() for line in text.splitlines()
                if line and not line.startswith("#")}

    assert reqs("VehiclePlant") == {"numpy"}
    assert reqs("LqrDycController") == {"numpy", "scipy", "control"}      # scipy: the feed-forward's state space
    assert reqs("Park2018Observer") == {"numpy", "scipy"}
    assert "control" in reqs("StabilityController")         # it embeds estimators and the LQR
    proc = subprocess.run([sys.executable, "-m", "pythonfmu", "deploy", "-f", str(fmu_dir / "LqrDycController.fmu")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "Requirement already satisfied: control" in proc.stdout
