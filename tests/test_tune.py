"""The LQR tuning study (sideslip tune): search, resume, stale points, the choice and the parameter file it writes,
which the command line and the FMUs accept."""
import csv
import json
import math
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from sideslip.fmi.param_file import read_param_file, write_param_file
from sideslip.params import ParameterError
from sideslip.studies.control_eval.study import _suggest, open_study, run_study
from sideslip.studies.control_eval.tuning import (OBJECTIVES, SEARCH_SPACE, TRAINING_SET, DEVELOPMENT_SET, TRUST,
                                                  defaults, search_space, tuning_cases)

pytest.importorskip("optuna")

TINY = {"training": (("fmvss126_suv_mu05_a5.0", {"maneuver_t_start": 0.5, "duration": 1.5}),),
        "training_seeds": (100,), "development": (("bench_dev_jturn_suv_ice", {"duration": 1.5}),),
        "development_seeds": (200,), "dev_points": 2, "progress": False, "workers": 1}


def test_the_sets_are_disjoint_from_the_control_evaluation():
    from sideslip.studies.control_eval import SCENARIOS, fmvss_names
    test = set(SCENARIOS) | set(fmvss_names())
    train, dev = {n for n, _ in TRAINING_SET}, {n for n, _ in DEVELOPMENT_SET}
    assert not (train & test) and not (dev & test) and not (train & dev)
    cases = tuning_cases(defaults())
    assert len(cases) == 2 * len(TRAINING_SET) and {c.seed for c in cases} == {100, 101}
    assert all(c.source.controller == "LqrDycController" and dict(c.params) == defaults() for c in cases)
    # every default lies in the searched range (the shipped point is the study's first)
    for name, (kind, lo, hi) in SEARCH_SPACE.items():
        assert lo <= defaults()[name] <= hi, name


@pytest.mark.parametrize("name", ["control_tune_bit_asm_snow_plough", "control_dev_bit_track_snow_plough"])
def test_the_sets_braked_turns_on_snow_on_a_cars_own_brake_balance_plough(name):
    """What the test set's understeering cars do braking in a turn on snow, the sets hold on other cars: uncontrolled
    the car turns at a fraction of the steering's kinematic yaw rate and its sideslip stays small (a spin-out of the
    sets turns at twice its ratio and slides)."""
    from sideslip.scenarios import get_scenario
    from sideslip.studies.control_eval.cases import ControlCase, Source
    from sideslip.studies.control_eval.engines import simulate_control
    from sideslip.studies.control_eval.tuning import CONDITION
    from sideslip.vehicles import load_vehicle

    sc = get_scenario(name)
    assert sc.vehicle_overrides == ""

    def run(scenario, vehicle):
        out = simulate_control(ControlCase(scenario, CONDITION, 100, Source("none")))
        wheelbase = load_vehicle(vehicle).l_f + load_vehicle(vehicle).l_r
        steer = (out["time"] > 4.0) & (out["time"] < 5.0)      # the handwheel held (steered from 3 s, released >= 5 s)
        kinematic = out["plant.vx"][steer] * np.abs(out["driver.delta_f"][steer]) / wheelbase
        turning = np.abs(out["plant.yaw_rate"][steer]).mean() / kinematic.mean()
        return turning, np.degrees(np.abs(out["plant.beta"]).max())

    ratio, beta = run(name, sc.vehicle)
    assert ratio < 0.3 and beta < 3.0
    spin_ratio, spin_beta = run("control_tune_bit_sonata_snow_spin", "park2018_sonata")
    assert spin_ratio > 2 * ratio and spin_beta > 10.0


def test_study_runs_chooses_writes_and_goes_on_where_it_stopped(tmp_path):
    out = tmp_path / "study"
    s = run_study(out, n_trials=3, **TINY)
    assert s["trials"] == 3 and s["sim_seconds"] == 3 * 1.5 and s["shipped"]["trial"] == 0
    assert s["chosen"]["trial"] in s["pareto"]
    rows = list(csv.DictReader((out / "trials.csv").open()))
    assert len(rows) == 3 and {*OBJECTIVES, "fmvss_effort_kNms"} <= set(rows[0])
    assert float(rows[0]["q_beta"]) == defaults()["q_beta"]            # the shipped point first
    fmu, values = read_param_file(out / "chosen.json")
    assert fmu == "LqrDycController" and values == s["chosen"]["parameters"]
    # on the truth the trust in an estimator changes nothing: not searched, the file has the shipped values
    trials = open_study(out / "journal.log").trials
    assert not any(set(TRUST) & set(t.params) for t in trials) and set(values) == set(SEARCH_SPACE)
    assert all(values[k] == defaults()[k] for k in TRUST) and set(search_space("SideslipFusion")) == set(SEARCH_SPACE)
    assert read_param_file(out / "chosen.ssv", "LqrDycController")[1] == pytest.approx(values)
    info = json.loads((out / "chosen.json").read_text())["info"]
    assert set(OBJECTIVES) <= set(info["development"]) and info["trial"] == s["chosen"]["trial"]
    assert (out / "pareto.png").stat().st_size > 10_000
    runs = (out / "runs.jsonl").read_text().splitlines()
    # going on to 4 points runs one more point only: the first three's runs come from the storage and the log
    s2 = run_study(out, n_trials=4, **TINY)
    assert s2["trials"] == 4 and s2["sim_seconds"] == 1.5
    assert (out / "runs.jsonl").read_text().splitlines()[:len(runs)] == runs


def test_points_left_running_by_a_dead_process_are_asked_again(tmp_path):
    out = tmp_path / "study"
    study = open_study(out / "journal.log")
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    import socket
    trial = study.ask()                       # the shipped point, asked by a process that then died
    trial.set_user_attr("owner", f"{socket.gethostname()}:{int(gone.stdout)}")
    assert _suggest(trial) == {k: v for k, v in defaults().items() if k not in TRUST}
    s = run_study(out, n_trials=1, **TINY)
    assert s["released_stale"] == 1 and s["trials"] == 1 and s["shipped"]["trial"] == 1


def test_failing_points_are_marked_failed_and_a_study_that_cannot_finish_says_why(tmp_path, monkeypatch):
    from sideslip.studies.control_eval import study as st
    real = st.evaluate_case

    def flaky(item):                          # every point but the shipped one fails
        params = dict(item[0].params)
        return real(item) if params.get("q_beta", defaults()["q_beta"]) == defaults()["q_beta"] else {"error": "boom"}
    monkeypatch.setattr(st, "evaluate_case", flaky)
    with pytest.raises(RuntimeError, match="points failed.*boom"):
        run_study(tmp_path / "study", n_trials=2, **TINY)    # workers=1: the patched function runs here
    trials = open_study(tmp_path / "study" / "journal.log").trials
    assert trials[0].state.name == "COMPLETE" and len(trials) >= 12
    assert all(t.state.name == "FAIL" and t.user_attrs["error"].endswith("boom") for t in trials[1:])


# ------------------------------------------------------------------------------ the parameter file
def test_parameter_file_round_trips_and_names_what_is_wrong(tmp_path):
    values = {"q_beta": 2.5e9, "q_gamma": 1e8, "friction_source": 1, "mu_floor": 0.3}
    j = write_param_file(tmp_path / "p.json", "LqrDycController", values, {"note": 1})
    x = write_param_file(tmp_path / "p.ssv", "LqrDycController", values)
    assert read_param_file(j) == ("LqrDycController", values)
    assert read_param_file(x, "LqrDycController") == ("LqrDycController", values)
    assert '<ssv:Integer value="1"' in x.read_text() and 'unit="' in x.read_text()
    with pytest.raises(ParameterError, match="q_betta.*q_beta"):
        write_param_file(tmp_path / "bad.json", "LqrDycController", {"q_betta": 1.0})
    (tmp_path / "range.json").write_text(json.dumps({"fmu": "LqrDycController", "parameters": {"mu_floor": 7}}))
    with pytest.raises(ParameterError, match="mu_floor"):
        read_param_file(tmp_path / "range.json")
    with pytest.raises(ValueError, match="not of BaselineEsc"):
        read_param_file(j, "BaselineEsc")
    with pytest.raises(ValueError, match="does not name its FMU"):
        read_param_file(x)


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "sideslip", *args], capture_output=True, text=True, cwd=cwd)


def test_run_and_export_ssp_apply_a_parameter_file_to_the_fmu(tmp_path, fmu_dir):
    # a tight yaw-moment limit makes the file's effect visible in the controller FMU's output
    write_param_file(tmp_path / "p.json", "LqrDycController", {"Mz_max": 10.0, "q_gamma": 1e9, "deadband": 0.0})
    env = ["--fmu-dir", str(fmu_dir)]
    r = _cli(*env, "run", "--scenario", "park2018_case1", "--controller", "LqrDycController", "--control-source",
             "truth", "--duration", "4", "--params", str(tmp_path / "p.json"), "--out", str(tmp_path / "run"),
             cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    with (tmp_path / "run" / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    mz = np.array([float(row["controller.Mz_cmd"]) for row in rows])
    assert np.max(np.abs(mz)) == pytest.approx(10.0, rel=1e-9)
    # the estimator has no such file's FMU: a clear error before anything is built
    write_param_file(tmp_path / "e.json", "BaselineEsc", {"Mz_max": 40.0})
    r = _cli(*env, "run", "--scenario", "park2018_case1", "--controller", "LqrDycController", "--params",
             str(tmp_path / "e.json"), "--out", str(tmp_path / "run2"), cwd=tmp_path)
    assert r.returncode == 2 and "BaselineEsc, which this run does not have" in r.stderr
    write_param_file(tmp_path / "p.ssv", "LqrDycController", {"Mz_max": 40.0})
    r = _cli(*env, "export-ssp", str(tmp_path / "loop.ssp"), "--scenario", "park2018_case1", "--controller",
             "LqrDycController", "--control-source", "truth", "--params", str(tmp_path / "p.ssv"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    ssd = zipfile.ZipFile(tmp_path / "loop.ssp").read("SystemStructure.ssd").decode()
    assert '<ssv:Parameter name="Mz_max"><ssv:Real value="40.0"' in ssd


def _control_args(*argv):
    import argparse
    from sideslip.cli import control
    p = argparse.ArgumentParser()
    p.add_argument("--fmu-dir")
    control.register(p.add_subparsers(dest="cmd"))
    return control.control_case_set(p.parse_args(["control", *argv]))


def test_control_case_sets_default_quick_plants_and_a_parameter_file(tmp_path):
    from sideslip.studies.control_eval import OFF_PLANT, SOURCES
    default = _control_args()
    own = [c for c in default if c.plant == "own"]
    assert len(own) == 22 * 2 * 2 * len(SOURCES) + 5 * 2 * 2 * len(SOURCES) and {c.seed for c in default} == {0, 1}
    assert len(default) - len(own) == (22 + 1) * 2 * 5
    quick = _control_args("--quick")
    assert len(quick) == (6 + 5) * 2 * len(SOURCES) + (4 + 1) * 5
    assert all(c.plant == "own" for c in _control_args("--quick", "--plant", "own"))
    assert all(c.plant == OFF_PLANT for c in _control_args("--quick", "--plant", OFF_PLANT))
    # any of CommonRoad's cars, each with the off-plant rows and runs; a plant not known: the known ones named
    two = _control_args("--quick", "--plant", "commonroad2", "--plant", "commonroad1")
    assert {c.plant for c in two} == {"commonroad1", "commonroad2"} and len(two) == 2 * (4 + 1) * 5
    with pytest.raises(ValueError, match="--plant 'commonroad4': plants are own, commonroad1, commonroad2"):
        _control_args("--plant", "commonroad4")
    # the project's plant's wheel-slip control: the evaluation's by default, none on asking
    from sideslip.studies.control_eval import WHEEL_SLIP_MAX
    assert WHEEL_SLIP_MAX > 0 and {c.wheel_slip_max for c in quick} == {WHEEL_SLIP_MAX}
    locking = _control_args("--quick", "--wheel-slip-max", "0", "--plant", "own")
    assert {c.wheel_slip_max for c in locking} == {0.0}
    assert {c.condition_label for c in locking} == {"sensors, wheel_slip_max 0", "sensors+mismatch, wheel_slip_max 0"}
    assert {c.condition_label for c in quick if c.plant == "own"} == {"sensors", "sensors+mismatch"}
    with pytest.raises(ValueError, match=r"--wheel-slip-max 0.7: a slip in \[0, 0.5\]"):
        _control_args("--wheel-slip-max", "0.7")
    write_param_file(tmp_path / "p.json", "LqrDycController", {"q_gamma": 2e9, "friction_source": 0})
    tuned = _control_args("--quick", "--params", str(tmp_path / "p.json"))
    for c in tuned:                           # the drivable LQR rows; the published one stays the paper's
        if c.source.controller == "LqrDycController" and c.source.label != "LQR published / truth":
            assert dict(c.params)["q_gamma"] == 2e9
        else:
            assert "q_gamma" not in dict(c.params)
    # a row's own setting stays under the file: the fixed-friction rows stay fixed
    from sideslip.studies.control_eval.engines import _controller_values
    from sideslip.scenarios import get_scenario
    write_param_file(tmp_path / "f.json", "LqrDycController", {"friction_source": 1})
    following = _control_args("--quick", "--params", str(tmp_path / "f.json"))
    fixed = next(c for c in following if c.source.label == "LQR / truth, fixed mu")
    assert _controller_values(fixed, None, get_scenario(fixed.scenario))["friction_source"] == 0


def test_straight_drives_and_responsiveness_are_constraints_not_objectives(tmp_path, monkeypatch):
    from sideslip.studies.control_eval import tuning
    moving = {"rms_yaw_rate_error_deg_s": 2.0, "effort_Nms": 3000.0, "max_abs_beta_deg": 4.0, "saturated_pct": 0.0,
              "rms_dMz_dt": 1.0, "sim_seconds": 5.0}
    fmvss = {**moving, "yaw_stable": True, "lateral_1p07s": 1.7, "max_abs_beta_deg": 4.0, "effort_Nms": 2000.0}
    moving = {**moving, "max_abs_beta_deg": 8.0}
    figures = tuning.objectives([moving, fmvss, {"straight": True, "rms_Mz_cmd": 70.0, "sim_seconds": 14.0}])
    assert figures["effort_kNms"] == 2.5 and figures["max_abs_beta_deg"] == 6.0 and figures["sim_seconds"] == 24.0
    assert figures["straight_rms_Mz_cmd"] == 70.0 and figures["fmvss_lateral_m"] == 1.7
    assert figures["fmvss_max_abs_beta_deg"] == 4.0                  # the FMVSS run's alone
    assert figures["fmvss_effort_kNms"] == 2.0
    two = tuning.objectives([fmvss, {**fmvss, "lateral_1p07s": 1.9}])
    assert two["fmvss_lateral_m"] == pytest.approx(1.8) and two["fmvss_lateral_se_m"] == pytest.approx(0.1)
    # the bar's error is the seeds' scatter within a maneuver, not the spread between maneuvers (roads, cars)
    runs = [{**fmvss, "scenario": name, "lateral_1p07s": y} for name, y in
            (("mu05", 1.60), ("mu05", 1.62), ("mu08", 2.60), ("mu08", 2.64))]
    four = tuning.objectives(runs)
    assert four["fmvss_lateral_m"] == pytest.approx(2.115)
    assert four["fmvss_lateral_se_m"] == pytest.approx(math.sqrt(0.0002 / 2 + 0.0008 / 2) / 2)
    # the bar less its standard error: a point within it of the ESC's mean is responsive enough
    assert tuning.constraints(figures, two)["responsive"] == pytest.approx(1.8 - 0.1 - 1.7)
    assert tuning.constraints(figures, {"fmvss_lateral_m": 1.8, "fmvss_stable": 1,
                                        "fmvss_max_abs_beta_deg": 3.5, "fmvss_worst_max_abs_beta_deg": 4.5}) == (
        pytest.approx({"straight": 70.0 - tuning.STRAIGHT_RMS_MAX, "responsive": 0.1, "stable": 0.0, "sideslip": 0.5,
                       "sideslip_worst": -0.5, "effort": 0.0}))
    # the FMVSS runs' effort against the cap (1.2) times the ESC's: 2.0 kN m s is within 1.2 x 1.7, not 1.2 x 1.6
    cap = tuning.EFFORT_CAP
    within, beyond = (tuning.constraints(figures, {"fmvss_effort_kNms": esc})["effort"] for esc in (1.7, 1.6))
    assert within == pytest.approx(2.0 - cap * 1.7) and within < 0.0
    assert beyond == pytest.approx(2.0 - cap * 1.6) and beyond > 0.0
    # a point that leaves an FMVSS run unstable the ESC holds is infeasible
    unstable = tuning.objectives([moving, {**fmvss, "yaw_stable": False}])
    assert unstable["fmvss_stable"] == 0 and tuning.constraints(unstable, {"fmvss_stable": 1})["stable"] == 1.0
    # a study whose straight drive no point keeps quiet enough: every point infeasible, the choice still made
    monkeypatch.setattr(tuning, "STRAIGHT_RMS_MAX", -1.0)
    straight = ("control_tune_straight_suv", {"duration": 1.5})
    s = run_study(tmp_path / "study", n_trials=2, **{**TINY, "training": (*TINY["training"], straight),
                                                      "development": (*TINY["development"], straight)})
    study = open_study(tmp_path / "study" / "journal.log")
    assert study.best_trials == [] and s["chosen"]["trial"] in s["pareto"]
    # each point carries its constraints for the sampler: the straight drive's is its RMS command + 1 N m
    for t in study.trials:
        assert t.system_attrs["constraints:straight"] == t.user_attrs["straight_rms_Mz_cmd"] + 1.0 > 0.0
    rows = list(csv.DictReader((tmp_path / "study" / "trials.csv").open()))
    assert [float(r["straight_rms_Mz_cmd"]) for r in rows] == [t.user_attrs["straight_rms_Mz_cmd"]
                                                             for t in study.trials]
    # a figure not measured constrains nothing
    assert tuning.constraints({"straight_rms_Mz_cmd": 0.0}, {"fmvss_lateral_m": 1.8})["responsive"] == 0.0


def test_the_effort_cap_weighs_each_car_and_road_alike():
    from sideslip.studies.control_eval import tuning
    from sideslip.studies.control_eval.cases import fmvss_family
    assert fmvss_family("fmvss126_asm_mu08_a3.5_right") == "fmvss126_asm_mu08"
    assert fmvss_family("fmvss126_suv_mu05_a5.0") == "fmvss126_suv_mu05"
    assert fmvss_family("pi2011_high") == "pi2011_high"
    run = {"rms_yaw_rate_error_deg_s": 2.0, "max_abs_beta_deg": 3.0, "saturated_pct": 0.0, "rms_dMz_dt": 1.0,
           "sim_seconds": 5.0, "yaw_stable": True, "source": "truth"}

    def runs(efforts):
        return [{**run, "scenario": name, "effort_Nms": e} for name, e in zip(
            ("fmvss126_suv_mu05_a5.0", "fmvss126_suv_mu05_a6.5_right", "fmvss126_asm_mu08_a2.0",
             "fmvss126_asm_mu08_a5.0"), efforts)]

    # the same as the ESC where it spends much, twice where it spends little: 1.14 times its mean over the runs,
    # 1.5 times on the mean over the two cars - beyond the cap
    esc = tuning.objectives(runs((3000.0, 3000.0, 400.0, 600.0)))
    mine = tuning.objectives(runs((3000.0, 3000.0, 800.0, 1200.0)))
    assert esc["fmvss_family_effort_kNms"] == pytest.approx({"fmvss126_suv_mu05": 3.0, "fmvss126_asm_mu08": 0.5})
    assert mine["fmvss_effort_kNms"] < tuning.EFFORT_CAP * esc["fmvss_effort_kNms"]
    assert tuning.constraints(mine, esc)["effort"] == pytest.approx(1.5 - tuning.EFFORT_CAP)
    fair = tuning.objectives(runs((3300.0, 3300.0, 550.0, 550.0)))
    assert tuning.constraints(fair, esc)["effort"] == pytest.approx(1.1 - tuning.EFFORT_CAP)
    # two sources: each car and road's worst
    fusion = [{**r, "source": "SideslipFusion", "effort_Nms": r["effort_Nms"] * (2.0 if "suv" in r["scenario"]
                                                                                  else 0.5)}
              for r in runs((3300.0, 3300.0, 550.0, 550.0))]
    both = tuning.point_figures(runs((3300.0, 3300.0, 550.0, 550.0)) + fusion)
    assert both["fmvss_family_effort_kNms"] == pytest.approx({"fmvss126_suv_mu05": 6.6, "fmvss126_asm_mu08": 0.55})
    assert tuning.constraints(both, esc)["effort"] == pytest.approx((2.2 + 1.1) / 2 - tuning.EFFORT_CAP)


def test_the_worst_fmvss_maneuver_and_every_source_constrain_a_point():
    from sideslip.studies.control_eval import tuning
    run = {"rms_yaw_rate_error_deg_s": 2.0, "effort_Nms": 2000.0, "saturated_pct": 0.0, "rms_dMz_dt": 1.0,
           "sim_seconds": 5.0, "yaw_stable": True}
    # the seeds' mean on each maneuver, the worst maneuver: a point that holds less on mu 0.5 and more on a dry
    # road than the ESC is within the mean's constraint and beyond the worst maneuver's
    runs = [{**run, "scenario": name, "max_abs_beta_deg": b, "source": "truth"}
            for name, b in (("mu05", 3.0), ("mu05", 3.2), ("mu05_b", 3.1), ("mu05_b", 3.1), ("mu08", 5.8),
                            ("mu08", 6.2))]
    esc = [{**r, "max_abs_beta_deg": b} for r, b in zip(runs, (4.0, 4.0, 4.2, 4.2, 5.4, 5.6))]
    mine, bar = tuning.objectives(runs), tuning.objectives(esc)
    assert mine["fmvss_worst_max_abs_beta_deg"] == pytest.approx(6.0) and bar["fmvss_worst_max_abs_beta_deg"] == 5.5
    c = tuning.constraints(mine, bar)
    assert c["sideslip"] < 0.0 and c["sideslip_worst"] == pytest.approx(0.5)
    # two sources: the objectives their mean, a constrained figure the worst source's
    fusion = [{**r, "source": "SideslipFusion", "max_abs_beta_deg": r["max_abs_beta_deg"] - 1.0,
               "rms_yaw_rate_error_deg_s": 3.0, "yaw_stable": r["scenario"] != "mu05_b"} for r in runs]
    both = tuning.point_figures(runs + fusion)
    assert tuning.point_figures(runs) == mine
    assert both["rms_yaw_rate_error_deg_s"] == pytest.approx(2.5) and both["max_abs_beta_deg"] == pytest.approx(
        (mine["max_abs_beta_deg"] * 2 - 1.0) / 2)
    assert both["fmvss_worst_max_abs_beta_deg"] == pytest.approx(6.0) and both["fmvss_stable"] == 4
    assert tuning.constraints(both, bar)["stable"] == 2.0 and both["sim_seconds"] == 60.0
    # the cases: every source x maneuver x seed; the truth named either way, a repeat run once
    cases = tuning_cases(defaults(), TRAINING_SET[:1], (1, 2), ("truth", "SideslipFusion", None))
    assert [(c.source.estimator, c.seed) for c in cases] == [(None, 1), (None, 2), ("SideslipFusion", 1),
                                                             ("SideslipFusion", 2)]
    assert set(search_space(["truth", "SideslipFusion"])) == set(SEARCH_SPACE) and set(search_space("truth")) == (
        set(SEARCH_SPACE) - set(TRUST))


def test_tune_names_a_source_it_does_not_know(tmp_path):
    r = _cli("tune", "--source", "truth", "--source", "SideslipFuzion", "--out", str(tmp_path / "t"), cwd=tmp_path)
    assert r.returncode != 0 and "SideslipFuzion" in r.stderr and "SideslipFusion" in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "t").exists()


def test_without_a_point_within_the_constraints_the_choice_takes_the_least_beyond_them():
    from sideslip.studies.control_eval.study import choose_point
    esc = {"rms_yaw_rate_error_deg_s": 4.0, "effort_kNms": 2.4, "max_abs_beta_deg": 5.6, "fmvss_stable": 10,
           "fmvss_max_abs_beta_deg": 4.9, "fmvss_worst_max_abs_beta_deg": 5.5, "straight_rms_Mz_cmd": 0.0}
    near = {**esc, "rms_yaw_rate_error_deg_s": 3.2, "effort_kNms": 2.45, "max_abs_beta_deg": 4.0,
            "fmvss_max_abs_beta_deg": 4.8, "fmvss_worst_max_abs_beta_deg": 6.0}          # 0.5 deg beyond one
    cheap = {**near, "effort_kNms": 2.0, "max_abs_beta_deg": 4.2, "fmvss_max_abs_beta_deg": 5.0,
             "fmvss_worst_max_abs_beta_deg": 6.3}                                        # 0.9 beyond two, less effort
    best, rank, excess, ok = choose_point({"near": near, "cheap": cheap}, esc)
    assert not ok and rank["cheap"] < rank["near"] and excess == pytest.approx({"near": 0.5, "cheap": 0.9})
    assert best == "near"
    # within the constraints, both: the objectives decide (yaw-rate error and max |beta| over the ESC's)
    fine = {k: {**f, "fmvss_max_abs_beta_deg": 4.8, "fmvss_worst_max_abs_beta_deg": 5.4} for k, f in
            (("near", near), ("cheap", cheap))}
    best, rank, excess, ok = choose_point(fine, esc)
    assert ok and best == "near" and excess == {"near": 0.0, "cheap": 0.0}
    # an unstable point is not chosen however close it is
    best = choose_point({"near": {**near, "fmvss_stable": 9}, "cheap": cheap}, esc)[0]
    assert best == "cheap"


def test_a_study_on_two_sources_runs_each_point_on_both_and_the_esc_on_the_truth(tmp_path):
    s = run_study(tmp_path / "study", n_trials=2, source=("truth", "SideslipFusion"), **{**TINY, "dev_points": 1})
    runs = [json.loads(line) for line in (tmp_path / "study" / "runs.jsonl").read_text().splitlines()]
    esc = [r for r in runs if "BaselineEsc" in r["key"]]
    lqr = [r for r in runs if "LqrDycController" in r["key"]]
    assert {r["result"]["source"] for r in esc} == {"truth"}
    assert {r["result"]["source"] for r in lqr} == {"truth", "SideslipFusion"}
    assert s["source"] == "truth, SideslipFusion" and s["sim_seconds"] == 2 * 2 * 1.5
    trials = open_study(tmp_path / "study" / "journal.log").trials
    assert set(TRUST) <= set(trials[1].params)          # an estimator among the sources: its trust is searched
    assert json.loads((tmp_path / "study" / "chosen.json").read_text())["info"]["source"] == "truth, SideslipFusion"


def test_a_study_started_from_a_point_runs_it_on_the_development_set(tmp_path):
    start = {"q_beta": 1.0e8, "q_gamma": 1.0e6, "Mz_max": 3000.0}       # Mz_max is not searched: left out
    s = run_study(tmp_path / "study", n_trials=2, start=[start], **{**TINY, "dev_points": 1})
    study = open_study(tmp_path / "study" / "journal.log", start=[start])   # opened again: not asked twice
    searched = {k: v for k, v in defaults().items() if k not in TRUST}     # the truth: no trust to search
    assert len(study.trials) == 2 and study.trials[1].params == {**searched, "q_beta": 1.0e8, "q_gamma": 1.0e6}
    # the one front point the development set gets is the best tracking (the shipped); the start point runs too
    assert study.trials[1].values[0] > study.trials[0].values[0]
    assert set(s["development"]) == {"0", "1", "shipped", "esc"}


def test_the_shipped_tuned_file_is_a_point_of_the_search_space_the_fmu_accepts():
    from pathlib import Path
    from sideslip.control.dyc import LqrDycConfig
    from sideslip.params import build
    fmu, values = read_param_file(Path(__file__).resolve().parents[1] / "examples" / "lqr_tuned.json")
    assert fmu == "LqrDycController" and set(values) == set(SEARCH_SPACE)
    cfg = build(LqrDycConfig, values)
    assert all(getattr(cfg, k) == v for k, v in values.items())


def test_the_lqr_defaults_are_the_shipped_file_to_three_significant_figures():
    from pathlib import Path
    from sideslip.control.dyc import LqrDycConfig
    _, values = read_param_file(Path(__file__).resolve().parents[1] / "examples" / "lqr_tuned.json")
    cfg = LqrDycConfig()
    for name, value in values.items():
        if name == "feedforward":           # 0 and the default 2 are both off in the drivable profile
            assert value != 1 and cfg.feedforward != 1
        elif name != "f_ff":                # the feed-forward's bandwidth acts only with it on
            assert getattr(cfg, name) == float(f"{value:.3g}"), name
