"""The cases of the control evaluation: rows (controller and what feeds it), scenarios, conditions, seeds."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass


from ...fmi.catalogue import fmu_spec
from ...params import declared_fields
from ...plant.maneuvers import parse_maneuver
from ...scenarios import FMVSS_FACTORS
from ..accuracy import OFF_PLANT_CONDITION, PAPER_METHODS
from ..drives import OWN


CONDITIONS = ("sensors", "sensors+mismatch")
FMVSS_FAMILY = "fmvss126_suv_mu08"
SCENARIOS = ("park2018_case5", "park2018_case3", "control_launch_turn_sonata", "bench_straight_sonata_long",
             "bench_changing_mu_sonata")
DURATION = {"bench_straight_sonata_long": 40.0}
"""Scenarios run shorter than defined [s] (the straight drive: 10 s at 10 m/s, 0.8 m/s2 to 30 m/s, 5 s at it)."""
LAUNCH = "control_launch_turn_sonata"
WHEEL_SLIP_MAX = 0.1
"""The project's plant in every closed loop of the evaluation and the tuning study has wheel-slip control (its
``wheel_slip_max``: ABS on the brakes, a slip limit on the in-wheel motors), as every car with stability control
has: without it the driver's brake locks the wheels in a braked turn on snow and the motors' torque difference
spins the wheels, and which wheel locks when, not the controller, decides the outcome (docs, "Stability control")."""


@dataclass(frozen=True)
class Source:
    """One row: a controller fed by the truth or an estimator (hardened profile), or no control."""

    label: str
    controller: str | None = None          #: FMU name of the controller, None for no control
    estimator: str | None = None           #: estimator name, None for the plant's truth
    params: tuple = ()                     #: ((name, value), ...) of the controller on top of its defaults


BEST_TWO = ("Yoon2014DualKF", "Kim2016SteeringEKF")
"""The two hardened estimators with the smallest mean sideslip error on the benchmark (docs/benchmark.md)."""
PUBLISHED_VALUES = (("control_profile", 0), ("q_beta", 1.0e10), ("q_gamma", 3.0e8), ("tau_beta", 0.15),
                    ("tau_gamma", 0.10))
"""The published row's LQR: Nguyen 2012's profile with the sideslip weighted above the yaw rate, as the paper chooses
(the text after eq 26; it prints no numbers), and reference lags of 0.15 and 0.10 s (it prints none either).  The
drivable profile's defaults are the tuning study's and weight the yaw rate more."""

SOURCES = (
    Source("none"),
    Source("LQR published / truth", "LqrDycController", None, PUBLISHED_VALUES),
    Source("LQR / truth", "LqrDycController"),
    *(Source(f"LQR / {e}", "LqrDycController", e) for e in PAPER_METHODS),
    Source("LQR / SideslipFusion", "LqrDycController", "SideslipFusion"),
    Source("LQR / truth, fixed mu", "LqrDycController", None, (("friction_source", 0),)),
    Source("LQR / SideslipFusion, fixed mu", "LqrDycController", "SideslipFusion", (("friction_source", 0),)),
    Source(f"StabilityController ({BEST_TWO[0]})", "StabilityController", BEST_TWO[0]),
    Source("StabilityController (SideslipFusion)", "StabilityController", "SideslipFusion"),
    Source("ESC / truth", "BaselineEsc"),
    *(Source(f"ESC / {e}", "BaselineEsc", e) for e in BEST_TWO),
)
"""The rows of the evaluation."""


@dataclass(frozen=True)
class ControlCase:
    """A scenario under a condition with a seed, for one row."""

    scenario: str
    condition: str
    seed: int
    source: Source
    params: tuple = ()                     #: controller parameter overrides (tuning)
    overrides: tuple = ()                  #: scenario overrides
    plant: str = OWN                       #: the plant (sideslip.studies.drives.PLANTS)
    wheel_slip_max: float = WHEEL_SLIP_MAX  #: the project's plant's wheel-slip control (0: none; CommonRoad's: unused)

    @property
    def condition_label(self) -> str:
        """The condition, with the plant when it is not the project's (``sensors+mismatch@commonroad3``), and with the
        project's plant's wheel-slip control when it is not :data:`WHEEL_SLIP_MAX` (``sensors, wheel_slip_max 0``)."""
        if self.plant != OWN:
            return f"{self.condition}@{self.plant}"
        if self.wheel_slip_max != WHEEL_SLIP_MAX:
            return f"{self.condition}, wheel_slip_max {self.wheel_slip_max:g}"
        return self.condition


QUICK_FACTORS = (3.5, 5.0, 6.5)
"""FMVSS 126 amplitudes of ``--quick``: the first the uncontrolled SUV fails, the first with the
displacement criterion, the largest."""
QUICK_OFF_PLANT_FACTORS = (5.0, 6.5)
"""FMVSS 126 amplitudes of ``--quick`` on :data:`OFF_PLANT`: those with the displacement criterion."""


def with_controller_params(case: ControlCase, params) -> ControlCase:
    """The case with the controller parameters ``params`` (``(name, value)`` pairs) its controller has."""
    if not case.source.controller:
        return case
    names = {f.name for f, _ in declared_fields(fmu_spec(case.source.controller).config_class)}
    return dataclasses.replace(case, params=case.params + tuple((k, v) for k, v in params if k in names))


def fmvss_names(factors=FMVSS_FACTORS, directions=("", "_right"), family: str = FMVSS_FAMILY) -> list[str]:
    """Scenario names of the FMVSS 126 runs."""
    return [f"{family}_a{f:.1f}{d}" for f in factors for d in directions]


def fmvss_family(scenario: str) -> str:
    """The car and road of an FMVSS 126 run: its scenario's name less the amplitude and direction
    (``fmvss126_suv_mu05_a6.5_right`` -> ``fmvss126_suv_mu05``); another name is its own family."""
    head, _, tail = scenario.rpartition("_a")
    return head if head and tail[:1].isdigit() else scenario


OFF_PLANT = "commonroad3"
"""The third-party plant of the evaluation: CommonRoad's VW Vanagon, known to the controllers and estimators by its
identified vehicle file (the estimator benchmark's test-set car; :mod:`sideslip.studies.drives`)."""
OFF_PLANT_SCENARIOS = ("park2018_case5",)
"""Besides FMVSS 126, what runs on :data:`OFF_PLANT`: the brake in a turn on snow."""
OFF_PLANT_SOURCES = ("none", "LQR / truth", "LQR / SideslipFusion", "LQR / SideslipFusion, fixed mu", "ESC / truth")
"""The rows run on :data:`OFF_PLANT` (its model is Python, many times the cost per step of the project's compiled
one)."""


def control_cases(sources=SOURCES, conditions=CONDITIONS, seeds=2, factors=FMVSS_FACTORS, directions=("", "_right"),
                  scenarios=SCENARIOS, off_plant: bool = True, off_plant_factors=None,
                  off_plants=(OFF_PLANT,), wheel_slip_max: float = WHEEL_SLIP_MAX) -> list[ControlCase]:
    """Every scenario x condition x seed x row on the project's plant (with ``wheel_slip_max``) and, with
    ``off_plant``, the FMVSS 126 runs (at ``off_plant_factors``, default ``factors``) and :data:`OFF_PLANT_SCENARIOS`
    x seed x the rows of ``sources`` among :data:`OFF_PLANT_SOURCES` on each of ``off_plants`` (CommonRoad's,
    :data:`sideslip.studies.drives.PLANTS`; default :data:`OFF_PLANT`), under
    :data:`~sideslip.studies.accuracy.OFF_PLANT_CONDITION`."""
    fmvss = fmvss_names(factors, directions)
    names = [*fmvss, *scenarios]
    out = [ControlCase(n, c, s, src, wheel_slip_max=wheel_slip_max)
           for n in names for c in conditions for s in range(seeds) for src in sources]
    if off_plant:
        off = [*fmvss_names(factors if off_plant_factors is None else off_plant_factors, directions),
               *(n for n in OFF_PLANT_SCENARIOS if n in scenarios)]
        out += [ControlCase(n, OFF_PLANT_CONDITION, s, src, plant=plant, wheel_slip_max=wheel_slip_max)
                for plant in off_plants for n in off
                for s in range(seeds) for src in sources if src.label in OFF_PLANT_SOURCES]
    return out


def steer_times(scenario) -> tuple[float, float, float]:
    """Beginning of steer, completion of steer [s] and sine frequency [Hz] of a sine-with-dwell scenario
    (from its maneuver, so that overrides such as ``maneuver_t_start`` are followed)."""
    man = parse_maneuver(scenario.maneuver)
    return man.t_start, man.completion_of_steer, man.frequency


def scenario_mu(scenario) -> float:
    """Friction of a scenario for the controller: its ``mu`` hint, else its road friction (of a time table
    ``"t0:v0, t1:v1, ..."``, the highest: the controller is set for the road at its best)."""
    if "mu" in scenario.hints:
        return float(scenario.hints["mu"])
    return max(float(item.rpartition(":")[2]) for item in str(scenario.road_mu).split(","))
