"""What several subcommands share: ``KEY=VALUE`` options and the options of a scenario run or a case set."""
from __future__ import annotations

import argparse

__all__ = ["kv", "run_args", "case_args", "positive", "count", "window", "file_params", "params_file_arg",
           "EXAMPLES_FORMAT"]

EXAMPLES_FORMAT = argparse.RawDescriptionHelpFormatter
"""The help format of a command with examples in its epilog (kept as written)."""


def positive(text: str) -> float:
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0.0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def count(text: str) -> int:
    """An argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


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
    sp.add_argument("--duration", type=positive, help="simulated time [s] (default: the scenario's)")
    sp.add_argument("--step", type=positive, default=1e-3, help="communication step [s] (default 1e-3)")
    sp.add_argument("--record-every", type=count, default=1, help="record every n-th step (default 1)")
    sp.add_argument("--format", action="append", choices=("csv", "mf4"), help="results file format (repeatable; "
                    "default csv, with its units in results.csv.units.json; mf4: ASAM MDF4, needs asammdf)")
    sp.add_argument("--window", metavar="T0:T1", type=window, help="only this time span [s] in the plot and the "
                    "metrics (the run covers the whole duration)")
    sp.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="scenario override: duration, road_mu, maneuver_<key>, sensor_<key>, ...")
    sp.add_argument("--param", action="append", metavar="INSTANCE.NAME=VALUE", help="FMU parameter override")
    params_file_arg(sp)
    sp.add_argument("--master", choices=("fmpy", "libcosim", "omsimulator"), default="fmpy",
                    help="co-simulation master (libcosim: pip install libcosimpy; omsimulator: set "
                         "SIDESLIP_OMSIMULATOR to its install folder; both Jacobi)")
    sp.add_argument("--scheme", choices=("gauss-seidel", "jacobi"), default="gauss-seidel",
                    help="coupling scheme of the fmpy master")


def params_file_arg(sp) -> None:
    """The ``--params FILE`` option (a parameter file of :mod:`sideslip.fmi.param_file`)."""
    sp.add_argument("--params", metavar="FILE", help="parameter file of one FMU (the chosen.json or chosen.ssv of "
                    "sideslip tune): its values for every instance of that FMU, under any --param")


def file_params(path, components) -> dict:
    """``{"instance.name": value}`` of the parameter file ``path`` for every component running its FMU (an ``.ssv``
    file is taken for the run's controller)."""
    from ..fmi.catalogue import fmu_spec
    from ..fmi.param_file import read_param_file

    fmu = None
    if str(path).lower().endswith(".ssv"):
        fmu = next((c.fmu for c in components if fmu_spec(c.fmu).role == "controller"), None)
        if fmu is None:
            raise ValueError(f"--params {path}: an .ssv file is applied to the run's controller, and it has none")
    fmu, values = read_param_file(path, fmu)
    names = [c.name for c in components if c.fmu == fmu]
    if not names:
        raise ValueError(f"--params {path} holds parameters of {fmu}, which this run does not have")
    return {f"{inst}.{k}": v for inst in names for k, v in values.items()}


def window(text: str) -> tuple[float, float]:
    """An argparse type: ``T0:T1`` in seconds, either end may be empty (the start or the end of the run)."""
    start, sep, end = text.partition(":")
    try:
        t0 = float(start) if start.strip() else float("-inf")
        t1 = float(end) if end.strip() else float("inf")
    except ValueError:
        t0 = t1 = float("nan")
    if not sep or not t1 > t0:
        raise argparse.ArgumentTypeError(f"expected T0:T1 in seconds with T1 > T0 (either may be empty), got {text!r}")
    return t0, t1


def case_args(sp, quick: str, seeds: str, condition: str, scenario: str) -> None:
    """The options that choose a set of cases (``benchmark``, ``control``)."""
    sp.add_argument("--quick", action="store_true", help=quick)
    sp.add_argument("--seeds", type=count, help=f"seeds per scenario and condition ({seeds})")
    sp.add_argument("--condition", action="append", help=f"{condition} (repeatable)")
    sp.add_argument("--scenario", action="append", help=f"{scenario} (repeatable)")
