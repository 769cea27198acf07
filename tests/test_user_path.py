"""The path a new user walks: vehicle files, logs in three formats, results in other tools, a CLI that checks
names before loading FMUs and prints one-line errors."""
from __future__ import annotations

import json
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from sideslip.cli import main
from sideslip.cosim.results import Results
from sideslip.recording import LogError, Recording, plausibility, read_log, replay
from sideslip.studies.real_drive import DATA
from sideslip.vehicles import load_vehicle, resolve_vehicle

MAP = """
[signals]
ax_m = "ax"
ay_m = "ay"
yaw_rate_m = "yaw_rate"
delta_m = "delta"
[reference]
beta = "beta"
vx = "vx"
"""


@pytest.fixture
def real_map(tmp_path):
    path = tmp_path / "map.toml"
    path.write_text(MAP)
    return path


def test_a_base_file_that_changes_the_mass_carries_the_sprung_mass_along(tmp_path):
    f = tmp_path / "heavy.toml"
    f.write_text('base = "pi2011_suv"\n[params]\nm = 2400\nl_f = 1.3\n')
    base = load_vehicle("pi2011_suv")
    vehicle, origins = resolve_vehicle(str(f))
    assert vehicle.m_s == pytest.approx(2400 - base.m_uf - base.m_ur)
    assert vehicle.l_fs == pytest.approx(1.3 + base.l_fs - base.l_f)
    assert origins["m"].startswith("file") and origins["m_s"].startswith("derived")
    assert origins["I_zz"] == "base pi2011_suv"
    assert load_vehicle("pi2011_suv", "m=2400").m_s == pytest.approx(vehicle.m_s)      # overrides follow the same rule
    f.write_text('base = "pi2011_suv"\n[params]\nm = 2400\nm_s = 1000\n')             # given: checked, not derived
    with pytest.raises(ValueError, match="m_s"):
        load_vehicle(str(f))


def test_vehicle_check_prints_values_with_origins_and_refuses_a_typo_with_the_closest_name(tmp_path, capsys):
    f = tmp_path / "car.toml"
    f.write_text('base = "park2018_sonata"\n[params]\nm = 1600\n')
    assert main(["vehicle", "check", str(f)]) == 0
    out = capsys.readouterr().out
    assert "derived: m - m_uf - m_ur" in out and "understeer gradient" in out and "roll gradient" in out
    f.write_text('base = "park2018_sonata"\n[params]\nC_f_nominl = 1\n')
    assert main(["vehicle", "check", str(f)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: parameter 'vehicle.C_f_nominl'") and "did you mean 'C_f_nominal'" in err
    assert "Traceback" not in err
    assert main(["vehicle", "check", "pi2011_sub"]) == 2
    assert "did you mean 'pi2011_suv'" in capsys.readouterr().err


def test_cli_checks_names_and_values_before_any_fmu_loads(tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["--fmu-dir", str(tmp_path / "no_fmus"), "run", "--scenario", "park2018_case", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "did you mean 'park2018_case5'" in err and "running" not in err
    assert main(["--fmu-dir", str(tmp_path / "no_fmus"), "run", "--scenario", "park2018_case2", "--estimator",
                 "Kim2016SteeringEKF", "--param", "Kim2016SteeringEKF.sigma_gama=1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "did you mean 'sigma_gamma'" in err and "Traceback" not in err
    assert main(["run", "--scenario", "park2018_case2", "--estimator", "Kim2016SteringEKF", "--out", str(out)]) == 2
    assert "did you mean 'Kim2016SteeringEKF'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["run", "--scenario", "park2018_case2", "--duration", "-1"])
    assert exc.value.code == 2 and "must be a finite number > 0" in capsys.readouterr().err
    assert not (tmp_path / "no_fmus").exists() and not out.exists()


def test_cli_version_list_filter_and_help_without_markup(capsys):
    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.startswith("sideslip-fmu ")
    assert main(["list", "vehicles", "--grep", "bmw"]) == 0
    assert capsys.readouterr().out.split() == ["commonroad_bmw_320i"]
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    assert "examples:" in text and ":mod:" not in text and "``" not in text


def test_an_fmu_that_refuses_its_vehicle_says_why_in_one_message(fmu_dir, tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('base = "park2018_sonata"\n[params]\nC_f_nominl = 1\n')
    assert main(["--fmu-dir", str(fmu_dir), "run", "--scenario", "park2018_case2", "--estimator", "Kim2016SteeringEKF",
                 "--param", f"Kim2016SteeringEKF.vehicle={bad}", "--duration", "0.1", "--out",
                 str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if x.startswith("error:"))
    assert "Kim2016SteeringEKF" in line and "parameter 'vehicle.C_f_nominl'" in line and "C_f_nominal" in line
    assert "Traceback" not in err


def test_csv_parquet_and_mdf_logs_read_the_same(tmp_path, real_map):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    asammdf = pytest.importorskip("asammdf")
    header = DATA.read_text().splitlines()[0].split(",")
    data = np.loadtxt(DATA, delimiter=",", skiprows=1)[:3000]
    pq.write_table(pa.table({n: data[:, i] for i, n in enumerate(header)}), tmp_path / "d.parquet")
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(data[:, i], data[:, 0], name=n) for i, n in enumerate(header) if n != "time"])
    mdf.save(tmp_path / "d.mf4", overwrite=True)
    np.savetxt(tmp_path / "d.csv", data, delimiter=",", header=",".join(header), comments="")
    logs = [read_log(tmp_path / f"d.{ext}", real_map) for ext in ("csv", "parquet", "mf4")]
    for other in logs[1:]:
        np.testing.assert_array_equal(other.time, logs[0].time)
        for group in ("signals", "reference"):
            assert getattr(other, group).keys() == getattr(logs[0], group).keys()
            for k, v in getattr(logs[0], group).items():
                np.testing.assert_array_equal(getattr(other, group)[k], v, err_msg=k)
    with pytest.raises(LogError, match="unknown log format"):
        read_log(tmp_path / "d.xlsx")


def test_a_speed_or_one_wheel_stands_in_for_the_wheel_speeds_and_fusion_runs_without_gnss(real_map):
    from sideslip.estimators.fusion.filter import SideslipFusion
    from sideslip.estimators.fusion.config import SideslipFusionConfig

    car = load_vehicle("stanford_track_car")
    rec = read_log(DATA, real_map).window(420.0, 440.0)
    with pytest.raises(LogError, match="--wheel-speeds-from vx"):
        rec.inputs(SideslipFusion.input_names)
    stood = rec.with_wheel_speeds(car, "vx")
    np.testing.assert_allclose(stood.signals["omega_rl_m"], rec.reference["vx"] / car.R_w)
    # one wheel: the axle's mean is that wheel's speed with the yaw rate's share at its side removed
    left = Recording(rec.time, {**rec.signals, "omega_rl_m": stood.signals["omega_rl_m"]
                                - rec.signals["yaw_rate_m"] * car.t_r / (2 * car.R_w)}, rec.reference, "x")
    np.testing.assert_allclose(left.with_wheel_speeds(car, "omega_rl_m").signals["omega_rr_m"],
                               stood.signals["omega_rl_m"], rtol=1e-12)
    fusion = SideslipFusion(SideslipFusionConfig(vehicle="stanford_track_car", use_gnss=False))
    with_gnss = SideslipFusion(SideslipFusionConfig(vehicle="stanford_track_car"))
    with pytest.raises(LogError, match="gps_ve"):
        replay(with_gnss, stood.on_grid(0.01), 0.01)
    out = replay(fusion, stood.on_grid(0.01), 0.01)
    err = np.degrees(out["beta_hat"] - stood.on_grid(0.01).reference["beta"])[500:]
    assert np.sqrt(np.mean(err ** 2)) < 2.0 and np.isfinite(out["beta_hat"]).all()


def test_plausibility_flags_degrees_flipped_axes_and_the_handwheel(real_map, tmp_path):
    rec = read_log(DATA, real_map)
    assert plausibility(rec) == []
    degrees = Recording(rec.time, rec.signals, {**rec.reference, "beta": np.clip(np.degrees(rec.reference["beta"]),
                                                                                 -3.0, 3.0)}, "x")
    assert any("logged in degrees" in f for f in plausibility(degrees))
    flipped = Recording(rec.time, {**rec.signals, "ay_m": -rec.signals["ay_m"]}, rec.reference, "x")
    assert any("one axis is flipped" in f for f in plausibility(flipped))
    handwheel = Recording(rec.time, {**rec.signals, "delta_m": 15.0 * rec.signals["delta_m"]}, rec.reference, "x")
    assert any("handwheel" in f for f in plausibility(handwheel))


def test_results_carry_units_into_pandas_csv_and_mdf(tmp_path):
    t = np.arange(5) * 0.1
    res = Results.from_columns({"time": t, "plant.beta": t * 0.01, "est.valid": np.ones(5, bool),
                                "controller.Mz_cmd": t * 100}, {"master": "fmpy"})
    pd = pytest.importorskip("pandas")
    frame = res.to_pandas()
    assert frame.attrs["units"]["plant.beta"] == "rad" and frame.attrs["units"]["controller.Mz_cmd"] == "N.m"
    assert frame.index.name == "time" and frame["plant.beta"].iloc[-1] == pytest.approx(0.004)
    res.to_csv(tmp_path / "r.csv")
    assert json.loads((tmp_path / "r.csv.units.json").read_text())["est.valid"] == "1"
    asammdf = pytest.importorskip("asammdf")
    mdf = asammdf.MDF(res.to_mdf(tmp_path / "r.mf4"))
    assert mdf.get("plant.beta").unit == "rad"
    np.testing.assert_array_equal(mdf.get("controller.Mz_cmd").samples, res["controller.Mz_cmd"])
    assert len(res.window(0.1, 0.3)["time"]) >= 2
    assert pd.DataFrame(dict(res)).shape == (5, 4) and len(res) == 4
    with pytest.raises(ValueError, match="fewer than two samples"):
        res.window(5.0, 6.0)


def test_replay_cli_records_what_reproduces_it_and_windows_the_metrics(fmu_dir, tmp_path, real_map, capsys):
    out = tmp_path / "rep"
    args = ["--fmu-dir", str(fmu_dir), "replay", "--log", str(DATA), "--map", str(real_map), "--vehicle",
            "stanford_track_car", "--estimator", "SideslipFusion", "--param", "SideslipFusion.use_gnss=false",
            "--wheel-speeds-from", "vx", "--window", "300:330", "--out", str(out)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "vx stands in" in text and "| SideslipFusion |" in text
    m = json.loads((out / "metrics.json").read_text())
    record = m["record"]
    assert record["map"]["text"] == MAP and record["log"]["sha256"] and record["versions"]["fmpy"]
    assert "--wheel-speeds-from vx" in record["command"] and "--window 300:330" in record["command"]
    assert "SideslipFusion.use_gnss=false" in record["command"] and m["plausibility"] == []
    assert m["metrics"]["SideslipFusion"]["rms"] < 3.0


def test_lqr_gains_equal_python_controls_and_the_default_controllers_do_not_import_it():
    import control

    from sideslip.bicycle import BicycleModel
    from sideslip.control.lqr import lqr_row

    model = BicycleModel.from_vehicle(load_vehicle("pi2011_suv"), nominal=True)
    for vx in (5.0, 20.0, 40.0):
        a, b = model.matrices(vx)
        q = np.diag([3e5, 2e6])
        ref = np.asarray(control.lqr(a, b[:, 1:], q, np.array([[1e-5]]))[0]).ravel()
        np.testing.assert_array_equal(lqr_row(a, b[:, 1:], q, 1e-5), ref)
    code = ("import sys; from sideslip.control import LqrDycController, BaselineEsc; "
            "from sideslip.control.stability import StabilityController; "
            "LqrDycController(); BaselineEsc(); StabilityController(); print('control' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == "False"


def test_fmus_carry_their_bytecode(fmu_dir):
    with zipfile.ZipFile(fmu_dir / "LqrDycController.fmu") as z:
        names = z.namelist()
    sources = [n for n in names if n.startswith("resources/sideslip_") and "/" in n[len("resources/"):]
               and n.endswith(".py")]
    pycs = [n for n in names if n.endswith(".pyc")]
    assert len(pycs) == len(sources) and all("__pycache__" in n for n in pycs)


RECOVERY_S = 2.0
"""How soon after its inputs come back from a fault an estimator is valid again (docs/deployment.md)."""


def test_valid_comes_back_within_two_seconds_after_a_burst_of_huge_inputs(fmu_dir):
    from sideslip.cosim.assembly import Component
    from sideslip.cosim.replay import replay_fmus
    from sideslip.studies.runs import run_scenario

    names = ["Kim2016SteeringEKF", "Pi2011FuzzyEKF", "Park2018Observer", "SideslipFusion"]
    res = run_scenario("park2018_case2", [], duration=9.0, fmu_dir=fmu_dir).results
    signals = {n.split(".", 1)[1]: res[n].astype(float) for n in res.names if n.startswith("sensors.")}
    rec = Recording(res["time"], signals, {"beta": res["plant.beta"]}, "loop")
    comps = [Component(n, n, {"vehicle": "park2018_sonata"}) for n in names]
    clean = replay_fmus(rec, comps, 1e-3, fmu_dir)
    burst = (rec.time >= 4.0) & (rec.time < 4.2)
    bad = {k: v.copy() for k, v in signals.items()}
    for k in ("ay_m", "yaw_rate_m", "ax_m", "delta_m", "omega_fl_m", "omega_rl_m"):
        bad[k][burst] = 1e300 * np.where(np.arange(burst.sum()) % 2, 1.0, -1.0)
    hit = replay_fmus(Recording(rec.time, bad, rec.reference, "burst"), comps, 1e-3, fmu_dir)
    t = hit["time"]
    for n in names:
        assert not hit[f"{n}.valid"][(t > 4.0) & (t < 4.2)].any(), n
        late = t >= 4.2 + RECOVERY_S
        np.testing.assert_array_equal(hit[f"{n}.valid"][late], clean[f"{n}.valid"][late], err_msg=n)
        assert clean[f"{n}.valid"][late].all(), n
        err = np.degrees(np.abs(hit[f"{n}.beta_hat"] - clean[f"{n}.beta_hat"]))[late]
        assert err.max() < 0.5, (n, err.max())


def test_a_second_free_is_harmless_and_a_freed_instance_refuses_calls(fmu_dir):
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    path = fmu_dir / "BaselineEsc.fmu"
    md = read_model_description(path)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="twice")
    for _ in range(5):
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        slave.doStep(0.0, 0.01)
        comp = slave.component
        slave.terminate()
        slave.freeInstance()
        slave.fmi2FreeInstance(comp)
        slave.fmi2FreeInstance(comp)
        with pytest.raises(FMICallException):
            slave.fmi2DoStep(comp, 0.0, 0.01, 1)
    slave.fmi2FreeInstance(None)


def test_valid_comes_back_after_a_burst_on_the_real_drive(fmu_dir):
    """The same burst on 30 s of the real drive's test slice (derived wheel speeds and GNSS), against the truth."""
    from sideslip.cosim.assembly import Component
    from sideslip.cosim.replay import replay_fmus
    from sideslip.studies.accuracy import REAL, Case, simulate

    names = ["Kim2016SteeringEKF", "Pi2011FuzzyEKF", "SideslipFusion"]
    full = simulate(Case("stanford2014_test", REAL, 0))
    keep = full.time <= full.time[0] + 30.0
    rec = Recording(full.time[keep], {k: np.asarray(v)[keep] for k, v in full.signals.items()},
                    {k: np.asarray(v)[keep] for k, v in full.reference.items()}, "real")
    comps = [Component(n, n, {"vehicle": "stanford_track_car"}) for n in names]
    clean = replay_fmus(rec, comps, 1e-3, fmu_dir)
    back = rec.time[0] + 10.2
    burst = (rec.time >= back - 0.2) & (rec.time < back)
    bad = {k: np.array(v, dtype=float) for k, v in rec.signals.items()}
    for k in ("ay_m", "yaw_rate_m", "ax_m", "delta_m", "omega_fl_m", "omega_rl_m"):
        bad[k][burst] = 1e300 * np.where(np.arange(burst.sum()) % 2, 1.0, -1.0)
    hit = replay_fmus(Recording(rec.time, bad, rec.reference, "burst"), comps, 1e-3, fmu_dir)
    t, truth = hit["time"], rec.on_grid(1e-3).reference["beta"]
    later = t >= back + 3.0
    for n in names:
        valid = hit[f"{n}.valid"] > 0.5
        assert valid[(t >= back) & (t <= back + RECOVERY_S)].any(), n
        err = lambda res: np.sqrt(np.mean(np.degrees(res[f"{n}.beta_hat"] - truth)[later] ** 2))  # noqa: E731
        assert err(hit) < 1.5 * err(clean), (n, err(hit), err(clean))
