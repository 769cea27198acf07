"""Closed-loop evaluation of the yaw-moment controllers under realistic sensors and model mismatch.

Every case is a scenario under one of the estimator benchmark's conditions (:data:`CONDITIONS`:
``sensors`` - automotive-grade sensor errors, ``sensors+mismatch`` - those plus the plant on Magic
Formula tires and the estimators' *and the controller's* vehicle perturbed from the plant's;
:mod:`sideslip.studies.accuracy`) with a seed, run in closed loop for every row of
:data:`SOURCES`: no control; the LQR (published and drivable profiles) on the true sideslip; the
LQR on each hardened estimator; the StabilityController (estimator and LQR in one model); the
baseline ESC on the truth and on the best two hardened estimators.  The project's plant has wheel-slip control
there (:data:`WHEEL_SLIP_MAX`: ABS and the motors' slip limit, as a car with stability control has).

Scenarios (:data:`SCENARIOS`): FMVSS 126 sine with dwell on the SUV, 1.5A-6.5A both directions
(:data:`FMVSS_FAMILY`); brake in a turn on packed snow (``park2018_case5``); acceleration in a turn
(``park2018_case3``); a low-speed launch into a turn (``control_launch_turn_sonata``); a long straight
drive (``bench_straight_sonata_long``, its first 40 s: 10 -> 30 m/s); a sine steer while the friction
drops from 0.9 to 0.4 and returns (``bench_changing_mu_sonata``).  On a plant the project did not write
(:data:`OFF_PLANT`, CommonRoad's VW Vanagon, known by its identified vehicle file): the FMVSS 126 runs and the
brake in a turn on snow for the rows of :data:`OFF_PLANT_SOURCES`, reported as the condition
``sensors+mismatch@commonroad3``.  It is the held-out test set of the tuning study (``sideslip tune``,
:mod:`~sideslip.studies.control_eval.study`), whose training and development maneuvers and seeds are others.

* FMVSS 126 (49 CFR 571.126 S5.2, S7.7, S7.11): the yaw rate 1.00 s and 1.75 s after the
  completion of steer must be below 35 % and 20 % of the first yaw-rate peak after the steering
  wheel changes sign; for amplitudes of 5A and more the lateral displacement of the CG 1.07 s
  after the beginning of steer, perpendicular to the initial heading, must be at least 1.83 m.
  A row passes a seed when it passes at every amplitude where the uncontrolled car fails.
* Every run (:func:`control_metrics`): max ``|beta|``, RMS yaw-rate and sideslip tracking errors
  against the reference model of :mod:`sideslip.control.reference` (computed from the driver's
  steering and the plant's speed, so that runs without a controller have a reference too), effort
  ``int |Mz_act| dt``, the share of time saturated, RMS and max of ``d(Mz_cmd)/dt``, the RMS of
  ``Mz_cmd`` and the largest moment against the driver's steering during the launch - all while
  ``v > v_min``.

Two engines run the same cases: ``library`` (the models in one process, :func:`sideslip.plant.loop.run_loop`;
the default, about 6 times faster) and ``fmpy`` (the FMUs, :func:`sideslip.studies.runs.run_scenario`),
which agree (tests/test_stability_control.py).
"""
from .cases import (BEST_TWO, CONDITIONS, DURATION, FMVSS_FAMILY, LAUNCH, OFF_PLANT, OFF_PLANT_SCENARIOS,
                    OFF_PLANT_SOURCES, PUBLISHED_VALUES, QUICK_FACTORS, QUICK_OFF_PLANT_FACTORS, SCENARIOS, SOURCES,
                    WHEEL_SLIP_MAX, ControlCase, Source, control_cases, fmvss_names, scenario_mu, steer_times,
                    with_controller_params)
from .engines import control_evaluation, plot_example, run_control_case, simulate_control
from .measures import control_metrics, fmvss126_metrics
from .report import format_control_evaluation, summarise
from .tuning import DEVELOPMENT_SET, SEARCH_SPACE, TRAINING_SET

__all__ = ["CONDITIONS", "OFF_PLANT", "OFF_PLANT_SCENARIOS", "OFF_PLANT_SOURCES", "FMVSS_FAMILY", "SCENARIOS",
           "QUICK_FACTORS", "QUICK_OFF_PLANT_FACTORS", "DURATION", "LAUNCH", "WHEEL_SLIP_MAX", "BEST_TWO",
           "PUBLISHED_VALUES", "Source", "SOURCES", "ControlCase", "control_cases", "fmvss_names",
           "with_controller_params", "plot_example", "steer_times", "scenario_mu", "fmvss126_metrics",
           "control_metrics", "simulate_control", "run_control_case", "control_evaluation", "summarise",
           "format_control_evaluation", "TRAINING_SET", "DEVELOPMENT_SET", "SEARCH_SPACE"]
