"""The FMUs in third-party hosts: FMU Compliance Checker, fmusim (Reference FMUs) and OMSimulator.

The tools come from environment variables (``.ci/run`` sets them when ``../shared/hosts`` exists):
``SIDESLIP_FMUCHECK`` (the ``fmuCheck`` program), ``SIDESLIP_FMUSIM`` (the ``fmusim`` program) and
``SIDESLIP_OMSIMULATOR`` (OMSimulator's install folder); without them a sibling ``shared/hosts``
folder of the checkout is used.  A tool that is absent or cannot start (e.g. fmusim without its
shared libraries) skips its tests with the reason.  Every host is fed numeric parameters only, as a
host that cannot set Strings would be.
"""
from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sideslip.cosim.assembly import Component, scenario_components
from sideslip.cosim.master import CoSimulation
from sideslip.cosim.omsimulator_master import ENV as OMS_ENV
from sideslip.cosim.omsimulator_master import run_omsimulator_ssp
from sideslip.cosim.replay import replay_fmus
from sideslip.cosim.ssp import export_ssp
from sideslip.fmi.catalogue import fmu_names, fmu_spec
from sideslip.scenarios import get_scenario, scenario_params
from sideslip.studies.accuracy import record
from sideslip.studies.metrics import trajectory_difference

SHARED_HOSTS = Path(__file__).resolve().parents[2] / "shared" / "hosts"
FMUS = fmu_names()
ESTIMATORS = fmu_names("estimator")
TOL = 1e-9
"""Largest scaled difference (over max(1, max|x|)) allowed between a host and fmpy."""


def _tool(env: str, default: Path) -> Path:
    """The tool named by ``env`` (else ``default``), skipping the test when it is missing or cannot start."""
    path = Path(os.environ.get(env) or default)
    if not path.exists():
        pytest.skip(f"{path} not found (set {env})")
    return path


def _program(env: str, default: Path, probe: str) -> Path:
    """The program of :func:`_tool`, skipped when it cannot start (e.g. a missing shared library)."""
    program = _tool(env, default)
    try:
        proc = subprocess.run([str(program), probe], capture_output=True, text=True, timeout=60)
    except OSError as exc:
        pytest.skip(f"{program} cannot start: {exc}")
    if "error while loading shared libraries" in proc.stderr:
        pytest.skip(f"{program} cannot start: {proc.stderr.strip()}")
    return program


@pytest.fixture(scope="module")
def fmucheck() -> Path:
    return _program("SIDESLIP_FMUCHECK", SHARED_HOSTS / "fmucheck" / "fmuCheck.linux64", "-h")


@pytest.fixture(scope="module")
def fmusim() -> Path:
    return _program("SIDESLIP_FMUSIM", SHARED_HOSTS / "fmusim" / "fmusim", "--help")


@pytest.fixture(scope="module")
def omsimulator() -> Path:
    home = _tool(OMS_ENV, SHARED_HOSTS / "omsimulator")
    program = home / "bin" / "OMSimulator"
    proc = subprocess.run([str(program), "--version"], capture_output=True, text=True, timeout=60)
    if proc.returncode != 0:
        pytest.skip(f"{program} cannot start: {(proc.stdout + proc.stderr).strip()[-500:]}")
    return home


# --- FMU Compliance Checker ----------------------------------------------------------------------------

@pytest.mark.parametrize("name", FMUS)
def test_fmucheck_finds_nothing(fmucheck, fmu_dir, tmp_path, name):
    proc = subprocess.run([str(fmucheck), "-k", "cs", "-h", "1e-3", "-s", "2", "-l", "3",
                           "-o", str(tmp_path / "out.csv"), str(fmu_dir / f"{name}.fmu")],
                          capture_output=True, text=True, timeout=300)
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-3000:]
    # the summary's counts exactly ("10 Warning(s)" must not pass as "0 Warning(s)")
    assert re.search(r"FMU reported:\s+0 warning\(s\) and error\(s\)", log), log[-3000:]
    assert re.search(r"Checker reported:\s+0 Warning\(s\)\s+0 Error\(s\)", log), log[-3000:]


# --- fmusim ----------------------------------------------------------------------------------------------

SCENARIO, SECONDS = "pi2011_high", 3.0


@pytest.fixture(scope="module")
def drive():
    """The sensor signals of a closed-loop drive (3 s of ``pi2011_high``, the scenario's sensors)."""
    rec = record(SCENARIO, get_scenario(SCENARIO).sensor_params())
    n = int(round(SECONDS / 1e-3)) + 1
    return type(rec)(rec.time[:n], {k: v[:n] for k, v in rec.signals.items()},
                     {k: v[:n] for k, v in rec.reference.items()}, SCENARIO)


def _estimator_params(name: str) -> dict:
    return fmu_spec(name).numeric_parameters(scenario_params(fmu_spec(name).config_class, get_scenario(SCENARIO)))


def _run_fmusim(fmusim: Path, fmu: Path, rec, params: dict, folder: Path, nan=None) -> dict[str, np.ndarray]:
    """Run an estimator in fmusim on a recording; the input row at ``t_k-1`` holds the values of ``t_k``
    (what the step from ``t_k-1`` to ``t_k`` gets in :func:`~sideslip.cosim.replay.replay_fmus`).
    ``nan = (names, t0, t1)`` replaces those inputs by NaN for ``t0 <= t < t1``."""
    names = [n for n in fmu_spec(fmu.stem).inputs if n in rec.signals]
    rows = np.column_stack([rec.time[:-1]] + [rec.signals[n][1:] for n in names])
    if nan is not None:
        bad, t0, t1 = nan
        during = (rows[:, 0] >= t0) & (rows[:, 0] < t1)
        for n in bad:
            rows[during, 1 + names.index(n)] = np.nan
    np.savetxt(folder / "in.csv", rows, delimiter=",", header=",".join(["time"] + names), comments="", fmt="%.17g")
    cmd = [str(fmusim), "--interface-type", "cs", "--stop-time", repr(float(rec.time[-1])),
           "--output-interval", "0.001", "--input-file", str(folder / "in.csv"),
           "--output-file", str(folder / "out.csv")]
    for key, value in params.items():
        cmd += ["--start-value", key, str(int(value) if isinstance(value, bool) else value)]
    proc = subprocess.run(cmd + [str(fmu)], capture_output=True, text=True, timeout=300, cwd=folder)
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
    with open(folder / "out.csv") as f:
        table = list(csv.reader(f))
    header = [h.strip('"') for h in table[0]]
    values = np.array([[{"true": 1.0, "false": 0.0}.get(x, None) if x in ("true", "false") else float(x)
                        for x in row] for row in table[1:]])
    return {h: values[:, j] for j, h in enumerate(header)}


@pytest.mark.parametrize("name", ESTIMATORS)
def test_fmusim_reproduces_fmpy_on_a_recorded_drive(fmusim, fmu_dir, drive, tmp_path, name):
    params = _estimator_params(name)
    ref = replay_fmus(drive, [Component(name, name, params)], fmu_dir=fmu_dir)
    out = _run_fmusim(fmusim, fmu_dir / f"{name}.fmu", drive, params, tmp_path)
    assert len(out["time"]) == len(ref["time"]) and np.allclose(out["time"], ref["time"], atol=1e-12)
    assert np.any(out["valid"] > 0.5) and np.ptp(out["beta_hat"]) > 1e-3       # a drive, not a rest
    for output in fmu_spec(name).outputs:
        a, b = out[output], np.asarray(ref[f"{name}.{output}"], dtype=float)
        scale = max(1.0, float(np.max(np.abs(b))))
        assert np.max(np.abs(a - b)) <= 1e-12 * scale, output


@pytest.mark.parametrize("name", ESTIMATORS)
def test_fmusim_runs_on_through_a_nan_burst(fmusim, fmu_dir, drive, tmp_path, name):
    params = _estimator_params(name)
    bad = [n for n in ("ay_m", "yaw_rate_m", "ax_m") if n in fmu_spec(name).inputs]
    t0, t1 = 1.5, 1.7
    out = _run_fmusim(fmusim, fmu_dir / f"{name}.fmu", drive, params, tmp_path, nan=(bad, t0, t1))
    assert out["time"][-1] == pytest.approx(SECONDS)                   # the run went on to its end
    for output in fmu_spec(name).outputs:
        assert np.all(np.isfinite(out[output])), output
    # the row of time t holds the outputs after the step that ends at t, which got the inputs of t
    during = (out["time"] > t0 + 1e-9) & (out["time"] <= t1 - 1e-9)
    assert np.all(out["valid"][during] == 0.0)
    assert np.all(out["inputs_held"][during] >= 1)
    assert out["inputs_held"][-1] == 0


# --- OMSimulator --------------------------------------------------------------------------------------------

LOOPS = [("pi2011_high", "Pi2011FuzzyEKF", 4.0), ("bench_sine_coms_dry", "Nguyen2012DACMRKF", 6.0),
         ("bench_train_slalom_asm", "Park2018Observer", 6.0), ("bench_slalom_suv_mu05", "Yoon2014DualKF", 6.0)]
"""Closed loops (scenario, estimator, duration [s]) with the LQR: three vehicles, each maneuver under way and asking
the controller for a moment beyond its dead band."""

_OMS_SCRIPT = """
import json, sys
import numpy as np
from sideslip.cosim.assembly import scenario_components
from sideslip.cosim.omsimulator_master import run_omsimulator
from sideslip.scenarios import get_scenario
job = json.loads(sys.argv[1])
for i, (scenario, estimator, duration) in enumerate(job["loops"]):
    comps, conns = scenario_components(get_scenario(scenario), [estimator], "LqrDycController")
    res = run_omsimulator(comps, conns, duration=duration, fmu_dir=job["fmu_dir"], temp_dir=job.get("temp_dir"))
    np.savez(f"{job['out']}_{i}.npz", **{n: np.asarray(res[n], dtype=float) for n in res.names})
"""


def _omsimulator_runs(home: Path, fmu_dir: Path, loops, out: Path, temp_dir: Path | None = None) -> list[dict]:
    """Run closed loops one after another in one OMSimulator process (a fresh Python that loads the FMUs
    through OMSimulator alone)."""
    job = {"loops": loops, "fmu_dir": str(fmu_dir), "out": str(out), "temp_dir": str(temp_dir) if temp_dir else None}
    env = dict(os.environ, **{OMS_ENV: str(home)})
    proc = subprocess.run([sys.executable, "-c", _OMS_SCRIPT, json.dumps(job)], capture_output=True, text=True,
                          timeout=900, env=env)
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
    return [dict(np.load(f"{out}_{i}.npz")) for i in range(len(loops))]


def _fmpy_jacobi(fmu_dir: Path, scenario: str, estimator: str, duration: float):
    comps, conns = scenario_components(get_scenario(scenario), [estimator], "LqrDycController")
    with CoSimulation(comps, conns, fmu_dir=fmu_dir, scheme="jacobi") as sim:
        return sim.run(duration)


class _Columns(dict):
    @property
    def names(self):
        return list(self)


@pytest.mark.parametrize("scenario,estimator,duration", LOOPS)
def test_omsimulator_loop_with_numeric_parameters_equals_fmpy(omsimulator, fmu_dir, tmp_path, scenario, estimator,
                                                               duration):
    oms = _Columns(_omsimulator_runs(omsimulator, fmu_dir, [(scenario, estimator, duration)], tmp_path / "r")[0])
    ref = _fmpy_jacobi(fmu_dir, scenario, estimator, duration)
    assert set(oms.names) == set(ref.names) and len(oms["time"]) == round(duration / 1e-3)
    # it acted: a loop with a silent controller would compare the plant's runs alone
    assert np.max(np.abs(oms["controller.Mz_cmd"])) > 10.0 and np.max(np.abs(oms["plant.beta"])) > 1e-3
    d = trajectory_difference(ref, oms)            # fmpy set the Strings: the numeric form configured the same
    assert d["max_scaled"] <= TOL, f"{d['max_scaled_field']}: {d['max_scaled']:.3g}"


def test_omsimulator_runs_two_models_in_one_process_with_deleted_folders(omsimulator, fmu_dir, tmp_path):
    """OMSimulator deletes each FMU's unpacked folder after loading it; the second model (other FMUs, and
    one FMU again) still runs its own code."""
    temp = tmp_path / "oms_temp"
    temp.mkdir()
    loops = [(scenario, estimator, 2.0) for scenario, estimator, _ in (LOOPS[1], LOOPS[0])]
    runs = _omsimulator_runs(omsimulator, fmu_dir, loops, tmp_path / "r", temp_dir=temp)
    assert not any(p.suffix == "" and p.is_dir() and (p / "resources").exists() for p in temp.rglob("*"))
    for (scenario, estimator, duration), run in zip(loops, runs):
        d = trajectory_difference(_fmpy_jacobi(fmu_dir, scenario, estimator, duration), _Columns(run))
        assert d["max_scaled"] <= TOL, f"{scenario}: {d['max_scaled_field']}: {d['max_scaled']:.3g}"


_OMS_NAN_SCRIPT = """
import json, math, sys
sys.path.append(sys.argv[2])
from OMSimulator import Capi as oms
fmu, params, temp, values, bad = sys.argv[1], json.loads(sys.argv[3]), sys.argv[4], json.loads(sys.argv[5]), sys.argv[6]
oms.setTempDirectory(temp)
assert oms.newModel("m").value == 0 and oms.addSystem("m.root", 1).value == 0
assert oms.addSubModel("m.root.est", fmu).value == 0
for key, (kind, value) in params.items():
    assert getattr(oms, "set" + kind)("m.root.est." + key, value).value == 0, key
oms.setFixedStepSize("m.root", 1e-3)
oms.setStopTime("m", 2.0)
assert oms.instantiate("m").value == 0 and oms.initialize("m").value == 0
held, status = [], []
for k in range(1, 2001):
    for key, value in values.items():
        oms.setReal("m.root.est." + key, math.nan if key == bad and 1000 <= k < 1200 else value)
    status.append(oms.stepUntil("m", k * 1e-3).value)
    held.append(oms.getReal("m.root.est.inputs_held")[0])
beta = oms.getReal("m.root.est.beta_hat")[0]
print("RESULT", json.dumps({"status": sorted(set(status)), "held": held, "beta": beta}))
oms.terminate("m"); oms.delete("m")
"""


def test_omsimulator_runs_on_through_a_nan_input(omsimulator, fmu_dir, tmp_path):
    """A NaN on an input (here set by the host on an unconnected input) does not end the run."""
    name = "LinearBicycleObserver"
    spec = fmu_spec(name)
    from fmpy import read_model_description
    kinds = {v.name: v.type for v in read_model_description(str(fmu_dir / f"{name}.fmu")).modelVariables}
    params = {k: (kinds[k], v) for k, v in spec.numeric_parameters({}).items()}
    wheel = 20.0 / params["vehicle.R_w"][1]                      # 20 m/s, a gentle left turn
    values = {"delta_m": 0.02, "yaw_rate_m": 0.1, **{f"omega_{w}_m": wheel for w in ("fl", "fr", "rl", "rr")}}
    proc = subprocess.run([sys.executable, "-c", _OMS_NAN_SCRIPT, str(fmu_dir / f"{name}.fmu"),
                           str(omsimulator / "lib"), json.dumps(params), str(tmp_path), json.dumps(values),
                           "yaw_rate_m"],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)   # its m_res.mat lands there
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
    out = json.loads(next(line[7:] for line in proc.stdout.splitlines() if line.startswith("RESULT ")))
    assert out["status"] == [0]                                  # every step ok
    held = np.array(out["held"])
    assert np.all(held[999:1199] >= 1) and held[998] == 0 and held[-1] == 0          # held[k-1]: step k
    assert np.isfinite(out["beta"])


def test_omsimulator_program_runs_the_exported_ssp(omsimulator, fmu_dir, tmp_path, monkeypatch):
    scenario, estimator, duration = LOOPS[0]
    ssp = export_ssp(tmp_path / "loop.ssp", scenario, [estimator], "LqrDycController", duration=duration,
                     fmu_dir=fmu_dir, numeric=True)
    monkeypatch.setenv(OMS_ENV, str(omsimulator))
    oms = run_omsimulator_ssp(ssp)
    ref = _fmpy_jacobi(fmu_dir, scenario, estimator, duration)
    assert len(oms["time"]) == round(duration / 1e-3) and set(ref.names) <= set(oms.names)
    d = trajectory_difference(ref, _Columns({name: oms[name] for name in ref.names}))
    assert d["max_scaled"] <= TOL, f"{d['max_scaled_field']}: {d['max_scaled']:.3g}"


def test_cli_runs_a_scenario_on_the_omsimulator_master(omsimulator, fmu_dir, tmp_path):
    env = dict(os.environ, **{OMS_ENV: str(omsimulator)})
    proc = subprocess.run([sys.executable, "-m", "sideslip", "--fmu-dir", str(fmu_dir), "run", "--scenario", "pi2011_high",
                           "--estimator", "Pi2011FuzzyEKF", "--duration", "1", "--master", "omsimulator", "--out",
                           str(tmp_path)], capture_output=True, text=True, timeout=600, env=env)
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["master"] == "omsimulator" and metrics["scheme"] == "jacobi"
    assert (tmp_path / "sideslip.png").is_file() and "Pi2011FuzzyEKF" in metrics["estimators"]
