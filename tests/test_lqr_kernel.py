"""The LQR controller's compiled samples against its pure-Python reference, in the library and inside the FMU.

The C kernel (``control/native/lqr_kernel.c``) repeats the reference's law operation for operation: both give the
same doubles (checked exactly on Linux x86-64, and to 1e-12 everywhere).  The runs cover both profiles, every
sideslip-feedback variant, the limiter, the integral against saturation, the friction-scheduled design following
``mu_hat``, several samples per step and one sample in several steps, and inputs that are not finite.
"""
from __future__ import annotations

import json
import math
import pickle
import platform
import sys
from pathlib import Path

import numpy as np
import pytest

from sideslip.control.dyc import LqrDycConfig, LqrDycController
from sideslip.params import build
from sideslip.plant import kernel
from sideslip.studies.control_eval.cases import SOURCES, ControlCase, with_controller_params
from sideslip.studies.control_eval.engines import simulate_control

EXACT = platform.system() == "Linux" and platform.machine() in ("x86_64", "AMD64")
TUNED = tuple(json.loads((Path(__file__).parents[1] / "examples" / "lqr_tuned.json").read_text())["parameters"].items())


def _assert_same(got: np.ndarray, ref: np.ndarray) -> None:
    assert got.shape == ref.shape
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.maximum(1.0, np.abs(ref)).max()
    if EXACT:
        assert np.array_equal(got, ref)


def _controller(compiled: int, **params) -> LqrDycController:
    return LqrDycController(build(LqrDycConfig, {**params, "compiled": compiled}))


def test_the_compiled_samples_are_built_with_the_library_and_chosen_by_the_parameters():
    assert kernel.available(), kernel.UNAVAILABLE
    assert LqrDycController().compiled
    assert not _controller(0).compiled
    assert not _controller(1, control_profile=0).compiled            # the published profile's feed-forward: Python
    assert _controller(1, control_profile=0, feedforward=0).compiled
    assert not _controller(1, feedforward=1).compiled


# (scenario, condition, row, controller parameters, what the run must show: a check on the reference's arrays)
LOOPS = [
    ("fmvss126_suv_mu08_a6.5", "sensors+mismatch", "LQR / truth", TUNED,                  # the tuned file
     lambda a: np.max(np.abs(a["controller.Mz_fb"])) > 1000.0),
    ("park2018_case5", "sensors+mismatch", "LQR / SideslipFusion", TUNED,                 # designs follow mu_hat
     lambda a: np.ptp(a["controller.yaw_rate_ref"]) > 0.05),
    ("fmvss126_suv_mu08_a5.0_right", "sensors", "LQR published / truth", (("feedforward", 0),),
     lambda a: np.max(np.abs(a["controller.Mz_cmd"])) > 1000.0),
    ("control_launch_turn_sonata", "sensors", "LQR / truth",
     (("beta_feedback", 1), ("sideslip_priority", 1), ("k_integral", 0.5), ("deadband", 0.01), ("k_beta", 20.0)),
     lambda a: np.ptp(a["controller.Mz_cmd"]) > 10.0),
    ("park2018_case3", "sensors+mismatch", "LQR / truth", (("Ts_control", 0.0005), ("beta_feedback", 2)),
     lambda a: np.ptp(a["controller.Mz_cmd"]) > 1.0),
    ("park2018_case3", "sensors", "LQR / truth", (("Ts_control", 0.01), ("yaw_rate_source", 0), ("valid_gate", 0),
                                                  ("deadband", 0.005)),                 # a command on the circle
     lambda a: np.ptp(a["controller.Mz_cmd"]) > 1.0),
    ("control_tune_bit_sonata_snow_spin", "sensors+mismatch", "LQR / SideslipFusion", TUNED,    # limiter ahead
     lambda a: dict(TUNED)["t_beta_lead"] > 0.0 and np.max(np.abs(a["controller.Mz_fb"])) > 1000.0),
    ("control_tune_bit_asm_snow_plough", "sensors+mismatch", "LQR / truth", TUNED + (("k_understeer", 10.0),),
     lambda a: np.max(a["controller.Mz_fb"]) > 1000.0),                                  # understeer integral
]


@pytest.mark.parametrize("scenario,condition,row,params,reached", LOOPS, ids=[f"{c[0]}-{c[2]}" for c in LOOPS])
def test_the_compiled_controller_gives_the_reference_doubles_in_the_closed_loop(scenario, condition, row, params,
                                                                                 reached):
    source = next(s for s in SOURCES if s.label == row)
    runs = {}
    for compiled in (0, 1):
        case = with_controller_params(ControlCase(scenario, condition, 0, source), params + (("compiled", compiled),))
        a = simulate_control(case)
        runs[compiled] = np.column_stack([a[k] for k in sorted(a) if k.startswith(("controller.", "plant."))])
    assert reached(a)
    _assert_same(runs[1], runs[0])


CONFIGS = {
    "default": {},
    "tuned": dict(TUNED),
    "published": {"control_profile": 0, "feedforward": 0},
    "band 1, priority, integral, limiter, held limit": {
        "beta_feedback": 1, "sideslip_priority": 1, "k_integral": 2.0, "k_beta": 40.0, "beta_limit": 0.03,
        "friction_source": 1, "Mz_max": 800.0, "deadband": 0.005, "beta_std_ref": 0.02},
    "two samples per step, yaw_rate_hat": {"Ts_control": 0.0005, "yaw_rate_source": 1, "beta_feedback": 2,
                                           "t_steer_offset": 0.5},
    "one sample in ten steps, mu_hat": {"Ts_control": 0.01, "valid_gate": 0, "k_integral": 1.0, "friction_source": 1},
    "limiter ahead, mu_hat": {"k_beta": 30.0, "beta_limit_scale": 0.5, "t_beta_lead": 0.3, "friction_source": 1},
    "limiter's bound capped, mu_hat": {"k_beta": 30.0, "beta_limit_mu_max": 0.6, "friction_source": 1},
    "understeer integral with the integral, saturating": {"k_understeer": 8.0, "k_integral": 0.5, "Mz_max": 800.0,
                                                          "deadband": 0.005},
}


@pytest.mark.parametrize("params", CONFIGS.values(), ids=CONFIGS.keys())
def test_the_compiled_controller_gives_the_reference_doubles_on_any_inputs(params):
    """Speeds from standstill through v_min to beyond v_max, the steering straight (offset learning) and to the
    limit, sideslip estimates inside and beyond the band, the estimate's validity and the enable switching, the
    friction estimate falling and rising (design changes), a growing std, yaw rates that saturate the command, and
    inputs that are not finite (the references held, no command)."""
    rng = np.random.default_rng(3)
    n = 6000
    k = np.arange(n)
    vx = np.clip(40.0 * np.sin(k / 1500.0) ** 2 + rng.normal(0.0, 0.3, n), 0.0, None) + np.where(k > 5000, 60.0, 0.0)
    delta = np.where(k % 2000 < 700, 0.001 + rng.normal(0.0, 2e-4, n), 0.08 * np.sin(k / 90.0))
    beta_hat = 0.09 * np.sin(k / 130.0) + rng.normal(0.0, 0.004, n)
    yaw_rate = np.where(k % 2000 < 700, rng.normal(0.0, 0.004, n), 0.7 * np.sin(k / 70.0))
    yaw_hat = yaw_rate + 0.002
    valid = (k // 450) % 3 != 1
    enable = (k // 1300) % 4 != 2
    mu_hat = np.clip(1.1 - k / 4000.0, -0.1, None) + 0.3 * (k > 4800)
    std = 0.002 + 0.03 * (k % 1000) / 1000.0
    for bad in (1234, 1235, 3000):
        delta[bad] = math.nan
    yaw_rate[4100] = math.inf
    inputs = list(zip(delta, vx, beta_hat, yaw_rate, yaw_hat, valid, enable, mu_hat, std))
    outs = [[], []]
    controllers = [_controller(compiled, **params) for compiled in (0, 1)]
    assert [c.compiled for c in controllers] == [False, True]
    designs = set()
    for u in inputs:
        for c, out in zip(controllers, outs):
            c.step(1e-3, *u)
            out.append((*c.outputs(), c.integral, c.understeer_integral, c.steer_offset, c.v_schedule,
                        c.enabled.value, c.beta_weight.value, c.t, c._samples))
        designs.add(controllers[0].mu_design)
    ref, got = np.array(outs[0]), np.array(outs[1])
    assert np.ptp(ref[:, 0]) > 100.0
    if params.get("k_understeer"):
        assert np.ptp(ref[:, 6]) > 0.001                        # the understeer integral grew and bled off
    if params.get("friction_source"):
        assert len(designs) > 5                                 # the design followed mu_hat down and back
    _assert_same(np.nan_to_num(got, nan=-9.0), np.nan_to_num(ref, nan=-9.0))


def test_a_pickled_controller_runs_compiled():
    c = _controller(1, **dict(TUNED))
    rows = [(0.02 * math.sin(k / 50.0), 20.0, 0.01, 0.1 * math.sin(k / 40.0), 0.0, True, True, 0.5, 0.01)
            for k in range(600)]
    for u in rows[:300]:
        c.step(1e-3, *u)
    copy = pickle.loads(pickle.dumps(c))
    assert copy.compiled
    for u in rows[300:]:
        c.step(1e-3, *u)
        copy.step(1e-3, *u)
    assert copy.outputs() == c.outputs()


def _fmu_run(fmu_dir, compiled: int) -> np.ndarray:
    from fmpy import simulate_fmu

    t = np.linspace(0.0, 4.0, 401)
    signals = np.array(list(zip(t, 0.03 * np.sin(3.0 * t), 8.0 + 4.0 * t, 0.02 * np.sin(2.0 * t),
                                0.4 * np.sin(2.5 * t), t < 3.0, 0.9 - 0.2 * t)),
                       dtype=[("time", float), ("delta_m", float), ("vx_hat", float), ("beta_hat", float),
                              ("yaw_rate_m", float), ("beta_valid", bool), ("mu_hat", float)])
    res = simulate_fmu(str(fmu_dir / "LqrDycController.fmu"), stop_time=4.0, output_interval=1e-3,
                       start_values={"compiled": compiled, **dict(TUNED)}, input=signals)
    return np.array([res[name] for name in res.dtype.names])


def test_the_controller_fmu_runs_compiled_and_gives_the_reference(fmu_dir):
    import zipfile

    with zipfile.ZipFile(fmu_dir / "LqrDycController.fmu") as z:
        package = next(n.split("/")[1] for n in z.namelist() if n.endswith("/control/dyc.py"))
    compiled = _fmu_run(fmu_dir, 1)
    assert sys.modules[f"{package}.plant.kernel"].available(), sys.modules[f"{package}.plant.kernel"].UNAVAILABLE
    reference = _fmu_run(fmu_dir, 0)
    assert np.ptp(reference[1]) > 100.0                   # Mz_cmd acts
    _assert_same(compiled, reference)
