"""SideslipFusion's models: every Jacobian, whole, against central differences; the state maps; the IMM."""
import math

import numpy as np
import pytest

from conftest import numeric_jacobian
from sideslip.estimators.fusion import (Fs, Geometry, SampleInputs, axle_pseudo, fiala_slip, gnss_delayed_model,
                                       gnss_measurement, gnss_model, kinematic_step, magnetometer_model,
                                       sliding_friction_measurement, wheel_measurement)
from sideslip.estimators.fusion.state import per_state, state_size
from sideslip.estimators.imm import InteractingMultipleModel, mixture
from sideslip.estimators.kalman import KalmanFilter
from sideslip.vehicles import load_vehicle

V = load_vehicle("park2018_sonata")
GEOMETRY = Geometry.from_vehicle(V)
FZ = (V.m * 9.81 * V.l_r / V.l, V.m * 9.81 * V.l_f / V.l)


def _state(seed: int) -> np.ndarray:
    """A state with every entry away from zero (a Jacobian entry that is always zero could hide a wrong one)."""
    r = np.random.default_rng(seed)
    x = np.empty(len(Fs))
    x[Fs.VX], x[Fs.VY], x[Fs.PSI] = r.uniform(8.0, 30.0), r.uniform(-1.0, 1.0), r.uniform(-3.0, 3.0)
    x[Fs.B_R], x[Fs.B_AX], x[Fs.B_AY] = r.uniform(-0.01, 0.01), r.uniform(-0.2, 0.2), r.uniform(-0.2, 0.2)
    x[Fs.D_DELTA], x[Fs.LN_CF], x[Fs.LN_CR] = r.uniform(-0.003, 0.003), r.uniform(-0.3, 0.3), r.uniform(-0.3, 0.3)
    x[Fs.LN_MU], x[Fs.E_W], x[Fs.G_Y] = math.log(r.uniform(0.3, 1.0)), r.uniform(-0.02, 0.02), r.uniform(-0.3, 0.3)
    x[Fs.D_GNSS], x[Fs.B_MAG] = r.uniform(0.05, 0.2), r.uniform(-0.05, 0.05)
    return x


def _inputs(utilisation: float, fx=(0.0, 0.0)) -> SampleInputs:
    """A turning sample whose axles use about ``utilisation`` of a friction of 0.6."""
    fy = (utilisation * 0.6 * FZ[0], utilisation * 0.6 * FZ[1])
    return SampleInputs(0.8, 5.0, 0.3, 0.04, 15.0, fy[0], fy[1], FZ[0], FZ[1], fx[0], fx[1])


@pytest.mark.parametrize("seed", range(3))
def test_kinematic_step_jacobian(seed):
    x = _state(seed)
    _, F = kinematic_step(x, 1.2, -3.0, 0.25, 0.01)
    np.testing.assert_allclose(F, numeric_jacobian(lambda s: kinematic_step(s, 1.2, -3.0, 0.25, 0.01).x, x),
                               rtol=1e-7, atol=1e-8)          # rounding of x (~30) over a 2e-6 step


@pytest.mark.parametrize("seed", range(3))
def test_gnss_jacobians(seed):
    x = _state(seed)
    np.testing.assert_allclose(gnss_model(x)[1], numeric_jacobian(lambda s: gnss_model(s)[0], x), atol=1e-7)
    # the delayed model is linearised at the compared sample (D = age): every column there, the delay's included
    age = x[Fs.D_GNSS]
    H = gnss_delayed_model(x, 1.5, 4.0, age)[1]
    np.testing.assert_allclose(H, numeric_jacobian(lambda s: gnss_delayed_model(s, 1.5, 4.0, age)[0], x), atol=1e-6)
    # the measurement's innovation is z - h
    z = np.array([3.0, -2.0])
    y, H2, R = gnss_measurement(z, x, np.eye(len(Fs)) * 0.01, 0.04, (1.5, 4.0), age)
    np.testing.assert_allclose(H2, -numeric_jacobian(lambda s: gnss_measurement(z, s, np.eye(len(Fs)), 0.04,
                                                                                  (1.5, 4.0), age).innovation, x),
                               atol=1e-6)
    assert np.all(np.linalg.eigvalsh(R) >= 0.04 - 1e-12)             # the delay's error adds along the track


def test_gnss_delay_column_is_the_acceleration_across_the_track_at_any_age():
    x = _state(4)
    for age in (0.0, 0.05, 0.3):
        h = lambda s: gnss_delayed_model(s, 1.5, 4.0, age)[0]        # noqa: E731
        col = numeric_jacobian(h, x)[:, Fs.D_GNSS]
        np.testing.assert_allclose(gnss_delayed_model(x, 1.5, 4.0, age)[1][:, Fs.D_GNSS], col, atol=1e-7)


@pytest.mark.parametrize("seed", range(3))
def test_magnetometer_and_wheel_jacobians(seed):
    x = _state(seed)
    np.testing.assert_allclose(magnetometer_model(x).row, numeric_jacobian(lambda s: magnetometer_model(s).h, x)[0],
                               atol=1e-8)
    inp = _inputs(0.3)
    for front in (False, True):
        row = wheel_measurement(x, inp, front).row
        num = -numeric_jacobian(lambda s: wheel_measurement(s, inp, front).innovation, x)
        np.testing.assert_allclose(row, num[0], atol=1e-8)


@pytest.mark.parametrize("utilisation", [0.05, 0.5, 0.9])
@pytest.mark.parametrize("braked", [False, True])
def test_tire_pseudo_measurement_jacobians(utilisation, braked):
    """Every column at fixed inputs; the accelerometer offset's column is the linear-range slope of the forces'
    dependence on it (axle_pseudo's docstring): the exact one times (1 - u)^(2/3)."""
    x = _state(7)
    x[Fs.LN_MU] = math.log(0.6)
    inp = _inputs(utilisation, (-0.3 * 0.6 * FZ[0], -0.2 * 0.6 * FZ[1]) if braked else (0.0, 0.0))
    axles = axle_pseudo(x, inp, GEOMETRY, 0.95)
    for k, axle in enumerate(axles):
        num = numeric_jacobian(lambda s: axle_pseudo(s, inp, GEOMETRY, 0.95)[k].residual, x, eps=1e-7)[0]
        others = [i for i in range(len(Fs)) if i != Fs.B_AY]
        np.testing.assert_allclose(axle.row[others], num[others], rtol=1e-5, atol=1e-7)
        # the forces are m_axle (a_y - b_ay): d h / d b_ay through the force
        m_axle = (GEOMETRY.m_f, GEOMETRY.m_r)[k]

        def through_force(b_ay, k=k, m_axle=m_axle):
            shifted = inp._replace(**{("fy_f", "fy_r")[k]: (inp.fy_f, inp.fy_r)[k] - m_axle * b_ay})
            return axle_pseudo(x, shifted, GEOMETRY, 0.95)[k].residual
        exact = (through_force(1e-3) - through_force(-1e-3)) / 2e-3
        assert axle.row[Fs.B_AY] == pytest.approx(exact * (1.0 - axle.utilisation) ** (2.0 / 3.0), rel=1e-4)


def test_beyond_u_max_the_friction_column_is_the_clipped_curves_at_u_max():
    """Saturated, the slip angle no longer depends on the force, but its friction column is kept at its value at
    u_max (fiala_slip's docstring: a friction estimated too low must be able to climb back out)."""
    x = _state(7)
    x[Fs.LN_MU] = math.log(0.6)
    at_max, beyond = (axle_pseudo(x, _inputs(u), GEOMETRY, 0.95) for u in (0.95 * (1 - 1e-12), 0.99))
    for a, b in zip(at_max, beyond):
        assert b.utilisation > 0.95 and b.slip == pytest.approx(a.slip, rel=1e-9)
        assert b.row[Fs.LN_MU] == pytest.approx(a.row[Fs.LN_MU], rel=1e-6) and b.row[Fs.LN_MU] < 0.0


def test_sliding_friction_measurement_jacobian():
    x0 = _state(8)
    axle = axle_pseudo(x0, _inputs(0.98), GEOMETRY, 0.95)[1]
    x = x0.copy()
    x[Fs.LN_MU] += 0.05
    m = sliding_friction_measurement(axle, x, x0, 0.04)
    np.testing.assert_allclose(m.row, -numeric_jacobian(
        lambda s: sliding_friction_measurement(axle, s, x0, 0.04).innovation, x)[0], atol=1e-9)
    assert m.innovation == pytest.approx(-math.log(axle.utilisation) + axle.capacity_slope * 0.05)


def test_fiala_slip_derivatives_against_differences():
    c, f_max = 80000.0, 6000.0
    for force in (300.0, -2500.0, 5000.0):
        s = fiala_slip(force, c, f_max, 0.95)
        d_c = (fiala_slip(force, c * math.exp(1e-6), f_max, 0.95).alpha
               - fiala_slip(force, c * math.exp(-1e-6), f_max, 0.95).alpha) / 2e-6
        d_m = (fiala_slip(force, c, f_max * math.exp(1e-6), 0.95).alpha
               - fiala_slip(force, c, f_max * math.exp(-1e-6), 0.95).alpha) / 2e-6
        assert s.d_ln_stiffness == pytest.approx(d_c, rel=1e-6)
        assert s.d_ln_friction == pytest.approx(d_m, rel=1e-5)


def test_the_state_maps_follow_the_states_not_their_order():
    assert state_size(False, False) == Fs.D_GNSS and state_size(True, False) == Fs.B_MAG
    assert state_size(True, True) == len(Fs)
    values = {s: float(s) * 10.0 for s in Fs}
    np.testing.assert_array_equal(per_state(values, 12), np.arange(12) * 10.0)
    with pytest.raises(ValueError, match="LN_MU"):
        per_state({s: 1.0 for s in Fs if s != Fs.LN_MU}, 12)


def test_the_imm_mixes_combines_and_weighs_any_number_of_modes():
    filters = [KalmanFilter([float(i), 0.0], np.eye(2) * (i + 1)) for i in range(3)]
    imm = InteractingMultipleModel([0.5, 0.3, 0.2], 0.06)
    assert imm.transition.sum(axis=1) == pytest.approx(np.ones(3))
    x, P = imm.combine(filters)
    assert x == pytest.approx([0.7, 0.0])
    # the mixture's covariance: the spread of the means plus the mean covariance
    assert P[0, 0] == pytest.approx(0.5 * 1 + 0.3 * 2 + 0.2 * 3 + 0.5 * 0.49 + 0.3 * 0.09 + 0.2 * 1.69)
    c = imm.mix(filters)
    assert c.sum() == pytest.approx(1.0)
    mixed_x, _ = mixture(imm.transition[:, 0] * [0.5, 0.3, 0.2] / c[0], [np.array([i, 0.0]) for i in range(3)],
                         [np.eye(2) * (i + 1) for i in range(3)])
    assert filters[0].x == pytest.approx(mixed_x)
    imm.update([0.0, -50.0, -2.0], c)                 # the second mode explains nothing: at its floor
    assert imm.probabilities.sum() == pytest.approx(1.0)
    assert imm.probabilities[1] == pytest.approx(1e-6, rel=0.01) and imm.probabilities[0] > imm.probabilities[2]
    with pytest.raises(ValueError, match="two or more"):
        InteractingMultipleModel([1.0], 0.01)
