"""What real hosts do to FMUs: the FMI lifecycle enforced, FMU states that are only data (fuzzed),
no per-instance leak, each FMU running its own code whatever happens to other FMUs' folders, and
parameters that fail with a message naming them."""
import ctypes
import json
import math
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

from sideslip.fmi.catalogue import CATALOGUE

ROOT = Path(__file__).resolve().parents[1]
FMUS = sorted(CATALOGUE)


def _status(call, *args):
    try:
        call(*args)
        return 0
    except FMICallException as exc:
        return exc.status


# ---------------------------------------------------------------- lifecycle
def test_a_wrong_guid_and_model_exchange_are_refused_at_instantiation(fmu_dir):
    path = fmu_dir / "Park2018Observer.fmu"
    md, unzip = read_model_description(str(path)), extract(str(path))
    lib = ctypes.CDLL(str(Path(unzip) / "binaries" / "linux64" / "Park2018Observer.so"))
    lib.fmi2Instantiate.restype = ctypes.c_void_p
    lib.fmi2Instantiate.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_void_p,
                                    ctypes.c_int, ctypes.c_int]
    messages = []

    def logger(env, name, status, category, message):
        messages.append((status, message.decode()))
    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    uri = (Path(unzip) / "resources").as_uri().encode()
    assert lib.fmi2Instantiate(b"a", 1, b"{not-this-fmu}", uri, ctypes.byref(cb), 0, 0) is None
    assert messages[-1][0] == 3 and "GUID '{not-this-fmu}'" in messages[-1][1] and md.guid in messages[-1][1]
    assert lib.fmi2Instantiate(b"b", 0, md.guid.encode(), uri, ctypes.byref(cb), 0, 0) is None   # Model Exchange
    assert messages[-1][0] == 3 and "Co-Simulation only" in messages[-1][1]
    comp = lib.fmi2Instantiate(b"c", 1, md.guid.encode(), uri, ctypes.byref(cb), 0, 0)
    assert comp is not None
    lib.fmi2FreeInstance.argtypes = [ctypes.c_void_p]
    lib.fmi2FreeInstance(comp)


def test_calls_in_the_wrong_state_and_communication_point_gaps_are_refused(harness):
    fmu = harness("VehiclePlant")
    f = fmu.fmu
    assert _status(f.exitInitializationMode) == 3                  # not in initialisation mode yet
    assert _status(f.fmi2DoStep, f.component, 0.0, 1e-3, 1) == 3   # not initialised
    fmu.init(vx0=10.0)
    assert _status(f.setupExperiment, None, 0.0) == 3              # after initialisation
    assert _status(f.enterInitializationMode) == 3
    for k in range(5):
        assert fmu.step(delta_f=0.01) == 0
    before = fmu.outputs()
    # a skipped interval and a repeated one: refused, nothing changed
    assert _status(f.fmi2DoStep, f.component, fmu.t + 1e-3, 1e-3, 1) == 3
    assert _status(f.fmi2DoStep, f.component, fmu.t - 1e-3, 1e-3, 1) == 3
    assert _status(f.fmi2DoStep, f.component, fmu.t, -1e-3, 1) == 3
    assert fmu.outputs() == before
    assert "a skipped or repeated interval" in fmu.messages[-3][1]
    # a non-finite communication point and a step longer than the bound: refused, nothing changed
    for point in (math.nan, math.inf):
        assert _status(f.fmi2DoStep, f.component, point, 1e-3, 1) == 3
        assert "is not finite" in fmu.messages[-1][1]
    assert _status(f.fmi2DoStep, f.component, fmu.t, 1e5, 1) == 3
    assert "longer than 10 s" in fmu.messages[-1][1]
    assert fmu.outputs() == before
    assert fmu.step(delta_f=0.01) == 0                             # at the right time it goes on
    f.terminate()
    assert _status(f.fmi2DoStep, f.component, fmu.t, 1e-3, 1) == 3     # after terminate
    assert "fmi2DoStep is not allowed in terminated" in fmu.messages[-1][1]
    assert _status(f.setReal, [fmu.vars["delta_f"].valueReference], [0.0]) == 3
    assert _status(f.terminate) == 3
    f.reset()                                                      # reset: a new instance
    fmu.t = 0.0
    fmu.init(vx0=10.0)
    assert fmu.step(delta_f=0.01) == 0


# ---------------------------------------------------------------- FMU state
_FUZZ = textwrap.dedent('''
    import ctypes, json, random, sys
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    def status(f, *a):
        try:
            f(*a)
            return 0
        except FMICallException as e:
            return e.status

    path, n = sys.argv[1], int(sys.argv[2])
    md = read_model_description(path)
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="fuzz")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    t = 0.0
    for k in range(50):
        s.doStep(t, 1e-3)
        t += 1e-3
    good = bytes(s.serializeFMUstate(s.getFMUstate()))
    rng = random.Random(7)
    seen = {}
    def deserialize_and_set(data):
        buf = (ctypes.c_char * max(len(data), 1)).from_buffer_copy(data or b"\\0")
        state = ctypes.c_void_p()
        r = status(s.fmi2DeSerializeFMUstate, s.component, buf, len(data), ctypes.byref(state))
        seen[r] = seen.get(r, 0) + 1
        if r == 0:
            r2 = status(s.fmi2SetFMUstate, s.component, state)
            seen["set", r2] = seen.get(("set", r2), 0) + 1
            status(s.fmi2FreeFMUstate, s.component, ctypes.byref(state))
    head = 37                                         # the frame: magic, version, length, checksum
    for i in range(n):
        kind = i % 5
        if kind == 0:
            data = bytes(rng.getrandbits(8) for _ in range(rng.randrange(0, 300)))
        elif kind == 1:
            data = good[:rng.randrange(0, len(good))]
        elif kind == 2:
            data = bytearray(good)
            for _ in range(rng.randrange(1, 6)):
                data[rng.randrange(len(data))] ^= rng.randrange(1, 256)      # xor: every byte really changes
            data = bytes(data)
        else:                                        # a valid frame around a damaged payload: for Python
            payload = bytearray(good[head:])
            if kind == 3:
                for _ in range(rng.randrange(1, 6)):
                    payload[rng.randrange(len(payload))] ^= rng.randrange(1, 256)
            else:
                payload = payload[:rng.randrange(len(payload))]
            h = 1469598103934665603
            for b in payload:
                h = ((h ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
            data = good[:21] + len(payload).to_bytes(8, "big") + h.to_bytes(8, "big") + bytes(payload)
        deserialize_and_set(data)
    for call in (lambda: status(s.fmi2SetFMUstate, s.component, None),
                 lambda: status(s.fmi2SerializedFMUstateSize, s.component, None, ctypes.byref(ctypes.c_size_t())),
                 lambda: status(s.fmi2FreeFMUstate, s.component, None)):
        seen["null", call()] = seen.get(("null", call()), 0) + 1
    # still usable, and save/restore exact
    s.doStep(t, 1e-3)
    t += 1e-3
    state = s.getFMUstate()
    blob = s.serializeFMUstate(state)
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    def run():
        nonlocal_t = t
        res = []
        for k in range(30):
            s.doStep(nonlocal_t, 1e-3)
            nonlocal_t += 1e-3
            res.append(s.getReal(outs))
        return res
    first = run()
    s.setFMUstate(state)
    again = run()
    s.setFMUstate(s.deSerializeFMUstate(blob))
    third = run()
    print(json.dumps({"seen": {str(k): v for k, v in seen.items()}, "exact": first == again == third}))
''')


@pytest.mark.parametrize("name", FMUS)
def test_fmu_state_fuzz_never_crashes_nor_goes_fatal_and_restores_exactly(fmu_dir, name, tmp_path):
    """Thousands of random, truncated and mutated byte strings (some inside a valid frame, to reach the
    Python side's checks) and NULL states, in a subprocess: no crash, no fmi2Fatal, every bad state
    refused with fmi2Error, the instance usable afterwards and save/restore exact."""
    script = tmp_path / "fuzz.py"
    script.write_text(_FUZZ)
    proc = subprocess.run([sys.executable, str(script), str(fmu_dir / f"{name}.fmu"), "1000"], capture_output=True,
                          text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    seen = result["seen"]
    assert result["exact"]
    assert not any("4" in k.replace(" ", "").split(",")[-1] for k in seen), seen          # never fmi2Fatal
    assert seen.get("3", 0) >= 590 and seen.get("('set', 3)", 0) + seen.get("3", 0) == 1000, seen
    assert seen.get("('null', 3)") and seen.get("('null', 0)"), seen                    # NULL: refused / no-op


# ---------------------------------------------------------------- leak
def test_instantiate_free_cycles_leave_memory_flat(fmu_dir, tmp_path):
    script = textwrap.dedent(f'''
        import gc
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        path = {str(fmu_dir / "Park2018Observer.fmu")!r}
        md, unzip = read_model_description(path), extract(path)
        def rss():
            return int(open("/proc/self/statm").read().split()[1]) * 4
        def cycle(i):
            s = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier="Park2018Observer", instanceName=f"i{{i}}")
            s.instantiate(); s.setupExperiment(startTime=0.0); s.enterInitializationMode(); s.exitInitializationMode()
            for k in range(10):
                s.doStep(k * 1e-3, 1e-3)
            s.terminate(); s.freeInstance()
            gc.collect()                    # cyclic garbage awaiting collection is not a leak
        for i in range(250):                # the allocator's arenas fill first, then stay
            cycle(i)
        gc.collect(); a = rss()
        for i in range(200):
            cycle(i)
        gc.collect(); print(rss() - a)
    ''')
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    grown_kb = int(proc.stdout.split()[-1])
    assert grown_kb < 100, f"{grown_kb} KB over 200 cycles"       # was 6-8 KB per cycle


# ---------------------------------------------------------------- each FMU runs its own code
def test_a_second_fmu_runs_after_the_host_deleted_the_first_ones_folder(fmu_dir, tmp_path):
    """What OMSimulator does by default: load an FMU, delete its unpacked folder, load the next."""
    script = textwrap.dedent(f'''
        import shutil, sys
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        def load(name):
            path = {str(fmu_dir)!r} + f"/{{name}}.fmu"
            md, unzip = read_model_description(path), extract(path)
            s = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=name, instanceName=name)
            s.instantiate()
            return s, md, unzip
        plant, md_p, dir_p = load("VehiclePlant")
        shutil.rmtree(dir_p)                             # the host deletes the first FMU's folder
        est, md_e, dir_e = load("Park2018Observer")
        shutil.rmtree(dir_e)
        vr = {{v.name: v.valueReference for v in md_p.modelVariables}}
        plant.setReal([vr["vx0"]], [20.0])
        for s in (plant, est):                           # both still initialise (vehicle files) and step
            s.setupExperiment(startTime=0.0); s.enterInitializationMode(); s.exitInitializationMode()
            for k in range(100):
                s.doStep(k * 1e-3, 1e-3)
        print("VX", plant.getReal([vr["vx"]])[0])
        print("SIDESLIP" , "sideslip" in sys.modules)
    ''')
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "SIDESLIP False" in proc.stdout and float(proc.stdout.split("VX")[1].split()[0]) > 0


def test_fmus_of_two_builds_in_one_process_each_run_their_own_code(fmu_dir, tmp_path):
    """A second build of the plant from a copy of the sources whose gravity is 9.0 instead of 9.81: in
    one process the two FMUs give their own results, not the first loaded one's."""
    source = tmp_path / "src"
    shutil.copytree(ROOT / "fmu_src", source, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    consts = source / "sideslip" / "constants.py"
    text = consts.read_text()
    assert "GRAVITY = 9.81" in text
    consts.write_text(text.replace("GRAVITY = 9.81", "GRAVITY = 9.0"))
    build = subprocess.run([sys.executable, "-c", "import sys; from sideslip.fmi.build import build_fmus; "
                            "build_fmus(['VehiclePlant'], sys.argv[1], log=lambda m: None)", str(tmp_path / "other")],
                           env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(source)}, capture_output=True, text=True,
                           timeout=600, cwd=tmp_path)
    assert build.returncode == 0, build.stderr[-2000:]
    script = textwrap.dedent(f'''
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        def run(path):
            md, unzip = read_model_description(path), extract(path)
            s = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier="VehiclePlant", instanceName=path)
            s.instantiate(); s.setupExperiment(startTime=0.0); s.enterInitializationMode()
            s.setReal([v.valueReference for v in md.modelVariables if v.name == "bank_angle"], [0.1])
            s.exitInitializationMode()
            for k in range(300):
                s.doStep(k * 1e-3, 1e-3)
            return s.getReal([v.valueReference for v in md.modelVariables if v.name == "vy"])[0]
        print(run({str(fmu_dir / "VehiclePlant.fmu")!r}), run({str(tmp_path / "other" / "VehiclePlant.fmu")!r}),
              run({str(fmu_dir / "VehiclePlant.fmu")!r}))
    ''')
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    ours, other, ours_again = map(float, proc.stdout.split())
    assert ours == ours_again and other != ours                    # on a bank, gravity moves the car sideways
    assert other / ours == pytest.approx(9.0 / 9.81, rel=0.02)


# ---------------------------------------------------------------- parameters that fail loudly
@pytest.mark.parametrize("name,params,expected", [
    ("VehiclePlant", dict(vehicle_overrides="m=inf"), "parameter 'vehicle.m' = inf is invalid; allowed: a finite number"),
    ("VehiclePlant", dict(vx0=math.nan), "parameter 'vx0' = nan is invalid; allowed: a finite number"),
    ("ManeuverDriver", dict(maneuver="sine_steer:v0=10,frequency=abc"),
     "parameter 'maneuver sine_steer: frequency' = 'abc' is invalid"),
    ("ManeuverDriver", dict(maneuver="no_such_maneuver"), "parameter 'maneuver' = 'no_such_maneuver' is invalid"),
])
def test_bad_parameters_are_named_and_no_traceback_reaches_the_host(harness, name, params, expected):
    fmu = harness(name)
    fmu.fmu.setupExperiment(startTime=0.0)
    fmu.fmu.enterInitializationMode()
    fmu.set(**params)
    assert _status(fmu.fmu.exitInitializationMode) == 3
    errors = [m for s, m in fmu.messages if s == 3]
    assert expected in errors[0]
    assert not any("Traceback" in m or 'File "' in m for _, m in fmu.messages)


@pytest.mark.parametrize("content,expected", [
    ("[params]\nm = 2000.0\n", "missing: m_s, m_uf"),
    ("[params\nm = 2000.0\n", "a TOML file (Expected ']'"),
    ('base = "pi2011_suv"\n[params]\nm_s = 2100.0\nbogus = 1.0\n', "parameter 'vehicle.bogus'"),
])
def test_a_vehicle_file_that_is_incomplete_or_malformed_is_refused_naming_it(harness, tmp_path, content, expected):
    path = tmp_path / "car.toml"
    path.write_text(content)
    fmu = harness("VehiclePlant")
    fmu.fmu.setupExperiment(startTime=0.0)
    fmu.fmu.enterInitializationMode()
    fmu.set(vehicle=str(path))
    assert _status(fmu.fmu.exitInitializationMode) == 3
    error = [m for s, m in fmu.messages if s == 3][0]
    assert expected in error and ("car.toml" in error or "vehicle." in error)


def test_a_vehicle_file_with_a_base_inherits_the_rest(harness, tmp_path):
    path = tmp_path / "car.toml"
    path.write_text('base = "pi2011_suv"\n[params]\nI_zz = 4000.0\n')
    fmu = harness("VehiclePlant")
    fmu.init(vehicle=str(path), vx0=10.0)
    assert fmu.step(delta_f=0.01) == 0


# ---------------------------------------------------------------- outputs within their ranges

@pytest.mark.parametrize("name", FMUS)
def test_outputs_stay_finite_and_within_their_declared_ranges_on_wild_inputs(harness, name):
    """Inputs anywhere in their declared ranges (held 0.2 s each, a tenth of the segments at a bound):
    every Real output stays finite and within its declared min/max at every step."""
    import numpy as np

    fmu = harness(name)
    fmu.init()
    rng = np.random.default_rng(11)
    inputs = [v for v in fmu.md.modelVariables if v.causality == "input"]
    outputs = [v for v in fmu.md.modelVariables if v.causality == "output" and v.type == "Real"]
    bounds = {v.name: (float(v.min), float(v.max)) for v in outputs}
    values = {}
    for k in range(2000):
        if k % 200 == 0:
            for v in inputs:
                if v.type == "Boolean":
                    values[v.name] = bool(rng.integers(2))
                else:
                    lo, hi = float(v.min), float(v.max)
                    values[v.name] = float(rng.choice([lo, hi]) if rng.random() < 0.1 else rng.uniform(lo, hi))
        assert fmu.step(**values) == 0
        for v, y in zip(outputs, fmu.get(*bounds)):
            lo, hi = bounds[v.name]
            assert math.isfinite(y) and lo <= y <= hi, (k, v.name, y)


def test_a_heading_is_reported_wrapped_not_clamped(harness):
    """Nguyen's yaw estimate turning more than half a lap without GPS: reported in (-pi, pi], not clamped
    (a heading outside its range is an angle to wrap, not a failure)."""
    import numpy as np

    fmu = harness("Nguyen2012DACMRKF", logging=True)
    fmu.init()
    wheel = 15.0 / 0.31
    yaw = []
    for _ in range(15000):                                 # 15 s of turning: more than half a lap
        fmu.step(yaw_rate_m=0.8, delta_m=0.05, omega_fl_m=wheel, omega_fr_m=wheel, omega_rl_m=wheel,
                 omega_rr_m=wheel, ay_m=12.0, gps_valid=False, gps_fresh=False)
        yaw.append(fmu.get("yaw_hat")[0])
    yaw = np.array(yaw)
    assert np.all(np.abs(yaw) <= math.pi) and np.unwrap(yaw)[-1] > 4.0 and yaw.min() < -2.0
    assert not [m for _, m in fmu.messages if "yaw_hat" in m]
