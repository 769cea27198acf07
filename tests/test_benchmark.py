"""The estimator benchmark: its conditions, its metrics on constructed estimates, and a tiny grid run
end to end (cases in a process, the leaderboard, JSON, heat map and error plots)."""
import json
import math

import numpy as np
import pytest

from sideslip.params import ParameterError
from sideslip.recording import Recording
from sideslip.scenarios import BENCHMARK_DEVELOPMENT, BENCHMARK_TEST, BENCHMARK_TRAINING
from sideslip.studies import accuracy as bm
from sideslip.studies.leaderboard import summarise, write_report
from sideslip.units import DEG, wrap_angle
from sideslip.vehicles import load_vehicle

RAD_PER_DEG = math.pi / 180.0


def test_training_and_test_sets_are_disjoint_in_maneuver_speed_vehicle_and_friction():
    train = {(s.maneuver, s.vehicle, s.road_mu) for s in BENCHMARK_TRAINING + BENCHMARK_DEVELOPMENT}
    test = {(s.maneuver, s.vehicle, s.road_mu) for s in BENCHMARK_TEST}
    assert not train & test
    assert not {s.name for s in BENCHMARK_TRAINING + BENCHMARK_DEVELOPMENT} & {s.name for s in BENCHMARK_TEST}
    simulated = len(bm.CONDITIONS) - 1                  # every condition but the real drive's, plus its slice
    # the own plant, plus one CommonRoad car under sensors+mismatch only
    assert len(bm.cases(seeds=2, development=True)) == (len(BENCHMARK_DEVELOPMENT) * (simulated + 1) + 1) * 2
    assert len(bm.cases(seeds=5)) == (len(BENCHMARK_TEST) * (simulated + 1) + 1) * 5
    assert len(bm.cases(seeds=5, plants=["own"])) == (len(BENCHMARK_TEST) * simulated + 1) * 5
    with pytest.raises(ValueError, match="unknown condition"):
        bm.cases(conditions=("rain",))
    with pytest.raises(ValueError, match="unknown plant"):
        bm.cases(plants=["carla"])


def test_the_three_sets_share_no_plant_vehicle_scenario_or_slice():
    """Training, development and test are disjoint in their (plant, estimators' vehicle, scenario or slice); the
    third CommonRoad car and the real drive's test slice are in the test set only."""
    def keys(**which):
        out = set()
        for c in bm.cases(seeds=1, **which):
            s = bm.setup(c)
            out.add((c.plant, s.estimator_vehicle.name, c.scenario))
        return out
    sets = {"training": keys(training=True), "development": keys(development=True), "test": keys()}
    for a in sets:
        for b in sets:
            if a < b:
                assert not sets[a] & sets[b]
                assert not {k[2] for k in sets[a]} & {k[2] for k in sets[b]}
                cars = lambda ks: {k[0] for k in ks if k[0] != "own"}      # noqa: E731
                assert not cars(sets[a]) & cars(sets[b])
    only_test = {k for k in sets["test"] if k[0] == "commonroad3" or k[2] == "stanford2014_test"}
    assert only_test and {k[0] for k in sets["test"]} == {"own", "commonroad3"}
    assert "stanford2014_test" in {k[2] for k in sets["test"]}


def test_the_road_draws_crossfall_or_a_crown_from_the_seed():
    drawn = []
    for seed in range(12):
        case = bm.Case("bench_banked_lc_asm", "sensors", seed)
        s = bm.setup(case)
        road = bm.road_draw(case, s.scenario)
        assert road == bm.road_draw(case, s.scenario)                        # the seed draws it
        if "road_crown" in road:
            assert 0.005 <= math.tan(road["road_crown"]) <= 0.03 and s.driver["road_crown"] == road["road_crown"]
        else:                                                              # on top of the scenario's 6 deg bank
            assert abs(math.tan(float(road["road_bank"]) - 6 * RAD_PER_DEG)) <= 0.03 + 1e-12
        drawn.append("road_crown" in road)
    assert any(drawn) and not all(drawn)
    circle = bm.setup(bm.Case("bench_circle_asm_r80_left", "sensors", 0)).scenario
    assert not any("road_crown" in bm.road_draw(bm.Case(circle.name, "sensors", k), circle)
                   for k in range(8))                                      # a circle leaves a crown's line
    assert "road_crown" not in bm.setup(bm.Case("bench_banked_lc_asm", "nominal", 0)).driver


@pytest.mark.parametrize("seed", range(6))
def test_conditions_draw_what_the_protocol_says(seed):
    case = bm.Case("bench_dlc_asm_80kmh", "sensors+mismatch", seed)
    e = bm.sensor_errors(case)
    assert abs(e["yaw_rate_bias"]) <= 0.6 * RAD_PER_DEG and e["yaw_rate_bias_drift"] > 0
    assert abs(e["ax_bias"]) <= 0.25 and abs(e["ay_bias"]) <= 0.25
    assert (e["gps_rate"], e["gps_delay"]) == (10.0, 0.1) and 0.05 <= e["gps_vel_sigma"] <= 0.1
    assert e["steer_bias"] != 0.0
    assert bm.sensor_errors(case) == e                         # the seed draws it, nothing else
    v = load_vehicle("kim2016_asm")
    m = bm.vehicle_mismatch(v, case)
    k = m.C_f_nominal / v.C_f_nominal
    assert 0.63 <= k <= 0.77 or 1.17 <= k <= 1.43               # -30 % or +30 %, +-10 % per axle
    assert abs(m.m / v.m - 1) <= 0.1 and abs(m.I_zz / v.I_zz - 1) <= 0.15 and abs(m.l_f - v.l_f) <= 0.05
    s = bm.setup(case)
    assert s.plant["tire_model"] == 1 and s.estimator_vehicle == m and not s.calibrated_field
    assert bm.setup(bm.Case("bench_dlc_asm_80kmh", "nominal", seed)).estimator_vehicle == v


def _recording(beta, t=None):
    t = np.arange(len(beta)) * 0.01 if t is None else t
    n = len(t)
    return Recording(t, {"mu": np.ones(n)}, {"beta": np.asarray(beta), "vx": np.full(n, 10.0), "vy": np.zeros(n)})


def test_row_metrics_on_a_constructed_estimate():
    beta = np.full(1000, 2.0 * RAD_PER_DEG)
    valid = np.ones(1000)
    valid[:100] = 0.0                                         # a 1 s start-up
    est = beta + 0.5 * RAD_PER_DEG * np.where(np.arange(1000) % 2, 1.0, -1.0)   # +-0.5 deg
    std = np.full(1000, 0.5 * RAD_PER_DEG)
    m = bm.row_metrics(_recording(beta), est, std, valid)
    assert m["rms"] == pytest.approx(0.5) and m["max"] == pytest.approx(0.5)
    assert m["zero_rms"] == pytest.approx(2.0) and m["rms_valid"] == pytest.approx(0.5)
    assert m["valid"] == pytest.approx(0.9) and m["time_to_valid"] == pytest.approx(1.0)
    assert m["std_ratio"] == pytest.approx(1.0) and m["nees"] == pytest.approx(1.0)
    assert m["coverage95"] == 1.0 and m["off_while_valid"] == 0.0
    # 0.7 s valid and 4 deg off: the validity target's measure; an estimate that is never valid still counts
    off = est.copy()
    off[500:570] += 4.0 * RAD_PER_DEG
    assert bm.row_metrics(_recording(beta), off, std, valid)["off_while_valid"] == pytest.approx(0.7)
    never = bm.row_metrics(_recording(beta), np.zeros(1000), std, np.zeros(1000))
    assert never["valid"] == 0.0 and never["rms"] == pytest.approx(2.0) and math.isnan(never["rms_valid"])


def test_the_summary_counts_cases_not_seed_means():
    """The longest stretch off while valid is the worst case's (a mean over seeds would hide one bad seed), and
    predict-zero, scored on the same samples, never beats itself."""
    def case(seed, rms, off):
        zero = {"rms": 2.0, "zero_rms": 2.0 * (1 + 1e-15), "max_abs_beta": 3.0, "off_while_valid": 0.0}
        row = {"rms": rms, "zero_rms": 2.0, "max_abs_beta": 3.0, "off_while_valid": off, "not_valid_when_worse": 0.9}
        return {"scenario": "s", "condition": "sensors", "seed": seed, "mu_min": 1.0,
                "rows": {"predict-zero": zero, "x": row}}
    s = summarise([case(0, 0.5, 0.0), case(1, 2.5, 1.2)])["sensors"]["rows"]
    assert s["x"]["worst_off_while_valid"] == pytest.approx(1.2) and s["x"]["total_off_while_valid"] == pytest.approx(1.2)
    assert (s["x"]["beats_zero_05"], s["x"]["knows_05"], s["x"]["cases_beta_05"]) == (1, 1, 2)
    assert s["predict-zero"]["beats_zero_05"] == 0 and s["predict-zero"]["beats_zero"] == 0


def test_the_tables_and_the_benchmark_share_one_scorer_apart_from_valid_only():
    """The paper tables score the valid samples, the benchmark every moving one: the same errors, the same
    speed threshold, one switch."""
    from sideslip.studies.metrics import MOVING_SPEED, estimate_metrics, score, scored_samples

    n = 1000
    beta = np.full(n, 2.0 * RAD_PER_DEG)
    est = beta + np.where(np.arange(n) < 300, 3.0, 0.5) * RAD_PER_DEG      # 3 deg off for the first 3 s, then 0.5 deg
    valid = (np.arange(n) >= 300).astype(float)                    # not valid while 3 deg off
    speed = np.where(np.arange(n) < 50, 0.5 * MOVING_SPEED, 10.0)  # standing for the first 0.5 s
    every, only_valid = scored_samples(speed), scored_samples(speed, valid, valid_only=True)
    assert every.sum() == 950 and only_valid.sum() == 700
    assert score(est - beta, beta, every, DEG)["rms"] == pytest.approx(math.sqrt((250 * 9 + 700 * 0.25) / 950))
    assert score(est - beta, beta, only_valid, DEG)["rms"] == pytest.approx(0.5)
    rec = Recording(np.arange(n) * 0.01, {"mu": np.ones(n)}, {"beta": beta, "vx": speed, "vy": np.zeros(n)})
    row = bm.row_metrics(rec, est, np.full(n, RAD_PER_DEG), valid)
    results = {"time": rec.time, "plant.vx": speed, "plant.vy": np.zeros(n), "plant.beta": beta,
               "est.beta_hat": est, "est.valid": valid}
    table = estimate_metrics(results, "est")
    assert row["rms"] == score(wrap_angle(est - beta) * DEG, beta * DEG, every)["rms"]
    assert row["rms_valid"] == pytest.approx(table["beta_hat"]["rms"]) == pytest.approx(0.5)
    assert row["valid"] == table["valid"] == pytest.approx(700 / 950)


def test_one_wrap_for_scalars_and_arrays():
    angles = np.array([-7.0, -math.pi, -1.0, 0.0, math.pi, 3.5, 12.0])
    assert list(wrap_angle(angles)) == [wrap_angle(float(a)) for a in angles]
    assert np.all((wrap_angle(angles) > -math.pi) & (wrap_angle(angles) <= math.pi))


def test_sideslip_errors_are_wrapped():
    beta = np.full(10, math.pi - 0.01)
    m = bm.row_metrics(_recording(beta), np.full(10, -math.pi + 0.01), np.full(10, 0.02), np.ones(10))
    assert m["rms"] == pytest.approx(math.degrees(0.02))


ROWS = tuple(r for r in bm.ROWS if r.label in ("predict-zero", "LinearBicycleObserver", "Yoon2014DualKF/hardened",
                                               "Nguyen2012DACMRKF/published"))


@pytest.mark.slow
def test_a_tiny_grid_end_to_end(tmp_path):
    cases = bm.cases(["bench_jturn_coms_ice"], ("nominal", "sensors+mismatch"), seeds=2)
    results = bm.run_benchmark(cases, ROWS, workers=2, progress=False)
    assert [r["case"] for r in results] == [c.name for c in cases]
    for r in results:
        assert set(r["rows"]) == {row.label for row in ROWS}
        zero = r["rows"]["predict-zero"]
        assert zero["rms"] == pytest.approx(zero["zero_rms"]) and zero["valid"] == 1.0
        for label, m in r["rows"].items():
            assert math.isfinite(m["rms"]) and m["restarts"] == 0, label
        assert ("traces" in r) == (r["seed"] == 0)
    # the sensors and the tires differ between the conditions, the truth not between seeds of a clean road
    nominal = [r for r in results if r["condition"] == "nominal"]
    assert nominal[0]["rows"]["predict-zero"]["rms"] == nominal[1]["rows"]["predict-zero"]["rms"]
    summary = write_report(results, tmp_path, meta={"seeds": 2})
    assert set(summary) == {"nominal", "sensors+mismatch", "sensors+mismatch on commonroad3"}
    assert [r["plant"] for r in results] == ["own"] * 4 + ["commonroad3"] * 2
    row = summary["sensors+mismatch"]["rows"]["Yoon2014DualKF/hardened"]
    per = row["per_scenario"]["bench_jturn_coms_ice"]
    assert per["seeds"] == 2 and per["rms_min"] <= per["rms"] <= per["rms_max"]
    assert row["cases_beta_1deg"] == 1 and row["beats_zero"] == 1      # 5 deg of sideslip on ice: beaten
    text = (tmp_path / "leaderboard.md").read_text()
    assert "## sensors+mismatch" in text and "| Yoon2014DualKF/hardened |" in text
    data = json.loads((tmp_path / "benchmark.json").read_text())
    assert len(data["cases"]) == 6 and data["meta"] == {"seeds": 2}
    assert "## sensors+mismatch on commonroad3" in text
    for name in ("heatmap.png", "heatmap_commonroad3.png", "errors_jturn_coms_ice.png",
                 "errors_jturn_coms_ice_commonroad3.png"):
        assert (tmp_path / name).stat().st_size > 10_000, name
    assert set(data["summary"]) == set(summarise(results))


def test_select_rows_keeps_predict_zero_and_names_unknown_rows():
    labels = [r.label for r in bm.select_rows(["Yoon2014DualKF"])]
    assert labels == ["predict-zero", "Yoon2014DualKF/published", "Yoon2014DualKF/hardened"]
    with pytest.raises(ValueError, match="unknown estimator 'Foo'"):
        bm.select_rows(["Foo"])


def test_sensor_values_given_replace_what_the_condition_draws():
    chosen = bm.cases(["bench_jturn_coms_ice"], ("nominal", "sensors+mismatch"), seeds=1,
                      sensors={"ay_sigma": "0.2", "gps_delay": 0.25})
    for case in chosen:
        s = bm.setup(case)
        assert s.sensors["ay_sigma"] == 0.2 and s.sensors["gps_delay"] == 0.25
    drawn = bm.sensor_errors(chosen[1])
    assert s.sensors["ax_sigma"] == drawn["ax_sigma"] and s.sensors["yaw_rate_bias"] == drawn["yaw_rate_bias"]
    with pytest.raises(ParameterError, match="ay_sgima"):
        bm.sensor_overrides({"ay_sgima": 0.2})
    with pytest.raises(ParameterError, match="ay_sigma"):
        bm.sensor_overrides({"ay_sigma": -1.0})


def test_a_parameter_given_goes_to_the_rows_whose_estimator_has_it():
    rows = bm.with_params(bm.select_rows(["SideslipFusion", "Yoon2014DualKF"]), {"sigma_accel": "0.3"})
    for row in rows:
        if row.estimator == "SideslipFusion":
            assert row.params[-1] == ("sigma_accel", 0.3)
        else:
            assert row in bm.ROWS                                   # predict-zero and Yoon's rows unchanged
    with pytest.raises(ValueError, match="no selected row's estimator has a parameter 'foo'"):
        bm.with_params(rows, {"foo": 1})
    with pytest.raises(ParameterError, match="sigma_accel"):
        bm.with_params(rows, {"sigma_accel": -1})


def test_the_command_line_benchmark_runs_the_rows_and_sensors_it_is_given(tmp_path):
    from sideslip.cli import main

    assert main(["benchmark", "--scenario", "bench_jturn_coms_ice", "--condition", "sensors+mismatch", "--seeds", "1",
                 "--estimator", "SideslipFusion/in-vehicle", "--param", "sigma_accel=0.3", "--sensor", "ay_sigma=0.2",
                 "--out", str(tmp_path), "--workers", "1"]) == 0
    data = json.loads((tmp_path / "benchmark.json").read_text())
    assert data["meta"]["params"] == {"sigma_accel": 0.3} and data["meta"]["sensors"] == {"ay_sigma": 0.2}
    got = data["cases"][0]["rows"]["SideslipFusion/in-vehicle"]["rms"]
    row = next(r for r in bm.ROWS if r.label == "SideslipFusion/in-vehicle")
    given = bm.Case("bench_jturn_coms_ice", "sensors+mismatch", 0, sensors=(("ay_sigma", 0.2),))
    expected = bm.run_case(given, bm.with_params((row,), {"sigma_accel": 0.3}))["rows"][row.label]["rms"]
    default = bm.run_case(bm.Case(given.scenario, given.condition), (row,))["rows"][row.label]["rms"]
    assert got == pytest.approx(expected, rel=1e-12) and abs(got - default) > 0.01


# ---------------------------------------------------------------- the real drive
def test_the_real_drives_slices_are_disjoint_and_each_in_one_set():
    from sideslip.studies.real_drive import REAL, SLICES

    spans = sorted(SLICES.values())
    assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:]))
    for flag, name in (({"training": True}, "stanford2014_train"), ({"development": True}, "stanford2014_dev"),
                       ({}, "stanford2014_test")):
        real = [c for c in bm.cases(seeds=2, **flag) if c.condition == REAL]
        assert {c.scenario for c in real} == {name} and len(real) == 2
        assert not any(c.scenario in SLICES for c in bm.cases(seeds=1, **flag) if c.condition != REAL)


def test_a_real_drive_keeps_its_logged_sensors_and_derives_the_missing_ones():
    """The logged IMU and steering as they are; the wheel speeds roll freely at the INS velocity; the GNSS speed is
    the INS speed with the receiver's noise and delay."""
    from sideslip.studies.real_drive import _log, real_drive

    case = bm.Case("stanford2014_train", "real", 1)
    s = bm.setup(case)
    rec = bm.simulate(case)
    log = _log()
    first = log["time"] >= 280.0 - 1e-9
    assert rec.duration == pytest.approx(140.0, abs=0.02) and rec.time[1] == pytest.approx(0.01)
    assert np.array_equal(rec.signals["ay_m"], log["ay"][first][:len(rec.time)])
    assert np.array_equal(rec.reference["beta"], log["beta"][first][:len(rec.time)])
    rear = 0.5 * (rec.signals["omega_rl_m"] + rec.signals["omega_rr_m"]) * s.vehicle.R_w
    assert np.median(np.abs(rear / rec.reference["vx"] - 1.0)) < 0.015                 # the radius error drawn
    fresh = rec.signals["gps_fresh"] > 0.5
    assert 9.0 < fresh.sum() / rec.duration < 11.0                                    # 10 Hz
    speed = np.hypot(rec.reference["vx"], rec.reference["vy"])
    lag = int(round(s.sensors["gps_delay"] / 0.01))
    assert np.median(np.abs(rec.signals["gps_speed"][fresh][5:] - np.roll(speed, lag)[fresh][5:])) < 0.2
    assert real_drive("stanford2014_train", s.sensors).signals["gps_ve"].tolist() == rec.signals["gps_ve"].tolist()


@pytest.mark.slow
def test_the_fusion_estimator_beats_predict_zero_on_the_real_drives_training_slice():
    rows = tuple(r for r in bm.ROWS if r.estimator is None or r.label == "SideslipFusion/EKF")
    res = bm.run_case(bm.Case("stanford2014_train", "real", 0), rows)
    zero, fusion = res["rows"]["predict-zero"], res["rows"]["SideslipFusion/EKF"]
    assert fusion["rms"] < 0.5 * zero["rms"] and fusion["restarts"] == 0
