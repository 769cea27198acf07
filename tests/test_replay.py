"""Recorded drives: reading logs (contract names, maps with units), clear errors on bad logs, estimator
FMUs replayed on a log of the project's own closed loop giving that loop's estimates, and the CLI."""
import math

import numpy as np
import pytest

from sideslip.cli import main
from sideslip.cosim.assembly import Component
from sideslip.cosim.replay import replay_fmus
from sideslip.recording import LogError, Recording, read_log, replay
from sideslip.estimators import LinearBicycleObserver, BicycleObserverConfig
from sideslip.studies.runs import run_scenario

WHEELS = ("omega_fl_m", "omega_fr_m", "omega_rl_m", "omega_rr_m")


def _write(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(f"{v:.17g}" if isinstance(v, float) else str(v)
                                                                  for v in row) for row in rows) + "\n")
    return path


def _drive(n=500, ts=0.01):
    """A constructed steady turn in SI: wheel speeds, steering, yaw rate, lateral acceleration, GPS."""
    t = np.arange(n) * ts
    w = np.full(n, 15.0 / 0.316)
    return t, {"delta_m": np.full(n, 0.02), "yaw_rate_m": np.full(n, 0.2), "ay_m": np.full(n, 3.0),
               **{k: w for k in WHEELS}, "gps_ve": np.full(n, 15.0), "gps_vn": np.zeros(n), "beta": np.full(n, 0.01)}


def test_contract_names_map_units_and_gps_freshness(tmp_path):
    t, sig = _drive()
    names = list(sig)
    rows = [[t[k], *(sig[n][k] for n in names)] for k in range(len(t))]
    si = read_log(_write(tmp_path / "si.csv", ["time", *names], rows))
    assert set(WHEELS) <= set(si.signals) and si.reference["beta"][0] == 0.01
    assert si.signals["gps_fresh"][0] == 1.0 and si.signals["gps_fresh"][1:].sum() == 0   # held values
    assert si.signals["gps_course"][0] == 0.0 and si.signals["gps_speed"][0] == 15.0
    # the same drive in a logger's units and column names, through a map
    header = ["t_ms", "steer_deg", "gyro_z_degps", "acc_y_g", "fl", "fr", "rl", "rr", "ve_kmh", "vn_kmh", "beta_deg"]
    logger = [[t[k] * 1e3, math.degrees(0.02), -math.degrees(0.2), 3.0 / 9.80665, *(sig[w][k] * 60 / (2 * math.pi)
               for w in WHEELS), 15.0 * 3.6, 0.0, math.degrees(0.01)] for k in range(len(t))]
    (tmp_path / "map.toml").write_text("\n".join([
        'time = { column = "t_ms", unit = "ms" }',
        '[signals]', 'delta_m = { column = "steer_deg", unit = "deg" }',
        'yaw_rate_m = { column = "gyro_z_degps", unit = "deg/s", scale = -1.0 }',
        'ay_m = { column = "acc_y_g", unit = "g" }',
        *(f'{w} = {{ column = "{c}", unit = "rpm" }}' for w, c in zip(WHEELS, ("fl", "fr", "rl", "rr"))),
        'gps_ve = { column = "ve_kmh", unit = "km/h" }', 'gps_vn = { column = "vn_kmh", unit = "km/h" }',
        '[reference]', 'beta = { column = "beta_deg", unit = "deg" }']))
    mapped = read_log(_write(tmp_path / "logger.csv", header, logger), tmp_path / "map.toml")
    np.testing.assert_allclose(mapped.time, si.time, atol=1e-12)
    for name in (*WHEELS, "delta_m", "yaw_rate_m", "ay_m", "gps_ve", "beta"):
        got = mapped.signals.get(name, mapped.reference.get(name))
        want = si.signals.get(name, si.reference.get(name))
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12, err_msg=name)


def _log(tmp_path, mutate=None, header=None):
    t, sig = _drive(100)
    names = list(sig)
    rows = [[t[k], *(sig[n][k] for n in names)] for k in range(len(t))]
    header = header or ["time", *names]
    if mutate:
        mutate(header, rows)
    return _write(tmp_path / "log.csv", header, rows)


@pytest.mark.parametrize("mutate, message", [
    (lambda h, r: r[10].__setitem__(0, 0.0), "time column 'time' does not increase (row 12)"),
    (lambda h, r: [row.__setitem__(3, "nan") for row in r[5:80]], "column 'ay_m' (ay_m) has no value from t = 0.050 s "
     "to 0.790 s (longer than 0.5 s)"),
    (lambda h, r: [row.__setitem__(5, row[5] * 100.0) for row in r], "column 'omega_fr_m' (omega_fr_m) reaches"),
    (lambda h, r: r[3].__setitem__(2, "abc"), "column 'yaw_rate_m', row 5: 'abc' is not a number"),
    (lambda h, r: r[3].pop(), "row 5 has 10 fields, the header 11"),
])
def test_bad_logs_name_the_column_and_the_reason(tmp_path, mutate, message):
    with pytest.raises(LogError, match=message.replace("(", r"\(").replace(")", r"\)")):
        read_log(_log(tmp_path, mutate))


def test_a_missing_column_is_named_when_an_estimator_needs_it(tmp_path):
    rec = read_log(_log(tmp_path))
    est = LinearBicycleObserver(BicycleObserverConfig())
    assert replay(est, rec)["beta_hat"].shape == rec.time.shape
    del rec.signals["delta_m"]
    with pytest.raises(LogError, match="no column for delta_m"):
        replay(LinearBicycleObserver(BicycleObserverConfig()), rec)
    with pytest.raises(LogError, match="unknown keys bogus"):
        (tmp_path / "bad.toml").write_text("bogus = 1\n")
        read_log(_log(tmp_path), tmp_path / "bad.toml")
    with pytest.raises(LogError, match="unit 'furlong' is not one of rad/s, deg/s, rpm"):
        (tmp_path / "units.toml").write_text('[signals]\nyaw_rate_m = { column = "yaw_rate_m", unit = "furlong" }\n')
        read_log(_log(tmp_path), tmp_path / "units.toml")


def test_on_grid_keeps_every_gps_fix_once():
    t = np.arange(0, 2.0, 0.001)
    fresh = (np.arange(len(t)) % 100 == 0).astype(float)          # 10 Hz fixes in a 1 ms log
    rec = Recording(t, {"gps_fresh": fresh}, {})
    assert rec.on_grid(0.01).signals["gps_fresh"].sum() == fresh.sum()
    coarse = Recording(t[::10], {"gps_fresh": np.ones(200)}, {})   # a 100 Hz log, a fix every sample
    assert coarse.on_grid(0.001).signals["gps_fresh"].sum() == 200


@pytest.fixture(scope="module")
def loop_log(fmu_dir, tmp_path_factory):
    """5 s of park2018_case2 with two estimator FMUs in the fmpy master, written as results.csv."""
    out = tmp_path_factory.mktemp("loop")
    run = run_scenario("park2018_case2", ["Park2018Observer", "Yoon2014DualKF"], duration=5.0, fmu_dir=fmu_dir,
                       out_dir=out)
    return out / "results.csv", run


def test_replaying_a_log_of_the_closed_loop_gives_the_loops_estimates(loop_log, fmu_dir):
    path, run = loop_log
    params = {c["name"]: c["parameters"] for c in run.metrics["components"]}
    comps = [Component(name, name, params[name]) for name in ("Park2018Observer", "Yoon2014DualKF")]
    res = replay_fmus(read_log(path), comps, 1e-3, fmu_dir)
    assert res.meta["unconnected_inputs"] == []
    compared = 0
    for name in res.names[1:]:
        np.testing.assert_array_equal(res[name], run.results[name].astype(float), err_msg=name)
        compared += 1
    assert compared == 31                 # every output of both FMUs, inputs_held included


def test_cli_replay_writes_estimates_metrics_and_plot(loop_log, fmu_dir, tmp_path, capsys):
    path, _ = loop_log
    out = tmp_path / "rep"
    assert main(["--fmu-dir", str(fmu_dir), "replay", "--csv", str(path), "--estimator", "Yoon2014DualKF",
                 "--vehicle", "park2018_sonata", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "| Yoon2014DualKF |" in text and "predict-zero RMS" in text
    assert all((out / f).stat().st_size > 200 for f in ("estimates.csv", "metrics.json", "sideslip.png"))
    assert main(["--fmu-dir", str(fmu_dir), "replay", "--log", str(tmp_path / "missing.csv"), "--estimator",
                 "Yoon2014DualKF"]) == 2
    assert "no such file" in capsys.readouterr().err
