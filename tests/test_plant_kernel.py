"""The plant's compiled step against its pure-Python reference, in the library and inside the FMU.

The C kernel repeats the reference's arithmetic operation for operation: on one platform both give the same
doubles (checked exactly here on Linux x86-64, where the paper tables are made, and to 1e-12 everywhere).  The
drives cover both tire models, the velocity effect of friction, the stiff low-speed wheel modes (several RK4
sub-steps up to their cap), braking to standstill, the in-wheel motors' lag and saturation, bank and wind, and the
wheel-slip control (ABS and the motors' slip limit) on both tire models and both motor axles.
"""
from __future__ import annotations

import math
import pickle
import platform
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from sideslip.fmi.build import PLATFORMS, _find_cc
from sideslip.plant import kernel
from sideslip.plant.vehicle import PlantConfig, VehiclePlant

EXACT = platform.system() == "Linux" and platform.machine() in ("x86_64", "AMD64")


def _inputs(k: int) -> dict:
    """A drive through every branch: accelerate, brake to standstill, motors' torque beyond their limit."""
    t = k * 1e-3
    return dict(delta_f=0.12 * math.sin(2.0 * t), T_drive=900.0 if t < 1.0 else 0.0,
                T_brake=0.0 if t < 1.2 else 9000.0, Mz_dyc=4000.0 * math.sin(7.0 * t),
                mu=0.35 if 1.0 <= t < 2.0 else 1.0, bank_angle=0.06, F_wind_y=300.0, M_wind_z=-80.0)


def _drive(plant: VehiclePlant, steps: int) -> tuple[np.ndarray, list[int]]:
    rows, subs = [], []
    for k in range(steps):
        plant.step(1e-3, **_inputs(k))
        rows.append((*plant.outputs(), *plant.x, plant.dT_motor))
        subs.append(plant.n_substeps)
    return np.array(rows), subs


CASES = [("park2018_sonata", 0, "", 0.0), ("park2018_sonata", 1, "", 0.0), ("pi2011_suv", 0, "eps_v=0.02", 0.0),
         ("pi2011_suv", 1, "eps_v=0.02, motor_axle=front", 0.0), ("kim2016_asm", 0, "motor_tau=0", 0.0),
         ("park2018_sonata", 0, "", 0.1), ("pi2011_suv", 1, "eps_v=0.02, motor_axle=rear", 0.15)]


def test_the_compiled_kernel_is_built_with_the_library():
    assert kernel.available(), kernel.UNAVAILABLE
    assert VehiclePlant().compiled


@pytest.mark.parametrize("vehicle,tire_model,overrides,slip", CASES)
def test_the_compiled_step_gives_the_reference_doubles(vehicle, tire_model, overrides, slip):
    config = dict(vehicle=vehicle, vehicle_overrides=overrides, vx0=22.0, tire_model=tire_model, max_substeps=6,
                  wheel_slip_max=slip)
    reference = VehiclePlant(PlantConfig(**config, compiled=0))
    compiled = VehiclePlant(PlantConfig(**config, compiled=1))
    assert not reference.compiled and compiled.compiled
    ref, ref_subs = _drive(reference, 6000)
    got, got_subs = _drive(compiled, 6000)
    assert got_subs == ref_subs and max(ref_subs) == 6 and min(ref_subs) == 1     # the sub-step rule and its cap
    assert ref[-1, 0] < 0.5                                                         # braked to standstill
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.maximum(1.0, np.abs(ref)).max()
    if EXACT:
        assert np.array_equal(got, ref)


def test_a_pickled_plant_runs_on_compiled():
    plant = VehiclePlant(PlantConfig(vehicle="park2018_sonata", vx0=20.0))
    for k in range(200):
        plant.step(1e-3, **_inputs(k))
    copy = pickle.loads(pickle.dumps(plant))
    assert copy.compiled
    for k in range(200, 400):
        plant.step(1e-3, **_inputs(k))
        copy.step(1e-3, **_inputs(k))
    assert copy.outputs() == plant.outputs()


def test_the_kernel_refuses_constants_of_another_layout():
    with pytest.raises(RuntimeError, match="takes .* constants"):
        kernel.PlantKernel([0.0] * 3)


def _fmu_run(fmu_dir, compiled: int) -> np.ndarray:
    from fmpy import simulate_fmu

    res = simulate_fmu(str(fmu_dir / "VehiclePlant.fmu"), stop_time=1.5, output_interval=1e-3,
                       start_values={"vehicle": "pi2011_suv", "vx0": 18.0, "compiled": compiled},
                       input=np.array([(0.0, 0.05, 300.0, 0.0, 800.0), (1.5, -0.05, 0.0, 3000.0, -800.0)],
                                      dtype=[("time", float), ("delta_f", float), ("T_drive", float),
                                             ("T_brake", float), ("Mz_dyc", float)]))
    return np.array([res[name] for name in res.dtype.names])


def test_the_plant_fmu_runs_compiled_and_gives_the_reference(fmu_dir):
    with zipfile.ZipFile(fmu_dir / "VehiclePlant.fmu") as z:
        carried = {n.rsplit("/", 2)[-2] for n in z.namelist() if f"/{kernel.LIBRARY_NAME}." in n}
        package = next(n.split("/")[1] for n in z.namelist() if n.endswith("/plant/kernel.py"))
    assert carried == {p for p in PLATFORMS if _find_cc(p)}
    assert "linux64" in carried
    compiled = _fmu_run(fmu_dir, 1)
    # the FMU's own kernel module, imported from its unpacked folder (the session built it in this process)
    assert sys.modules[f"{package}.plant.kernel"].available(), sys.modules[f"{package}.plant.kernel"].UNAVAILABLE
    reference = _fmu_run(fmu_dir, 0)
    assert np.max(np.abs(compiled - reference)) <= 1e-12 * np.max(np.abs(reference))
    if EXACT:
        assert np.array_equal(compiled, reference)


def test_the_win64_kernel_exports_its_functions_and_needs_only_system_dlls(fmu_dir, tmp_path):
    objdump = shutil.which("x86_64-w64-mingw32-objdump")
    if _find_cc("win64") is None or objdump is None:
        pytest.skip("no mingw-w64 cross compiler or objdump: FMUs carry no win64 kernel")
    with zipfile.ZipFile(fmu_dir / "VehiclePlant.fmu") as z:
        name = next(n for n in z.namelist() if n.endswith(f"win64/{kernel.LIBRARY_NAME}.dll"))
        dll = tmp_path / "kernel.dll"
        dll.write_bytes(z.read(name))
    text = subprocess.run([objdump, "-p", str(dll)], capture_output=True, text=True, check=True).stdout
    for symbol in ("sideslip_plant_step", "sideslip_plant_io_size", "sideslip_plant_constants_size",
                   "sideslip_plant_kernel_version",
                   "sideslip_driver_step", "sideslip_driver_io_size", "sideslip_driver_plan_size",
                   "sideslip_lqr_step", "sideslip_lqr_io_size", "sideslip_lqr_law_size", "sideslip_lqr_design_size",
                   *(f"sideslip_fusion_{name}" for name in ("inputs", "kinematic", "wheel", "axles", "heading",
                                                            "io_size", "constants_size"))):
        assert symbol in text
    assert {line.split()[-1].lower() for line in text.splitlines() if "DLL Name:" in line} <= {"kernel32.dll",
                                                                                               "msvcrt.dll"}
