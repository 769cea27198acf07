"""What several subcommands share: ``KEY=VALUE`` options and the options of a scenario run or a case set."""
from __future__ import annotations

__all__ = ["kv", "run_args", "case_args"]


def kv(items, what) -> dict:
    """``{key: value}`` of repeated ``KEY=VALUE`` options."""
    from ..params import ParameterError, parse_assignment

    try:
        return dict(parse_assignment(item, what) for item in items or [])
    except ParameterError as exc:
        raise SystemExit(f"{what}: expected KEY=VALUE, got {exc.value!r}") from None


def run_args(sp, scenario_required: bool) -> None:
    """The options of a closed loop of a scenario (``run``, ``demo``)."""
    sp.add_argument("--scenario", required=scenario_required, help="scenario name (see list)")
    sp.add_argument("--controller", default="none", help="controller FMU or 'none'")
    sp.add_argument("--control-source", help="what feeds the controller: an estimator instance (default: the "
                    "first) or 'truth' (the plant's beta and vx)")
    sp.add_argument("--out", help="output folder (default out/<scenario>)")
    sp.add_argument("--duration", type=float, help="simulated time [s] (default: the scenario's)")
    sp.add_argument("--step", type=float, default=1e-3, help="communication step [s] (default 1e-3)")
    sp.add_argument("--record-every", type=int, default=1, help="record every n-th step")
    sp.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="scenario override: duration, road_mu, maneuver_<key>, sensor_<key>, ...")
    sp.add_argument("--param", action="append", metavar="INSTANCE.NAME=VALUE", help="FMU parameter override")
    sp.add_argument("--master", choices=("fmpy", "libcosim", "omsimulator"), default="fmpy",
                    help="co-simulation master (libcosim: pip install libcosimpy; omsimulator: set "
                         "SIDESLIP_OMSIMULATOR to its install folder; both Jacobi)")
    sp.add_argument("--scheme", choices=("gauss-seidel", "jacobi"), default="gauss-seidel",
                    help="coupling scheme of the fmpy master")


def case_args(sp, quick: str, seeds: str, condition: str, scenario: str) -> None:
    """The options that choose a set of cases (``benchmark``, ``control``)."""
    sp.add_argument("--quick", action="store_true", help=quick)
    sp.add_argument("--seeds", type=int, help=f"seeds per scenario and condition ({seeds})")
    sp.add_argument("--condition", action="append", help=f"{condition} (repeatable)")
    sp.add_argument("--scenario", action="append", help=f"{scenario} (repeatable)")
