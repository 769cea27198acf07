"""SideslipFusion's compiled tire pseudo-measurements against their pure-Python reference, in the library and inside
the FMU.

The C kernel (``estimators/fusion/native/fusion_kernel.c``) repeats :func:`axle_pseudo` (with the tire model's
stiffness, capacity and inverse brush tire) operation for operation: both give the same doubles (checked exactly on
Linux x86-64, and to 1e-12 everywhere) and raise the same exceptions.  The drives cover the EKF and the IMM, grip,
the friction test's detections, sliding axles on snow and ice, and the pure-slip tire.
"""
from __future__ import annotations

import math
import pickle
import platform
import sys
import zipfile

import numpy as np
import pytest

from sideslip.estimators import ESTIMATORS
from sideslip.estimators.fusion import Fs, Geometry, SampleInputs, axle_pseudo
from sideslip.params import build
from sideslip.plant import kernel
from sideslip.scenarios import get_scenario, scenario_params
from sideslip.studies.runs import run_library

EXACT = platform.system() == "Linux" and platform.machine() in ("x86_64", "AMD64")
FUSION = ESTIMATORS["SideslipFusion"]


def _assert_same(got: np.ndarray, ref: np.ndarray) -> None:
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.maximum(1.0, np.abs(ref)).max()
    if EXACT:
        assert np.array_equal(got, ref)


def _fusion(scenario, compiled: int, **params):
    return FUSION(build(FUSION.config_class, {**scenario_params(FUSION.config_class, scenario), **params,
                                              "compiled": compiled}))


def test_the_compiled_tire_model_is_built_with_the_library_and_chosen_by_the_parameter():
    assert kernel.available(), kernel.UNAVAILABLE
    scenario = get_scenario("park2018_case2", estimator_profile=1)
    assert _fusion(scenario, 1)._model._compiled_axles is not None
    assert _fusion(scenario, 0)._model._compiled_axles is None


# (scenario, seconds, parameters, what the drive must have reached: a check on the reference's outputs)
DRIVES = [
    ("park2018_case2", 8.0, {}, lambda o: o["valid"].mean() > 0.5 and o["friction_utilisation"].max() > 0.3),
    ("park2018_case2", 8.0, {"formulation": 1}, lambda o: np.ptp(o["slide_probability"]) > 0.05),
    ("bench_dev_jturn_suv_ice", 8.0, {}, lambda o: o["friction_utilisation"].max() >= 0.999
     and o["mu_hat"].min() < 0.3),                      # saturated and sliding axles, the friction test's detection
    ("bench_jturn_coms_ice", 8.0, {"formulation": 1}, lambda o: o["friction_utilisation"].max() >= 0.999
     and o["mu_hat"].min() < 0.3),
    ("control_tune_bit_suv_snow_spin", 6.0, {"combined_slip": False}, lambda o: np.abs(o["beta_hat"]).max() > 0.5),
]


@pytest.mark.parametrize("scenario,duration,params,reached", DRIVES,
                         ids=[f"{d[0]}-{'-'.join(map(str, d[2].items())) or 'default'}" for d in DRIVES])
def test_the_compiled_fusion_gives_the_reference_doubles_on_a_drive(scenario, duration, params, reached):
    sc = get_scenario(scenario, estimator_profile=1)
    recorded = run_library(sc, [], duration=duration)
    inputs = list(zip(*(recorded["sensors." + name].tolist() for name in FUSION.input_names)))
    runs = {}
    for compiled in (0, 1):
        est = _fusion(sc, compiled, **params)
        out = []
        for row in inputs:
            est.step(1e-3, *row)
            out.append(est.outputs())
        runs[compiled] = np.array(out)
    assert reached(dict(zip(FUSION.output_names, runs[0].T)))
    _assert_same(runs[1], runs[0])


GEOMETRY = Geometry(1.2, 1.6, 1.1e5, 9.0e4, 6.0e4, 5.0e4, 0.3, 820.0, 615.0)


def _random_case(rng, k: int):
    """States and inputs from grip to beyond the friction limit, both signs, friction below and above the file's
    stiffness range, longitudinal forces beyond the capacity, and stiffness / friction states far off."""
    x = np.zeros(len(Fs))
    x[Fs.VX] = rng.uniform(0.5, 40.0)
    x[Fs.VY] = rng.normal(0.0, 2.0)
    x[Fs.B_R], x[Fs.D_DELTA] = rng.normal(0.0, 0.01, 2)
    x[Fs.LN_CF], x[Fs.LN_CR] = rng.normal(0.0, 0.5 if k % 7 else 3.0, 2)
    x[Fs.LN_MU] = rng.uniform(-3.0, 0.6)
    fz = rng.uniform(500.0, 9000.0, 2)
    fy = rng.normal(0.0, 1.0, 2) * fz * math.exp(x[Fs.LN_MU]) * (2.0 if k % 5 == 0 else 0.7)
    fx = rng.normal(0.0, 0.5, 2) * fz * (1.5 if k % 3 == 0 else 0.3)
    inp = SampleInputs(0.0, 0.0, rng.normal(0.0, 0.5), rng.normal(0.0, 0.1), 20.0, fy[0], fy[1], fz[0], fz[1],
                       fx[0], fx[1])
    return x, inp, rng.choice([0.5, 0.9, 0.95, 0.999])


def _outcome(fn):
    try:
        return fn()
    except (ZeroDivisionError, OverflowError) as exc:
        return type(exc)


def test_the_compiled_tire_model_gives_the_reference_doubles_and_raises_where_it_raises():
    rng = np.random.default_rng(11)
    kern = kernel.FusionKernel(GEOMETRY, len(Fs))
    refs, gots = [], []
    for k in range(3000):
        x, inp, u_max = _random_case(rng, k)
        ref = axle_pseudo(x, inp, GEOMETRY, u_max)
        got = kern.axles(x, inp, u_max)
        for axle, values, row in zip(ref, (got[:5], got[5:10]), got[10:]):
            refs.append([axle.residual, axle.slip, axle.utilisation, axle.slip_at_max, axle.capacity_slope,
                         *axle.row])
            gots.append([*values, *row])
    refs, gots = np.array(refs), np.array(gots)
    assert (refs[:, 2] > 0.999).any() and (refs[:, 2] < 0.5).any()          # beyond the limit and in grip
    _assert_same(gots, refs)
    # what the reference raises, the kernel raises: a friction state that overflows, a stiffness that underflows
    # to zero, a file whose low-friction point is at friction 1
    x, inp, _ = _random_case(rng, 1)
    for geometry, state in ((GEOMETRY, {Fs.LN_MU: 800.0}), (GEOMETRY, {Fs.LN_CF: -800.0}),
                            (GEOMETRY._replace(mu_lo=1.0), {}), (GEOMETRY, {Fs.LN_CR: 800.0})):
        xs = x.copy()
        for i, v in state.items():
            xs[i] = v
        ref = _outcome(lambda: axle_pseudo(xs, inp, geometry, 0.95))
        got = _outcome(lambda: kernel.FusionKernel(geometry, len(Fs)).axles(xs, inp, 0.95))
        assert isinstance(ref, type) and got is ref


def test_a_pickled_fusion_runs_compiled():
    sc = get_scenario("park2018_case2", estimator_profile=1)
    recorded = run_library(sc, [], duration=3.0)
    inputs = list(zip(*(recorded["sensors." + name].tolist() for name in FUSION.input_names)))
    est = _fusion(sc, 1)
    for row in inputs[:1500]:
        est.step(1e-3, *row)
    copy = pickle.loads(pickle.dumps(est))
    assert copy._model._compiled_axles is not None
    assert copy._model._compiled_axles.__self__ is not est._model._compiled_axles.__self__
    for row in inputs[1500:]:
        est.step(1e-3, *row)
        copy.step(1e-3, *row)
    assert copy.outputs() == est.outputs()


def _fmu_run(fmu_dir, compiled: int, signals) -> np.ndarray:
    from fmpy import simulate_fmu

    res = simulate_fmu(str(fmu_dir / "SideslipFusion.fmu"), stop_time=float(signals["time"][-1]), output_interval=1e-3,
                       start_values={"compiled": compiled}, input=signals)
    return np.array([res[name] for name in res.dtype.names if name != "time"], dtype=float)


def test_the_fusion_fmu_runs_compiled_and_gives_the_reference(fmu_dir):
    recorded = run_library(get_scenario("park2018_case2", estimator_profile=1), [], duration=4.0)
    names = FUSION.input_names
    signals = np.array(list(zip(recorded["time"], *(recorded["sensors." + n] for n in names))),
                       dtype=[("time", float)] + [(n, bool if n in ("gps_fresh", "gps_valid") else float)
                                                  for n in names])
    with zipfile.ZipFile(fmu_dir / "SideslipFusion.fmu") as z:
        package = next(n.split("/")[1] for n in z.namelist() if n.endswith("/estimators/fusion/mode.py"))
    compiled = _fmu_run(fmu_dir, 1, signals)
    module = sys.modules[f"{package}.plant.kernel"]
    assert module.available(), module.UNAVAILABLE
    reference = _fmu_run(fmu_dir, 0, signals)
    assert np.ptp(reference[0]) > 1e-3                     # beta_hat moves
    _assert_same(compiled, reference)
