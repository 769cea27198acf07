"""Sensor models: noise and bias statistics, sample rates, GPS delay/outages, magnetometer, faults, seeds."""
import math

import numpy as np
import pytest

from sideslip.params import ParameterError
from sideslip.plant.sensors import SO, SensorConfig, SensorSuite, parse_windows

H = 1e-3


def truth(t, **over):
    """A deterministic truth vector (SENSOR_INPUTS order) as a function of time."""
    d = dict(ax=0.3, ay=-0.2, yaw_rate=0.05, roll_rate=0.01, delta_f=0.02, omega_fl=50.0, omega_fr=51.0,
             omega_rl=49.0, omega_rr=48.0, vx=10.0 + t, vy=0.5, yaw=0.3 * t, roll=0.02)
    d.update({k: (v(t) if callable(v) else v) for k, v in over.items()})
    return [d[k] for k in SensorSuite.input_names]


def run(cfg, seconds, **over):
    s = SensorSuite(cfg)
    rows = []
    for k in range(int(round(seconds / H))):
        t = (k + 1) * H
        s.step(H, *truth(t, **over))
        rows.append(s.outputs())
    return np.array(rows)


def test_noise_sigma_and_bias_as_configured():
    """50000 IMU samples: mean within 4 standard errors of the bias; std within 3 % of sigma
    (the standard error of a sample std is sigma / sqrt(2 N) = 0.3 %)."""
    cfg = SensorConfig(seed=7, imu_rate=1000.0, ax_sigma=0.1, ax_bias=0.2, ay_sigma=0.05, ay_bias=-0.3,
                       yaw_rate_sigma=0.002, yaw_rate_bias=0.01, roll_rate_sigma=0.004, roll_rate_bias=-0.02)
    out = run(cfg, 50.0)
    n = out.shape[0]
    for idx, true, sigma, bias in ((SO.AX_M, 0.3, 0.1, 0.2), (SO.AY_M, -0.2, 0.05, -0.3),
                                    (SO.YAW_RATE_M, 0.05, 0.002, 0.01), (SO.ROLL_RATE_M, 0.01, 0.004, -0.02)):
        err = out[:, idx] - true
        assert abs(err.mean() - bias) < 4 * sigma / math.sqrt(n)
        assert err.std() == pytest.approx(sigma, rel=0.03)


def test_wheel_speed_radius_error_and_steering_bias():
    cfg = SensorConfig(seed=3, wheel_sigma=0.0, wheel_radius_error=0.02, steer_sigma=0.0, steer_bias=0.01)
    out = run(cfg, 0.1)
    assert out[-1, SO.OMEGA_FL_M] == pytest.approx(50.0 * 1.02)
    assert out[-1, SO.OMEGA_RR_M] == pytest.approx(48.0 * 1.02)
    assert out[-1, SO.DELTA_M] == pytest.approx(0.03)


def test_zero_order_hold_at_the_sample_rate():
    cfg = SensorConfig(imu_rate=100.0, ax_sigma=0.0)
    out = run(cfg, 1.0, ax=lambda t: t)
    changes = np.nonzero(np.diff(out[:, SO.AX_M]))[0]
    assert np.all(np.diff(changes) == 10)                  # a new sample every 10 ms, held between
    assert out[9, SO.AX_M] == pytest.approx(0.010)         # sampled at t = 10 ms


def test_gps_rate_and_delay_are_exact():
    """Fixes at k / rate; each carries the velocity of t_fix - delay (here the truth is linear in t)."""
    cfg = SensorConfig(gps_rate=20.0, gps_delay=0.4, gps_vel_sigma=0.0)
    out = run(cfg, 5.0, yaw=0.0, vy=0.0)
    t = np.arange(1, out.shape[0] + 1) * H
    fresh = out[:, SO.GPS_FRESH] == 1.0
    t_fix = t[fresh]
    assert np.allclose(np.diff(t_fix), 0.05, atol=1e-9)
    assert t_fix[0] == pytest.approx(0.45)                  # first fix whose delayed truth exists
    assert np.allclose(out[fresh, SO.GPS_VE], 10.0 + t_fix - 0.4, atol=1e-9)
    assert np.allclose(out[fresh, SO.GPS_SPEED], 10.0 + t_fix - 0.4, atol=1e-9)
    assert np.all(out[:, SO.GPS_VALID][t >= 0.45] == 1.0) and np.all(out[:, SO.GPS_VALID][t < 0.45] == 0.0)
    # held between fixes
    i = np.nonzero(fresh)[0][3]
    assert out[i + 1, SO.GPS_VE] == out[i, SO.GPS_VE] and out[i + 1, SO.GPS_FRESH] == 0.0


def test_gps_delay_interpolates_between_steps():
    cfg = SensorConfig(gps_rate=10.0, gps_delay=0.1234, gps_vel_sigma=0.0)
    out = run(cfg, 2.0, yaw=0.0, vy=0.0)
    t = np.arange(1, out.shape[0] + 1) * H
    fresh = out[:, SO.GPS_FRESH] == 1.0
    assert np.allclose(out[fresh, SO.GPS_VE], 10.0 + t[fresh] - 0.1234, atol=1e-9)


def test_gps_course_is_counter_clockwise_from_east():
    cfg = SensorConfig(gps_vel_sigma=0.0)
    out = run(cfg, 0.2, yaw=math.radians(100.0), vy=0.0, vx=5.0)
    assert out[-1, SO.GPS_COURSE] == pytest.approx(math.radians(100.0))
    out = run(cfg, 0.2, yaw=math.radians(179.0), vy=1.0, vx=5.0)     # course wraps through +-pi
    assert out[-1, SO.GPS_COURSE] == pytest.approx(math.radians(179.0) + math.atan2(1.0, 5.0) - 2 * math.pi)


def test_outage_clears_gps_valid_and_stops_fixes():
    cfg = SensorConfig(gps_rate=10.0, gps_outages="1-2.5, 3-3.2")
    out = run(cfg, 4.0)
    t = np.arange(1, out.shape[0] + 1) * H
    inside = ((t >= 1) & (t < 2.5)) | ((t >= 3) & (t < 3.2))
    assert np.all(out[inside, SO.GPS_VALID] == 0.0) and np.all(out[inside, SO.GPS_FRESH] == 0.0)
    assert np.all(out[(t > 0.1) & ~inside, SO.GPS_VALID] == 1.0)
    assert out[(t > 2.5) & (t < 2.65), SO.GPS_FRESH].sum() >= 1   # fixes resume after the outage
    with pytest.raises(ParameterError, match="gps_outages"):
        SensorConfig(gps_outages="5-3")


def test_same_seed_same_data_and_different_seed_different_data():
    a = run(SensorConfig(seed=11, mag_dist_count=3), 2.0)
    b = run(SensorConfig(seed=11, mag_dist_count=3), 2.0)
    c = run(SensorConfig(seed=12, mag_dist_count=3), 2.0)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_magnetometer_unit_field_and_heading():
    cfg = SensorConfig(mag_sigma=0.0, mag_inclination=math.radians(60.0))
    for yaw in (0.0, 1.0, -2.5):
        out = run(cfg, 0.05, yaw=yaw, roll=0.0)
        mx, my, mz = out[-1, SO.MAG_X], out[-1, SO.MAG_Y], out[-1, SO.MAG_Z]
        assert math.hypot(mx, my, mz) == pytest.approx(1.0)
        assert mz == pytest.approx(-math.sin(math.radians(60.0)))
        # the horizontal field points north (+Y): in vehicle axes its bearing is pi/2 - yaw
        assert math.atan2(my, mx) == pytest.approx(math.remainder(math.pi / 2 - yaw, 2 * math.pi))
    rolled = run(cfg, 0.05, yaw=0.0, roll=0.3)[-1]
    assert math.hypot(rolled[SO.MAG_X], rolled[SO.MAG_Y], rolled[SO.MAG_Z]) == pytest.approx(1.0)


def test_magnetic_disturbances_share_count_and_magnitude():
    cfg = SensorConfig(seed=5, mag_sigma=0.0, mag_dist_count=4, mag_dist_share=0.2, mag_dist_min=0.05,
                       mag_dist_max=1.0, mag_dist_horizon=20.0)
    s = SensorSuite(cfg)
    assert len(s.episodes) == 4
    starts = [e[0] for e in s.episodes]
    assert starts == sorted(starts) and all(b[0] >= a[1] for a, b in zip(s.episodes, s.episodes[1:]))
    out = run(cfg, 20.0, yaw=0.0, roll=0.0)
    active = out[:, SO.MAG_DISTURBANCE_ACTIVE] == 1.0
    assert active.mean() == pytest.approx(0.2, abs=0.002)
    norm_dev = np.abs(np.linalg.norm(out[:, [SO.MAG_X, SO.MAG_Y, SO.MAG_Z]], axis=1) - 1.0)
    assert np.all(norm_dev[~active] < 1e-12)
    for _, _, d in s.episodes:
        assert 0.05 <= math.hypot(*d) <= 1.0


@pytest.mark.parametrize("mode", ["stuck", "offset"])
def test_steering_sensor_faults(mode):
    cfg = SensorConfig(steer_sigma=0.0, steer_fault=mode, steer_fault_time=1.0, steer_fault_offset=0.05)
    out = run(cfg, 2.0, delta_f=lambda t: 0.1 * math.sin(t))
    t = np.arange(1, out.shape[0] + 1) * H
    before, after = t < 1.0, t >= 1.0
    assert np.allclose(out[before, SO.DELTA_M], 0.1 * np.sin(np.floor(t[before] * 100 + 1e-6) / 100), atol=1e-12)
    if mode == "stuck":
        assert np.ptp(out[after, SO.DELTA_M]) == 0.0
    else:
        ref = 0.1 * np.sin(np.floor(t[after] * 100 + 1e-6) / 100) + 0.05
        assert np.allclose(out[after, SO.DELTA_M], ref, atol=1e-12)
    assert np.all(out[after, SO.DELTA_FAULT_ACTIVE] == 1.0) and np.all(out[before, SO.DELTA_FAULT_ACTIVE] == 0.0)


def test_parse_windows():
    assert parse_windows("") == ()
    assert parse_windows("3-4, 1-2") == ((1.0, 2.0), (3.0, 4.0))
    with pytest.raises(ParameterError):
        parse_windows("a-b")


def test_a_sample_draws_the_noise_stream_gauss_would_across_block_ends():
    """``_draws(k)`` returns what ``k`` calls of ``_gauss`` return, also where a block of the stream ends."""
    sliced, single = SensorSuite(SensorConfig(seed=3)), SensorSuite(SensorConfig(seed=3))
    got, want = [], []
    for k in [4, 1, 4, 2, 3] * 1200:                     # 16,800 values: four blocks and their ends
        got += sliced._draws(k)
        want += [single._gauss() for _ in range(k)]
    assert got == want


def test_no_sensor_sample_is_due_before_its_not_before_time():
    """The bound that lets a step skip the samplers is conservative: wherever ``due`` would be true, the time is
    at or after ``not_before`` (sample times and times just around them, rates from 1 Hz to 1 kHz)."""
    from sideslip.plant.sensors import _Sampler

    rng = np.random.default_rng(0)
    for rate in (1.0, 5.0, 20.0, 100.0, 333.0, 1000.0):
        for last in rng.integers(0, 10**6, 200):
            probe = _Sampler(rate)
            probe.last = int(last)
            bound = probe.not_before()
            for t in ((last + 1) / rate) * (1.0 + np.array([-1e-6, -1e-12, 0.0, 1e-15, 1e-9])):
                if math.floor(t * rate + 1e-6) > last:
                    assert t >= bound, (rate, last, t)
    sensors = SensorSuite(SensorConfig(imu_rate=333.0, wheel_rate=100.0, steer_rate=50.0, mag_rate=75.0))
    skipped = 0
    for k in range(1, 3001):                             # in a run: a skipped step has no sampler due
        t = k * 1e-3
        if t < sensors._next_due:
            skipped += 1
            assert all(math.floor(t * s.rate + 1e-6) <= s.last for s in sensors._samplers), t
        sensors.step(1e-3, *([0.1] * 13))
    assert skipped > 1000
