"""Closed-loop stability control with the FMUs: FMVSS 126 outcomes and the brake-in-turn spin-out.

The full evaluation (22 FMVSS 126 runs per beta source, every estimator) is
``python -m sideslip control`` (docs, "Stability control"); this test runs the amplitudes that
decide the outcome: 3.5A (the first the uncontrolled SUV fails), 5A (the first with the 1.83 m
displacement criterion, the tightest for the controlled car: 1.89 m measured on the truth) and 6.5A.
"""
import pytest

from sideslip.studies.control_eval import FMVSS_FAMILY, control_evaluation

BEST = ("Yoon2014DualKF", "Pi2011FuzzyEKF")
"""The two estimators with the smallest sideslip error in the FMVSS 126 runs (0.20 and 0.23 deg RMS, docs/control.md)."""


@pytest.fixture(scope="module")
def evaluation(fmu_dir):
    return control_evaluation(fmu_dir, workers=2, sources=["none", "truth", *BEST], factors=(3.5, 5.0, 6.5),
                              directions=("",), others=("park2018_case5",))


def test_uncontrolled_suv_fails_fmvss126_yaw_stability(evaluation):
    fam = evaluation[FMVSS_FAMILY]["none"]
    assert not fam["pass"]
    assert all(not r["yaw_stable"] for r in fam["runs"].values())          # spins at 3.5A, 5A and 6.5A
    assert fam["yaw_rate_ratio_1s"] > 0.7                                   # measured 0.79


@pytest.mark.parametrize("source", ["truth", *BEST])
def test_lqr_passes_fmvss126_on_true_and_on_estimated_sideslip(evaluation, source):
    fam = evaluation[FMVSS_FAMILY][source]
    assert fam["pass"], fam["failed"]
    assert fam["yaw_rate_ratio_1s"] < 0.35 and fam["yaw_rate_ratio_1p75s"] < 0.20
    assert fam["lateral_1p07s"] >= 1.83
    assert fam["max_abs_beta_deg"] < 12.0                                   # measured 8-10 deg (none: 68)


def test_lqr_limits_the_brake_in_turn_spin_out(evaluation):
    rows = evaluation["park2018_case5"]
    assert rows["none"]["max_abs_beta_deg"] > 30.0                          # measured 35.2
    assert rows["truth"]["max_abs_beta_deg"] < 0.5 * rows["none"]["max_abs_beta_deg"]
    assert rows["truth"]["effort_Nms"] > 0
