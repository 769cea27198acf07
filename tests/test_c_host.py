"""Non-Python hosts: a plain C FMI importer (tests/native/fmi2_importer.c), not linked with
libpython and run with an empty environment, loads our FMUs; their shim starts the build
Python and its site-packages.  The outputs must equal an fmpy run of the same FMU."""
from __future__ import annotations

import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from sideslip.studies.runs import run_scenario
from sideslip.fmi.build import python_config
from sideslip.fmi.catalogue import fmu_names

NATIVE = Path(__file__).parent / "native"
CC = next((shutil.which(c) for c in (os.environ.get("CC"), "cc", "gcc") if c and shutil.which(c)), None)
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler: the FMUs keep pythonfmu's plain binary")
STEP = 1e-3


@pytest.fixture(scope="module")
def importer(tmp_path_factory) -> Path:
    import fmpy

    exe = tmp_path_factory.mktemp("importer") / "fmi2_importer"
    headers = Path(fmpy.__file__).parent / "c-code"
    subprocess.run([CC, "-O1", f"-I{headers}", str(NATIVE / "fmi2_importer.c"), "-o", str(exe), "-ldl"],
                   check=True, capture_output=True, text=True)
    # the point of the exercise: the importer knows nothing of Python
    assert "libpython" not in subprocess.run(["ldd", str(exe)], capture_output=True, text=True).stdout
    return exe


def _columns(md, inputs: dict[str, np.ndarray], n: int):
    """Importer header columns and value rows: every input of the FMU, from ``inputs`` when
    given there, else its start value."""
    cols, data = [], []
    for v in md.modelVariables:
        if v.causality != "input":
            continue
        cols.append(("R" if v.type == "Real" else "B") + str(v.valueReference))
        start = float(v.start in ("true", "1")) if v.type == "Boolean" else float(v.start or 0.0)
        data.append(np.asarray(inputs.get(v.name, np.full(n, start)), dtype=float))
    return cols, (np.column_stack(data) if data else np.zeros((n, 0)))


def _run_c(importer, fmu: Path, tmp: Path, cols, rows, out_vrs, env_extra=None):
    unzip = tmp / fmu.stem
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unzip)
    md = read_model_description(str(fmu))
    csv_in = tmp / f"{fmu.stem}_in.csv"
    times = np.arange(len(rows)) * STEP
    np.savetxt(csv_in, np.column_stack([times, rows]), delimiter=",", header=",".join(["time", *cols]),
               comments="", fmt="%.17g")
    csv_out = tmp / f"{fmu.stem}_out.csv"
    # no PYTHONPATH, no LD_PRELOAD; the BLAS kernel choice passed on so that both runs use the same kernels
    env = {"PATH": "/usr/bin:/bin", **{k: v for k, v in os.environ.items() if k.startswith("OPENBLAS_")},
           **(env_extra or {})}
    proc = subprocess.run([str(importer), str(unzip), md.coSimulation.modelIdentifier, md.guid, repr(STEP),
                           str(csv_in), str(csv_out), *map(str, out_vrs)], env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return np.loadtxt(csv_out, delimiter=",", ndmin=2)[:, 1:], proc.stderr


def _run_fmpy(fmu: Path, cols, rows, out_vrs) -> np.ndarray:
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="fmpy")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    out = np.empty((len(rows), len(out_vrs)))
    for k, row in enumerate(rows):
        for col, x in zip(cols, row):
            if col[0] == "R":
                slave.setReal([int(col[1:])], [float(x)])
            else:
                slave.setBoolean([int(col[1:])], [bool(x != 0.0)])
        slave.doStep(k * STEP, STEP)
        out[k] = slave.getReal(out_vrs)
    slave.terminate()
    slave.freeInstance()
    return out


def _real_outputs(fmu: Path) -> list[int]:
    md = read_model_description(str(fmu))
    return [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]


def test_c_host_runs_an_estimator_fmu_like_fmpy(importer, fmu_dir, tmp_path):
    """Park2018Observer, 1000 steps of real sensor data (park2018_case2, 5-6 s, in the
    maneuver) from a CSV, in the C importer and in fmpy: identical outputs."""
    run = run_scenario("park2018_case2", duration=6.0, fmu_dir=fmu_dir).results
    window = slice(5000, 6000)
    inputs = {}
    for field in run.names:
        inst, _, name = field.partition(".")
        if inst in ("sensors", "driver"):
            inputs.setdefault(name, run[field][window])
    fmu = fmu_dir / "Park2018Observer.fmu"
    md = read_model_description(str(fmu))
    cols, rows = _columns(md, inputs, 1000)
    wired = [v.name for v in md.modelVariables if v.causality == "input" and v.name in inputs]
    assert len(wired) >= 10, wired                       # real data, not start values
    assert np.ptp(inputs["ay_m"]) > 2.0                  # and a maneuver in it
    out_vrs = _real_outputs(fmu)
    c_out, log = _run_c(importer, fmu, tmp_path, cols, rows, out_vrs, {"IMPORTER_LOGGING": "1"})
    py_out = _run_fmpy(fmu, cols, rows, out_vrs)
    assert c_out.shape == py_out.shape == (1000, len(out_vrs))
    assert np.isfinite(c_out).all()
    assert np.array_equal(c_out, py_out)                 # same interpreter, same code: bit for bit
    beta = [v.valueReference for v in md.modelVariables if v.name == "beta_hat"][0]
    assert np.ptp(c_out[:, out_vrs.index(beta)]) > 1e-3   # the estimate moves
    # the shim started the build Python and added this environment's site-packages
    cfg = python_config()
    assert "sideslip-fmu: started Python from" in log
    assert cfg["site"].split(os.pathsep)[0] in log


@pytest.mark.parametrize("name", fmu_names())
def test_every_fmu_runs_in_the_c_host(importer, fmu_dir, tmp_path, name):
    """Each FMU, 50 steps at its input start values: C host equals fmpy."""
    fmu = fmu_dir / f"{name}.fmu"
    cols, rows = _columns(read_model_description(str(fmu)), {}, 50)
    out_vrs = _real_outputs(fmu)
    c_out, _ = _run_c(importer, fmu, tmp_path, cols, rows, out_vrs)
    np.testing.assert_allclose(c_out, _run_fmpy(fmu, cols, rows, out_vrs), rtol=0, atol=1e-12)


def test_c_host_without_python_says_what_to_set(importer, fmu_dir, tmp_path):
    fmu = fmu_dir / "OpenLoopKinematic.fmu"
    cols, rows = _columns(read_model_description(str(fmu)), {}, 2)
    with pytest.raises(AssertionError) as err:
        _run_c(importer, fmu, tmp_path, cols, rows, [], {"SIDESLIP_FMU_LIBPYTHON": "/nonexistent/libpython3.so"})
    assert "SIDESLIP_FMU_LIBPYTHON" in str(err.value) and "/nonexistent/libpython3.so" in str(err.value)


def test_site_packages_override_is_used(importer, fmu_dir, tmp_path):
    """SIDESLIP_FMU_SITE_PACKAGES replaces the build environment's site-packages: pointing it at
    a folder whose numpy is broken must break the FMU (so the variable is really read)."""
    broken = tmp_path / "site"
    (broken / "numpy").mkdir(parents=True)
    (broken / "numpy" / "__init__.py").write_text("raise ImportError('the override was used')\n")
    fmu = fmu_dir / "OpenLoopKinematic.fmu"
    cols, rows = _columns(read_model_description(str(fmu)), {}, 2)
    with pytest.raises(AssertionError) as err:
        _run_c(importer, fmu, tmp_path, cols, rows, [], {"SIDESLIP_FMU_SITE_PACKAGES": str(broken)})
    assert "the override was used" in str(err.value)


def test_c_host_with_two_fmus_runs_and_exits_cleanly(importer, fmu_dir, tmp_path):
    """Two FMUs (each with its own pythonfmu library) in one C process share the interpreter the
    first one started, and the process exits with status 0 (pythonfmu 0.7's double release of
    its interpreter guard at exit corrupted the heap and aborted the host before the shim's fix)."""
    plant = fmu_dir / "VehiclePlant.fmu"
    second = tmp_path / "second"
    with zipfile.ZipFile(plant) as z:
        z.extractall(second)
    md2 = read_model_description(str(plant))
    fmu = fmu_dir / "OpenLoopKinematic.fmu"
    cols, rows = _columns(read_model_description(str(fmu)), {}, 20)
    out_vrs = _real_outputs(fmu)
    c_out, _ = _run_c(importer, fmu, tmp_path, cols, rows, out_vrs,
                      {"IMPORTER_SECOND": f"{second} {md2.coSimulation.modelIdentifier} {md2.guid}"})
    np.testing.assert_allclose(c_out, _run_fmpy(fmu, cols, rows, out_vrs), rtol=0, atol=1e-12)
