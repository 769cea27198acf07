"""The papers' tables with the FMUs in closed loop: the figures reached, each with the margin stated.

The reached values (docs/accuracy.md) are measured with seeded sensors, so a run
is deterministic on one machine; the margins cover floating-point differences between
machines and small, deliberate retuning.  Where a target is met the test asserts
the target itself; where it is missed (documented in docs/accuracy.md with the evidence) the test
pins the reached value so a regression shows.
"""
import math

import pytest

from sideslip.studies.papers import kim2016, nguyen2012, park2018, pi2011, yoon2014
from sideslip.studies.runs import run_jobs

pytestmark = pytest.mark.slow          # every test here runs whole scenarios in closed loop

MARGIN = 1.15
"""Reached figures may grow by 15 % before a test fails."""

PARK_REACHED = {1: 0.172, 2: 0.067, 3: 0.070, 4: 0.308, 5: 0.482}
"""RMS sideslip error [deg] of the integrated observer per case, as measured."""


@pytest.fixture(scope="module")
def park(fmu_dir):
    return park2018.park2018_accuracy(fmu_dir)


def test_park2018_integrated_observer_meets_table3_rms_on_cases_2_to_5(park):
    for case in (2, 3, 4, 5):
        assert park[case]["integrated"]["rms"] <= park[case]["paper"]["rms"], case


def test_park2018_reached_figures(park):
    for case, reached in PARK_REACHED.items():
        assert park[case]["integrated"]["rms"] <= MARGIN * reached, case
    # case 1 (3 Hz steering) misses the paper's 0.063 deg: docs/accuracy.md, "Park 2018: where it misses"
    assert park[1]["integrated"]["rms"] > park[1]["paper"]["rms"]


def test_park2018_integrated_observer_against_its_sub_filters(park):
    """Better than each sub-filter on the spin-out (case 5), better than the bicycle EKF on cases 1, 2 and
    4, better than the kinematic EKF on case 3; the rest is the documented miss (docs/accuracy.md)."""
    row = park[5]
    assert row["integrated"]["rms"] < min(row["bicycle EKF"]["rms"], row["kinematic EKF"]["rms"])
    for case in (1, 2, 4):
        assert park[case]["integrated"]["rms"] < park[case]["bicycle EKF"]["rms"], case
    assert park[3]["integrated"]["rms"] < park[3]["kinematic EKF"]["rms"]
    # the direct-integration baseline drifts with the sensor offsets; the method does not
    for case in PARK_REACHED:
        assert park[case]["integrated"]["rms"] < park[case]["OpenLoopKinematic"]["rms"], case


def test_park2018_table_renders(park):
    text = park2018.format_park2018_accuracy(park)
    assert text.count("\n") == 6 and "0.063 / 0.218" in text


def test_park2018_gps_outage_in_case3(fmu_dir):
    res = park2018.park2018_gps_outage(fmu_dir, "park2018_case3", (15.0, 20.0))
    assert res["gps_valid_during"] == 0.0
    out = res["beta_hat"]
    assert out["rms_outage"] <= MARGIN * 0.087 and out["max_outage"] <= MARGIN * 0.279
    assert out["recovery_s"] <= 0.5
    kin = res["beta_hat_kinematic"]
    assert 0.0 < kin["max_shift_during"] <= MARGIN * 0.112    # open loop: it drifts, a little, then recovers
    assert kin["recovery_s"] <= 0.5
    assert res["beta_hat_bicycle"]["max_shift_during"] == 0.0  # the bicycle EKF does not use the GPS


def test_kim2016_table3_better_on_all_and_no_false_alarm(fmu_dir):
    table = kim2016.kim2016_accuracy(fmu_dir)
    reached = {"kim2016_track_40": {"beta": 0.0016, "yaw_rate": 0.0133, "delta": 0.0037},
               "kim2016_track_80": {"beta": 0.0011, "yaw_rate": 0.0127, "delta": 0.0030}}
    for name, row in table.items():
        for key in ("beta", "yaw_rate", "delta"):
            assert row[key] < row["paper"][key], (name, key)
            assert row[key] <= MARGIN * reached[name][key], (name, key)
        assert not row["false_alarm"], name
        assert row["max_abs_residual"] <= 0.5 * 0.05          # half the detector threshold


def test_kim2016_steering_fault_detection_delay(fmu_dir):
    rows = kim2016.kim2016_fault_detection(fmu_dir)
    assert not any(r["flagged_before_fault"] for r in rows)
    by = {(r["scenario"], r["mode"], r["offset"]): r for r in rows}
    assert by[("kim2016_track_80", "offset", 0.08)]["delay_s"] <= MARGIN * 0.75
    assert by[("kim2016_track_80", "offset", 0.06)]["delay_s"] <= MARGIN * 1.08
    assert by[("kim2016_track_40", "offset", -0.08)]["delay_s"] <= MARGIN * 0.77
    stuck = by[("kim2016_track_80", "stuck", 0.0)]
    assert math.isfinite(stuck["delay_s"]) and stuck["delay_after_departure_s"] <= MARGIN * 0.89


def test_parallel_runs_work_after_fmus_were_loaded_in_this_process(harness, fmu_dir):
    """Loading a pythonfmu FMU puts its resources/ (a copy of the package) on sys.path; spawned
    workers must still import this package and find every FMU."""
    import sys

    harness("Park2018Observer")
    assert any(p.endswith("resources") for p in sys.path)
    job = ("park2018_case2", ("Park2018Observer",), None, None, ("Park2018Observer.beta_hat",), 0.5)
    (m1, a1), (m2, a2) = run_jobs([job, job], fmu_dir, workers=2)
    assert (a1["Park2018Observer.beta_hat"] == a2["Park2018Observer.beta_hat"]).all()
    assert m1["summary"]["duration"] == pytest.approx(0.5)


# ---------------------------------------------------------------- Estimators II
def test_nguyen2012_table3(fmu_dir):
    """DACMRKF at or below Table III on both; the ranking DACMRKF < MRKF < SRKF holds on the cornering
    test; on the lane change the DACMRKF is the worst (docs/accuracy.md, "Nguyen 2012: where it meets and misses")."""
    t = nguyen2012.nguyen2012_accuracy(fmu_dir)
    lc, co = t["nguyen2012_lanechange"]["rmsd"], t["nguyen2012_cornering"]["rmsd"]
    assert lc["dacmrkf"] <= 0.38e-2 and co["dacmrkf"] <= 0.41e-2
    assert co["dacmrkf"] < co["mrkf"] < co["srkf"]
    reached = {"nguyen2012_lanechange": {"srkf": 0.146e-2, "mrkf": 0.145e-2, "dacmrkf": 0.270e-2},
               "nguyen2012_cornering": {"srkf": 1.008e-2, "mrkf": 1.006e-2, "dacmrkf": 0.387e-2}}
    for name, row in reached.items():
        for mode, value in row.items():
            assert t[name]["rmsd"][mode] <= MARGIN * value, (name, mode)
    # between fixes the error of the multi-rate filters grows, but the DACMRKF stays below the others
    inter = t["nguyen2012_cornering"]["inter_sample"]
    assert max(inter["dacmrkf"]) < min(inter["mrkf"])


def test_pi2011_table4(fmu_dir):
    """Better than both baselines on every road, max and mean; Table 4's values are not reached (docs/accuracy.md)."""
    t = pi2011.pi2011_accuracy(fmu_dir)
    reached = {"pi2011_high": (7.4, 2.51), "pi2011_medium": (14.4, 3.08), "pi2011_low": (37.0, 9.14)}
    for road, row in t.items():
        for key in ("max", "mean"):
            assert row["method"][key] < min(row["model"][key], row["kinematic"][key]), (road, key)
        assert row["method"]["max"] <= MARGIN * reached[road][0] and row["method"]["mean"] <= MARGIN * reached[road][1]


YOON_SUBSET = ("yoon2014_dlc_ice", "yoon2014_slalom_asphalt_banked", "yoon2014_jturn_asphalt",
               "yoon2014_jturn_ice_banked")


def test_yoon2014_overall_rms_and_ablations(fmu_dir):
    """Four of the sixteen runs (every maneuver, both roads, flat and banked; the CLI runs all sixteen):
    overall RMS below the 1.3 deg target, each ablation worse, at Table II's and Table III's levels."""
    t = yoon2014.yoon2014_accuracy(fmu_dir, scenarios=YOON_SUBSET)
    reached = {"table2": 0.132, "[0.05,1] at 20%": 0.445, "[0.05,1] at 40%": 0.926}
    for level, res in t.items():
        o = res["overall"]
        assert o["full"] <= MARGIN * reached[level], level
        assert o["no_rejection"] > 4 * o["full"], level
    assert t["table2"]["overall"]["full"] <= 1.3
    assert t["table2"]["overall"]["no_shifting"] > 5 * t["table2"]["overall"]["full"]
