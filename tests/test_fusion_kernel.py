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

from sideslip import geomagnetic
from sideslip.constants import GRAVITY
from sideslip.estimators import ESTIMATORS
from sideslip.estimators.fusion import Fs, Geometry, SampleInputs, axle_pseudo, kinematic_step, wheel_measurement
from sideslip.estimators.fusion.inputs import InputConditioner
from sideslip.estimators.fusion.magnetometer import MagnetometerHeading
from sideslip.geomagnetic import earth_field
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
    inp = SampleInputs(*map(float, (0.0, 0.0, rng.normal(0.0, 0.5), rng.normal(0.0, 0.1), 20.0, fy[0], fy[1], fz[0],
                                    fz[1], fx[0], fx[1])))          # Python floats, as the filter's
    return x, inp, rng.choice([0.5, 0.9, 0.95, 0.999])


def _outcome(fn):
    try:
        return fn()
    except (ZeroDivisionError, OverflowError, ValueError) as exc:
        return type(exc)


def test_the_compiled_tire_model_gives_the_reference_doubles_and_raises_where_it_raises():
    rng = np.random.default_rng(11)
    kern = _kernel()
    refs, gots = [], []
    for k in range(3000):
        x, inp, u_max = _random_case(rng, k)
        ref = axle_pseudo(x, inp, GEOMETRY, u_max)
        got = _kernel(u_max=u_max).axles(x, inp) if u_max != 0.95 else kern.axles(x, inp)
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
        got = _outcome(lambda: _kernel(geometry).axles(xs, inp))
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


def _kernel(geometry=GEOMETRY, front_undriven=1.0, n=len(Fs), ts=0.01, u_max=0.95, conditioner=None):
    cfg = FUSION.config_class()
    if conditioner is None:
        conditioner = InputConditioner(_fusion(get_scenario("park2018_case2"), 1).vehicle, ts, 5.0, True, 0.1, 1.3)
    return kernel.FusionKernel((*geometry, GRAVITY, ts, u_max, front_undriven, cfg.mag_norm_gate,
                                cfg.mag_declination, cfg.mag_tilt_std, cfg.mag_roll_error, cfg.sigma_mag,
                                cfg.mag_tilt_correlation_time, cfg.mag_gate, *conditioner.kernel_constants()), n)


def test_the_compiled_kinematic_step_and_wheel_speeds_give_the_reference_doubles():
    rng = np.random.default_rng(5)
    for n in (len(Fs) - 2, len(Fs)):
        for front in (0.0, 1.0):
            kern = _kernel(front_undriven=front, n=n)
            refs, gots = ([], []), ([], [])          # the kinematic step's, the wheels'
            for k in range(500):
                x = rng.normal(0.0, 1.0, n) * np.r_[20.0, 2.0, 3.0, 0.01, 0.2, 0.2, 0.01, 0.3, 0.3, 1.0, 0.02,
                                                     0.3, 0.1, 0.1, 0.1][:n]
                x[Fs.LN_MU] = rng.uniform(-3.0, 0.5) if k % 50 else 800.0           # exp overflows: both raise
                inp = SampleInputs(*map(float, (rng.normal(0.0, 3.0), rng.normal(0.0, 5.0), rng.normal(0.0, 0.5),
                                                rng.normal(0.0, 0.4) * (4.0 if k % 7 == 0 else 1.0),
                                                rng.uniform(-1.0, 40.0), 0.0, 0.0, 1.0, 1.0, 0.0, 0.0)))
                xp, F = kinematic_step(x, inp.ax, inp.ay, inp.r_m, 0.01)
                xp_c, F_c = kern.kinematic(x, inp.ax, inp.ay, inp.r_m)
                refs[0].append(np.r_[xp, F.ravel()])
                gots[0].append(np.r_[xp_c, F_c.ravel()])
                ref = _outcome(lambda: wheel_measurement(x, inp, bool(front)))
                got = _outcome(lambda: kern.wheel(x[Fs.VX], x[Fs.E_W], x[Fs.LN_MU], inp.delta, inp.v_wheel, inp.ax))
                if isinstance(ref, type):
                    assert got is ref
                    continue
                refs[1].append(np.r_[ref.innovation, ref.variance, ref.row])
                gots[1].append(np.r_[got[0], got[2], got[1]])
                if EXACT:                                  # the zeros' signs too (the front rows' cos(delta) < 0)
                    assert np.array_equal(np.signbit(got[1]), np.signbit(ref.row))
            for got_k, ref_k in zip(gots, refs):
                _assert_same(np.array(got_k), np.array(ref_k))


def _compiled_heading(kern, mag, phi, x, P, age):
    return kern.heading(*mag, phi, x[Fs.G_Y], x[Fs.PSI], x[Fs.B_MAG], P[Fs.G_Y, Fs.G_Y], P[Fs.PSI, Fs.PSI],
                        P[Fs.B_MAG, Fs.B_MAG], P[Fs.PSI, Fs.B_MAG], age)


def test_the_compiled_magnetometer_heading_gives_the_reference_doubles():
    """Readings within and beyond the norm gate, a level and a tilted car on a bank, headings across +-pi, a field
    without a horizontal part, states that pass and fail the innovation gate, and readings held for several
    samples."""
    rng = np.random.default_rng(9)
    cfg = FUSION.config_class()
    kern = _kernel()
    seen = set()
    for k in range(3000):
        heading = rng.uniform(-4.0, 4.0)
        field = earth_field(geomagnetic.INCLINATION, cfg.mag_declination)
        c, s = math.cos(heading), math.sin(heading)
        mag = np.array([c * field[0] + s * field[1], -s * field[0] + c * field[1], field[2]])
        mag = mag * rng.uniform(0.85, 1.15) + rng.normal(0.0, 0.01, 3)
        if k % 97 == 0:
            mag = np.array([0.0, 0.0, 1.0])                  # pointing straight down: no horizontal field
        x = np.zeros(len(Fs))
        x[Fs.PSI] = heading + rng.normal(0.0, 0.02 if k % 3 else 0.5)
        x[Fs.G_Y], x[Fs.B_MAG] = rng.normal(0.0, 2.0), rng.normal(0.0, 0.01)
        P = np.diag(rng.uniform(1e-6, 1e-2, len(Fs)))
        P[Fs.PSI, Fs.B_MAG] = P[Fs.B_MAG, Fs.PSI] = 0.5 * math.sqrt(P[Fs.PSI, Fs.PSI] * P[Fs.B_MAG, Fs.B_MAG])
        phi, age = float(rng.normal(0.0, 0.05)), int(rng.integers(1, 12))
        ref = MagnetometerHeading(cfg, 0.01)._reading(tuple(mag.tolist()), phi, x, P, age)
        got = _compiled_heading(kern, tuple(mag.tolist()), phi, x, P, age)
        seen.add(ref[0])
        if ref[0] == 0.0:
            assert got[0] == 0.0
            continue
        _assert_same(np.array(got), np.array(ref))
    assert seen == {0.0, 1.0, 2.0}
    assert _outcome(lambda: _compiled_heading(kern, (1e200, 0.0, 0.0), 0.0, x, P, 1)) is OverflowError
    assert _outcome(lambda: MagnetometerHeading(cfg, 0.01)._reading((1e200, 0.0, 0.0), 0.0, x, P, 1)) is OverflowError


@pytest.mark.parametrize("combined", [True, False])
def test_the_compiled_input_conditioner_gives_the_reference_doubles(combined):
    """Samples in sequence (the roll model, the yaw acceleration's and the horizontal acceleration's low-passes carry
    state): accelerations to beyond the friction, both signs of the longitudinal force, offsets and roll gains."""
    vehicle = _fusion(get_scenario("park2018_case2"), 1).vehicle
    ref, cond = (InputConditioner(vehicle, 0.01, 5.0, combined, 0.1, 1.3) for _ in range(2))
    cond.compiled = _kernel(conditioner=cond).inputs
    rng = np.random.default_rng(4)
    rows = []
    for k in range(2000):
        u = [float(v) for v in (rng.normal(0.0, 4.0), 9.0 * math.sin(k / 40.0) + rng.normal(0.0, 1.0),
                                0.6 * math.sin(k / 25.0), rng.normal(0.0, 0.05), 20.0, rng.normal(0.0, 0.2),
                                rng.normal(0.0, 0.2), rng.normal(0.0, 0.05))]
        a, b = ref(*u), cond(*u)
        rows.append((np.r_[a, ref.roll.phi, ref.roll.phi_rate, ref.ln_mu_floor],
                     np.r_[b, cond.roll.phi, cond.roll.phi_rate, cond.ln_mu_floor]))
    refs, gots = (np.array(r) for r in zip(*rows))
    assert np.ptp(refs[:, -1]) > 0.5 and (refs[:, 9] != 0.0).any() == combined
    _assert_same(gots, refs)
    for c in (ref, cond):                  # a roll model that diverged: math.sin of an infinity raises
        c.roll.phi = math.inf
    assert _outcome(lambda: ref(*u)) is ValueError and _outcome(lambda: cond(*u)) is ValueError
