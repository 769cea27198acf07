"""The papers' tables with the FMUs in closed loop: the figures reached, each with the margin stated.

The reached values (README, "Estimator accuracy") are measured with seeded sensors, so a run
is deterministic on one machine; the margins cover floating-point differences between
machines and small, deliberate retuning.  Where a target of the issue is met the test asserts
the target itself; where it is missed (documented in the README with the evidence) the test
pins the reached value so a regression shows.
"""
import math

import pytest

from sideslip.cosim import paper_tables as pt

MARGIN = 1.15
"""Reached figures may grow by 15 % before a test fails."""

PARK_REACHED = {1: 0.172, 2: 0.067, 3: 0.070, 4: 0.308, 5: 0.482}
"""RMS sideslip error [deg] of the integrated observer per case, as measured."""


@pytest.fixture(scope="module")
def park(fmu_dir):
    return pt.park2018_accuracy(fmu_dir)


def test_park2018_integrated_observer_meets_table3_rms_on_cases_2_to_5(park):
    for case in (2, 3, 4, 5):
        assert park[case]["integrated"]["rms"] <= park[case]["paper"]["rms"], case


def test_park2018_reached_figures(park):
    for case, reached in PARK_REACHED.items():
        assert park[case]["integrated"]["rms"] <= MARGIN * reached, case
    # case 1 (3 Hz steering) misses the paper's 0.063 deg: README, "Park 2018: where it misses"
    assert park[1]["integrated"]["rms"] > park[1]["paper"]["rms"]


def test_park2018_integrated_observer_against_its_sub_filters(park):
    """Better than each sub-filter on the spin-out (case 5), better than the bicycle EKF on cases 1, 2 and
    4, better than the kinematic EKF on case 3; the rest is the README's documented miss."""
    row = park[5]
    assert row["integrated"]["rms"] < min(row["bicycle EKF"]["rms"], row["kinematic EKF"]["rms"])
    for case in (1, 2, 4):
        assert park[case]["integrated"]["rms"] < park[case]["bicycle EKF"]["rms"], case
    assert park[3]["integrated"]["rms"] < park[3]["kinematic EKF"]["rms"]
    # the direct-integration baseline drifts with the sensor offsets; the method does not
    for case in PARK_REACHED:
        assert park[case]["integrated"]["rms"] < park[case]["OpenLoopKinematic"]["rms"], case


def test_park2018_table_renders(park):
    text = pt.format_park2018_accuracy(park)
    assert text.count("\n") == 6 and "0.063 / 0.218" in text


def test_park2018_gps_outage_in_case3(fmu_dir):
    res = pt.park2018_gps_outage(fmu_dir, "park2018_case3", (15.0, 20.0))
    assert res["gps_valid_during"] == 0.0
    out = res["beta_hat"]
    assert out["rms_outage"] <= MARGIN * 0.087 and out["max_outage"] <= MARGIN * 0.279
    assert out["recovery_s"] <= 0.5
    kin = res["beta_hat_kinematic"]
    assert 0.0 < kin["max_shift_during"] <= MARGIN * 0.112    # open loop: it drifts, a little, then recovers
    assert kin["recovery_s"] <= 0.5
    assert res["beta_hat_bicycle"]["max_shift_during"] == 0.0  # the bicycle EKF does not use the GPS


def test_kim2016_table3_better_on_all_and_no_false_alarm(fmu_dir):
    table = pt.kim2016_accuracy(fmu_dir)
    reached = {"kim2016_track_40": {"beta": 0.0016, "yaw_rate": 0.0133, "delta": 0.0037},
               "kim2016_track_80": {"beta": 0.0011, "yaw_rate": 0.0127, "delta": 0.0030}}
    for name, row in table.items():
        for key in ("beta", "yaw_rate", "delta"):
            assert row[key] < row["paper"][key], (name, key)
            assert row[key] <= MARGIN * reached[name][key], (name, key)
        assert not row["false_alarm"], name
        assert row["max_abs_residual"] <= 0.5 * 0.05          # half the detector threshold


def test_kim2016_steering_fault_detection_delay(fmu_dir):
    rows = pt.kim2016_fault_detection(fmu_dir)
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
    (m1, a1), (m2, a2) = pt.run_jobs([job, job], fmu_dir, workers=2)
    assert (a1["Park2018Observer.beta_hat"] == a2["Park2018Observer.beta_hat"]).all()
    assert m1["summary"]["duration"] == pytest.approx(0.5)
