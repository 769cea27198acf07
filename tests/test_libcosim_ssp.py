"""A second master (DNV's libcosim) and the SSP export: same closed loop, same trajectories."""
from __future__ import annotations

import subprocess
import sys
import zipfile

import numpy as np
import pytest

from sideslip.cosim.libcosim_master import libcosim_available, run_libcosim, run_libcosim_ssp
from sideslip.cosim.assembly import MasterError
from sideslip.cosim.master import CoSimulation
from sideslip.studies.metrics import trajectory_difference
from sideslip.cosim.assembly import scenario_components
from sideslip.studies.runs import run_scenario
from sideslip.scenarios import get_scenario
from sideslip.cosim.ssp import NS

pytestmark = pytest.mark.skipif(not libcosim_available(), reason="libcosimpy is not installed")

SCENARIO, ESTIMATOR, CONTROLLER, DURATION = "nguyen2012_cornering", "Nguyen2012DACMRKF", "LqrDycController", 3.0
TOL = 1e-9
"""Largest difference allowed between the masters, relative to each signal's scale max(1, max|x|).
Not zero: libcosim counts time in integer nanoseconds and passes each step as the difference
of two converted time points, which differs from 1e-3 in the last bit (measured: 1e-12)."""


def _difference(reference, other) -> tuple[float, str]:
    d = trajectory_difference(reference, other)
    return d["max_scaled"], d["max_scaled_field"]


@pytest.fixture(scope="module")
def fmpy_runs(fmu_dir):
    """The fmpy master on the loop, Jacobi (libcosim's scheme) and Gauss-Seidel (the default)."""
    return {scheme: run_scenario(SCENARIO, [ESTIMATOR], CONTROLLER, duration=DURATION, fmu_dir=fmu_dir,
                                 scheme=scheme).results for scheme in ("jacobi", "gauss-seidel")}


def test_libcosim_master_equals_the_fmpy_master(fmu_dir, fmpy_runs):
    comps, conns = scenario_components(get_scenario(SCENARIO), [ESTIMATOR], CONTROLLER)
    lc = run_libcosim(comps, conns, duration=DURATION, fmu_dir=fmu_dir)
    assert set(lc.names) == set(fmpy_runs["jacobi"].names)
    assert np.abs(lc["controller.Mz_cmd"]).max() > 5.0        # it acts (drivable LQR: 21 N m at most here)
    worst, where = _difference(fmpy_runs["jacobi"], lc)
    assert worst <= TOL, f"{where}: {worst:.3g}"
    # the check can fail: the other coupling scheme differs far beyond the tolerance
    assert _difference(fmpy_runs["gauss-seidel"], lc)[0] > 1e-6


def test_run_scenario_on_libcosim_gives_metrics(fmu_dir):
    out = run_scenario(SCENARIO, [ESTIMATOR], CONTROLLER, duration=0.5, fmu_dir=fmu_dir, master="libcosim")
    assert out.metrics["master"] == "libcosim" and out.metrics["scheme"] == "jacobi"
    assert len(out.results["time"]) == 500 and out.results["time"][0] == pytest.approx(1e-3)


def test_libcosim_master_reports_a_bad_step(fmu_dir):
    comps, conns = scenario_components(get_scenario(SCENARIO), [ESTIMATOR], CONTROLLER)
    with pytest.raises(MasterError, match="nanoseconds"):
        run_libcosim(comps, conns, duration=0.1, step=1e-10 / 3, fmu_dir=fmu_dir)


def test_jacobi_scheme_is_refused_when_unknown():
    with pytest.raises(MasterError, match="scheme"):
        CoSimulation([], scheme="newton")


@pytest.fixture(scope="module")
def ssp_file(fmu_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp") / f"{SCENARIO}.ssp"
    proc = subprocess.run([sys.executable, "-m", "sideslip", "--fmu-dir", str(fmu_dir), "export-ssp",
                           "--scenario", SCENARIO, "--estimator", ESTIMATOR, "--controller", CONTROLLER,
                           "--duration", str(DURATION), str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out


def test_ssp_package_is_valid_ssp_1_0_for_fmpy(ssp_file, fmpy_runs):
    from fmpy.ssp.ssd import read_ssd

    ssd = read_ssd(str(ssp_file), validate=True)             # the SSP 1.0 schema fmpy ships
    assert ssd.version == "1.0"
    assert [e.name for e in ssd.system.elements] == ["driver", "plant", "sensors", ESTIMATOR, "controller"]
    wired = {f"{c.startElement}.{c.startConnector} -> {c.endElement}.{c.endConnector}"
             for c in ssd.system.connections}
    assert wired == set(fmpy_runs["jacobi"].meta["connections"])      # the masters' own wiring
    by_name = {e.name: e for e in ssd.system.elements}
    for comp in fmpy_runs["jacobi"].meta["components"]:
        bound = {p.name: p.value for b in by_name[comp["name"]].parameterBindings for s in b.parameterValues
                 for p in s.parameters}
        assert set(bound) == set(comp["parameters"]), comp["name"]
    assert by_name["plant"].source == "resources/VehiclePlant.fmu"
    names = zipfile.ZipFile(ssp_file).namelist()
    assert {f"resources/{f}.fmu" for f in ("ManeuverDriver", "VehiclePlant", "VehicleSensors", ESTIMATOR,
                                          CONTROLLER)} <= set(names)
    root = __import__("xml.etree.ElementTree", fromlist=["parse"]).fromstring(
        zipfile.ZipFile(ssp_file).read("SystemStructure.ssd"))
    exp = root.find("ssd:DefaultExperiment", NS)
    assert float(exp.get("stopTime")) == DURATION
    assert root.find("ssd:Units", NS) is not None


def test_ssp_package_runs_in_libcosim_like_the_master(ssp_file, fmpy_runs):
    lc = run_libcosim_ssp(ssp_file)                           # stop time and step from the package
    assert len(lc["time"]) == int(DURATION * 1000)
    worst, where = _difference(fmpy_runs["jacobi"], lc)
    assert worst <= TOL, f"{where}: {worst:.3g}"
