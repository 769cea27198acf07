"""``run``, ``demo`` and ``export-ssp``: a scenario's closed loop, with metrics and a plot, or as an SSP package."""
from __future__ import annotations

import sys
from pathlib import Path

from .common import EXAMPLES_FORMAT, file_params, kv, params_file_arg, run_args

__all__ = ["register", "DEMO_SCENARIO"]

DEMO_SCENARIO = "park2018_case2"
PROFILES = {"published": 0, "hardened": 1}
"""The ``profile`` values of the paper methods by name."""


def _sensor_offsets(scenario: str, overrides: dict) -> str:
    """The scenario's non-zero sensor biases, e.g. ``yaw_rate 0.00873 rad/s``."""
    from ..params import declared_fields
    from ..plant.sensors import SensorConfig
    from ..units import unit_of_quantity
    from ..scenarios import get_scenario

    sensors = get_scenario(scenario, **(overrides or {})).sensors
    biases = {f.name[:-len("_bias")]: (float(sensors.get(f.name, 0.0)), unit_of_quantity(info.quantity))
              for f, info in declared_fields(SensorConfig) if f.name.endswith("_bias")}
    return ", ".join(f"{name} {value:.3g} {unit}" for name, (value, unit) in biases.items() if value)


def _assumptions(estimators) -> list[tuple[str, str]]:
    """``(instance, needs)`` of the run's estimators that state sensor assumptions."""
    from ..cosim.assembly import estimator_instances
    from ..fmi.catalogue import fmu_spec

    found = [(inst, getattr(fmu_spec(fmu).model_class, "needs", ""))
             for inst, fmu in estimator_instances(estimators)]
    return [(inst, text) for inst, text in found if text]


def _run(args, estimators, out_dir) -> int:
    from ..cosim.assembly import scenario_components
    from ..progress import fraction_callback, progress_bar
    from ..scenarios import get_scenario
    from ..studies.runs import run_scenario

    controller = None if args.controller in (None, "none") else args.controller
    overrides = kv(args.set, "--set")
    if getattr(args, "profile", None):
        overrides["estimator_profile"] = PROFILES[args.profile]
    params = kv(args.param, "--param")
    formats = tuple(dict.fromkeys(args.format or ["csv"]))
    # every name and value checked before an FMU is built or loaded
    scenario = get_scenario(args.scenario, **overrides)
    comps, _ = scenario_components(scenario, estimators, controller, params, getattr(args, "control_source", None))
    if args.params:
        params = {**file_params(args.params, comps), **params}
        scenario_components(scenario, estimators, controller, params, getattr(args, "control_source", None))
    duration = args.duration or scenario.duration
    if args.window and args.window[0] >= duration:
        raise ValueError(f"--window starts at {args.window[0]:g} s, after the run's end at {duration:g} s")
    print(f"running {args.scenario}" + (f" with {', '.join(estimators)}" if estimators else "")
          + (f", controller {controller}" if controller else "") + f" -> {out_dir}", file=sys.stderr)
    with progress_bar(duration, "closed loop", "sim s") as bar:
        run = run_scenario(args.scenario, estimators, controller, out_dir=out_dir, duration=args.duration,
                           step=args.step, record_every=args.record_every, fmu_dir=args.fmu_dir,
                           params=params, overrides=overrides,
                           control_source=getattr(args, "control_source", None),
                           progress=fraction_callback(bar) if not bar.disable else None,
                           master=getattr(args, "master", "fmpy"), scheme=getattr(args, "scheme", "gauss-seidel"),
                           window=args.window, formats=formats)
    m = run.metrics
    s = m["summary"]
    print(f"scenario {m['scenario']['name']}: {m['scenario']['description']}")
    print(f"  truth: max |beta| {s['max_abs_beta_deg']:.2f} deg, max |ay| {s['max_abs_ay']:.2f} m/s2, "
          f"max |yaw rate| {s['max_abs_yaw_rate_deg_s']:.1f} deg/s, final speed {s['final_speed']:.2f} m/s")
    offsets = _sensor_offsets(args.scenario, kv(args.set, "--set"))
    if offsets:
        print(f"  sensor offsets: {offsets}")
    print(f"  {m['us_per_step']:.1f} us per step, {m['real_time_factor']:.1f}x real time "
          f"({m['simulation_wall_time']:.1f} s wall)")
    if run.table():
        print()
        print(run.table())
    needs = _assumptions(estimators)
    if needs:
        print("\nwhat these methods assume of their sensors (outside it their error grows):")
        for name, text in needs:
            print(f"  {name}: {text}")
    warnings = [msg for msg in m["messages"] if msg.startswith(("[warning]", "[error]"))]
    if warnings:
        print("\nFMU messages:")
        for msg in warnings[:20]:
            print("  " + msg)
    files = [f"results.{f}" for f in formats] + ["metrics.json", "sideslip.png"]
    print(f"\nwrote {Path(out_dir) / files[0]}, " + ", ".join(files[1:]))
    return 0


def _cmd_run(args) -> int:
    out = args.out or str(Path("out") / args.scenario)
    return _run(args, args.estimator or [], out)


def _cmd_demo(args) -> int:
    from ..fmi.catalogue import fmu_names

    args.scenario = args.scenario or DEMO_SCENARIO
    return _run(args, fmu_names("estimator"), args.out or str(Path("out") / "demo"))


def _cmd_export_ssp(args) -> int:
    from ..cosim.assembly import scenario_components
    from ..cosim.ssp import export_ssp
    from ..scenarios import get_scenario

    controller = None if args.controller in (None, "none") else args.controller
    params = kv(args.param, "--param")
    if args.params:
        comps, _ = scenario_components(get_scenario(args.scenario, **kv(args.set, "--set")), args.estimator or (),
                                       controller, params, args.control_source)
        params = {**file_params(args.params, comps), **params}
    out = export_ssp(args.out, args.scenario, args.estimator or (), controller, params=params,
                     control_source=args.control_source, overrides=kv(args.set, "--set"),
                     duration=args.duration, step=args.step, fmu_dir=args.fmu_dir)
    print(f"wrote {out}")
    return 0


def register(sub) -> None:
    run = sub.add_parser("run", help="run a scenario in closed loop", formatter_class=EXAMPLES_FORMAT, epilog=(
        "examples:\n  sideslip run --scenario pi2011_medium --estimator SideslipFusion --controller LqrDycController\n"
        "  sideslip run --scenario pi2011_low --set road_mu=0.25 --duration 5 --window 1:4 --format mf4\n"
        "  sideslip run --scenario nguyen2012_cornering --estimator srkf=Nguyen2012DACMRKF --param srkf.mode=srkf"))
    run_args(run, True)
    run.add_argument("--estimator", action="append", help="estimator FMU (repeatable)")
    run.add_argument("--profile", choices=tuple(PROFILES), help="the paper methods' profile (default: the "
                     "scenario's; a paper's scenario runs them as published)")
    run.set_defaults(func=_cmd_run)
    demo = sub.add_parser("demo", help=f"run {DEMO_SCENARIO} with every estimator (the paper methods hardened), print "
                          "metrics, write a plot", formatter_class=EXAMPLES_FORMAT,
                          epilog="examples:\n  sideslip demo\n  sideslip demo --profile published --out out/published")
    run_args(demo, False)
    demo.add_argument("--profile", choices=tuple(PROFILES), default="hardened", help="the paper methods' profile: "
                      "hardened (default), or published, the papers' form")
    demo.set_defaults(func=_cmd_demo)
    ssp = sub.add_parser("export-ssp", help="write a scenario's closed loop as an SSP 1.0 package (FMUs inside)",
                         formatter_class=EXAMPLES_FORMAT, epilog="example:\n  sideslip export-ssp loop.ssp --scenario "
                         "pi2011_medium --estimator Pi2011FuzzyEKF --controller LqrDycController")
    ssp.add_argument("out", metavar="OUT.ssp", help="the package to write")
    ssp.add_argument("--scenario", required=True, help="scenario name (see list)")
    ssp.add_argument("--estimator", action="append", help="estimator FMU (repeatable)")
    ssp.add_argument("--controller", default="none", help="controller FMU or 'none'")
    ssp.add_argument("--control-source", help="estimator instance or 'truth' feeding the controller")
    ssp.add_argument("--duration", type=float, help="DefaultExperiment stop time [s] (default: the scenario's)")
    ssp.add_argument("--step", type=float, default=1e-3, help="fixed communication step [s] (default 1e-3)")
    ssp.add_argument("--set", action="append", metavar="KEY=VALUE", help="scenario override")
    ssp.add_argument("--param", action="append", metavar="INSTANCE.NAME=VALUE", help="FMU parameter override")
    params_file_arg(ssp)
    ssp.set_defaults(func=_cmd_export_ssp)
