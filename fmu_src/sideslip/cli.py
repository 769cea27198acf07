"""Command line: ``python -m sideslip {list,run,demo,bench,benchmark,replay,paper,control,export-ssp,build,docs}``.

``run`` writes ``DIR/results.csv``, ``DIR/metrics.json`` and ``DIR/sideslip.png`` and prints
a metrics table; ``demo`` is ``run`` on a default scenario with every estimator of the FMU
catalogue; ``bench`` prints microseconds per communication step per FMU and the closed-loop
real-time factor; ``paper`` reproduces a paper's result tables with the FMUs (dispatching to
:data:`sideslip.studies.papers.PAPERS`); ``control`` evaluates the yaw-moment controller;
``benchmark`` scores every estimator on the benchmark's cases (:mod:`sideslip.studies.benchmark`);
``replay`` runs estimator FMUs on a recorded drive (:mod:`sideslip.studies.logs`);
``export-ssp`` writes a scenario's closed loop as an SSP 1.0 package; ``run --master libcosim`` or
``--master omsimulator`` runs the loop in another master; ``docs`` writes the per-FMU reference pages.  FMUs are built on first
use (``build/fmus``).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

__all__ = ["main"]

DEMO_SCENARIO = "park2018_case2"


def _kv(items, what) -> dict:
    """``{key: value}`` of repeated ``KEY=VALUE`` options."""
    from .params import ParameterError, parse_assignment

    try:
        return dict(parse_assignment(item, what) for item in items or [])
    except ParameterError as exc:
        raise SystemExit(f"{what}: expected KEY=VALUE, got {exc.value!r}") from None


def _cmd_list(args) -> int:
    from .fmi.catalogue import CATALOGUE
    from .plant.maneuvers import maneuver_names
    from .vehicles import vehicle_names
    from .scenarios import SCENARIOS, get_scenario, scenario_names

    print("scenarios:")
    for name in scenario_names():
        if name.startswith("fmvss126") and name not in SCENARIOS:
            print(f"  {name:34s} (FMVSS 126 family; A computed on first use)")
            continue
        sc = get_scenario(name)
        print(f"  {name:34s} {sc.vehicle:16s} {sc.duration:6.0f} s  {sc.description}  [{sc.source}]")
    print("\nFMUs:")
    for name, e in sorted(CATALOGUE.items(), key=lambda kv: (kv[1].role, kv[0])):
        print(f"  {name:24s} {e.role:11s} {len(e.inputs):3d} inputs {len(e.outputs):3d} outputs")
    print("\nvehicles:  " + ", ".join(vehicle_names()))
    print("maneuvers: " + ", ".join(maneuver_names()))
    return 0


def _sensor_offsets(scenario: str, overrides: dict) -> str:
    """The scenario's non-zero sensor biases, e.g. ``yaw_rate 0.00873 rad/s``."""
    from .params import declared_fields
    from .plant.sensors import SensorConfig
    from .units import unit_of_quantity
    from .scenarios import get_scenario

    sensors = get_scenario(scenario, **(overrides or {})).sensors
    biases = {f.name[:-len("_bias")]: (float(sensors.get(f.name, 0.0)), unit_of_quantity(info.quantity))
              for f, info in declared_fields(SensorConfig) if f.name.endswith("_bias")}
    return ", ".join(f"{name} {value:.3g} {unit}" for name, (value, unit) in biases.items() if value)


def _assumptions(estimators) -> list[tuple[str, str]]:
    """``(instance, needs)`` of the run's estimators that state sensor assumptions."""
    from .cosim.assembly import estimator_instances
    from .fmi.catalogue import fmu_spec

    found = [(inst, getattr(fmu_spec(fmu).model_class, "needs", ""))
             for inst, fmu in estimator_instances(estimators)]
    return [(inst, text) for inst, text in found if text]


def _run(args, estimators, out_dir) -> int:
    from .studies.runs import run_scenario

    def progress(frac):
        print(f"\r  {frac * 100:5.1f} %", end="", file=sys.stderr, flush=True)

    controller = None if args.controller in (None, "none") else args.controller
    print(f"running {args.scenario}" + (f" with {', '.join(estimators)}" if estimators else "")
          + (f", controller {controller}" if controller else "") + f" -> {out_dir}", file=sys.stderr)
    run = run_scenario(args.scenario, estimators, controller, out_dir=out_dir, duration=args.duration,
                       step=args.step, record_every=args.record_every, fmu_dir=args.fmu_dir,
                       params=_kv(args.param, "--param"), overrides=_kv(args.set, "--set"),
                       control_source=getattr(args, "control_source", None),
                       progress=progress if sys.stderr.isatty() else None,
                       master=getattr(args, "master", "fmpy"), scheme=getattr(args, "scheme", "gauss-seidel"))
    print("", file=sys.stderr)
    m = run.metrics
    s = m["summary"]
    print(f"scenario {m['scenario']['name']}: {m['scenario']['description']}")
    print(f"  truth: max |beta| {s['max_abs_beta_deg']:.2f} deg, max |ay| {s['max_abs_ay']:.2f} m/s2, "
          f"max |yaw rate| {s['max_abs_yaw_rate_deg_s']:.1f} deg/s, final speed {s['final_speed']:.2f} m/s")
    offsets = _sensor_offsets(args.scenario, _kv(args.set, "--set"))
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
    print(f"\nwrote {Path(out_dir) / 'results.csv'}, metrics.json, sideslip.png")
    return 0


def _cmd_run(args) -> int:
    out = args.out or str(Path("out") / args.scenario)
    return _run(args, args.estimator or [], out)


def _cmd_demo(args) -> int:
    from .fmi.catalogue import fmu_names

    args.scenario = args.scenario or DEMO_SCENARIO
    return _run(args, fmu_names("estimator"), args.out or str(Path("out") / "demo"))


def _cmd_bench(args) -> int:
    from .studies.bench import format_bench, run_bench

    b = run_bench(duration=args.duration, fmu_dir=args.fmu_dir, repeats=args.repeats)
    print(json.dumps(b, indent=2) if args.json else format_bench(b))
    return 0


def _cmd_paper(args) -> int:
    from .studies.papers import PAPERS

    paper = PAPERS[args.name]
    params = _kv(args.param, "--param")
    if params and not paper.ACCEPTS_PARAMS:
        accepting = ", ".join(n for n, m in PAPERS.items() if m.ACCEPTS_PARAMS)
        raise SystemExit(f"--param applies to {accepting}, not {args.name}")
    figures, text = paper.report(args.fmu_dir, args.workers, params, args.extra or ())
    print(json.dumps(figures, indent=2, default=str) if args.json else text)
    return 0


def _cmd_benchmark(args) -> int:
    import time

    from .studies import benchmark as bm
    from .studies.leaderboard import write_report

    seeds = args.seeds or (2 if args.quick else 5)
    conditions = args.condition or (("nominal", "sensors+mismatch") if args.quick else bm.CONDITIONS)
    sensors, params = _kv(args.sensor, "--sensor"), _kv(args.param, "--param")
    cases = [] if args.log and not args.scenario else bm.cases(args.scenario or None, conditions, seeds,
                                                                training=args.training, development=args.development,
                                                                sensors=sensors)
    cases += [bm.log_case(path, args.map, args.vehicle) for path in args.log or ()]
    print(f"benchmark: {len(cases)} cases ({len({c.scenario for c in cases})} scenarios x {len(conditions)} "
          f"conditions x {seeds} seeds) -> {args.out}", file=sys.stderr)
    t0 = time.perf_counter()
    rows = bm.with_params(bm.select_rows(args.estimator), params)
    results = bm.run_benchmark(cases, rows, args.workers, args.scheduler, progress=sys.stderr.isatty())
    wall = time.perf_counter() - t0
    which = "training" if args.training else "development" if args.development else "test"
    meta = {"seeds": seeds, "conditions": list(conditions), "training": args.training, "set": which, "wall_s": wall,
            "cases": len(cases), "quick": args.quick, "sensors": bm.sensor_overrides(sensors),
            "params": {k: v for row in rows for k, v in row.params if k in params}}
    write_report(results, args.out, title=f"Sideslip estimator benchmark ({which} set)", meta=meta)
    print((Path(args.out) / "leaderboard.md").read_text())
    print(f"{len(cases)} cases in {wall:.0f} s; wrote {args.out}/leaderboard.md, benchmark.json, heatmap.png, "
          "errors_*.png")
    return 0


def _cmd_replay(args) -> int:
    from .studies.logs import format_replay, replay_log

    # a bad log raises LogError (a ValueError naming the column): main prints it as "error: ..."
    summary = replay_log(args.csv, args.estimator, args.map, args.vehicle, _kv(args.param, "--param"), args.step,
                         args.out, args.fmu_dir)
    print(format_replay(summary))
    print("\nwrote " + ", ".join(summary["files"]))
    return 0


def _cmd_docs(args) -> int:
    from .fmi.docs import write_fmu_pages

    for path in write_fmu_pages(args.out):
        print(f"wrote {path}")
    return 0


def _cmd_build(args) -> int:
    from .fmi.build import build_fmus

    build_fmus(args.names or None, args.fmu_dir, force=args.force)
    return 0


def _cmd_export_ssp(args) -> int:
    from .cosim.ssp import export_ssp

    controller = None if args.controller in (None, "none") else args.controller
    out = export_ssp(args.out, args.scenario, args.estimator or (), controller, params=_kv(args.param, "--param"),
                     control_source=args.control_source, overrides=_kv(args.set, "--set"),
                     duration=args.duration, step=args.step, fmu_dir=args.fmu_dir)
    print(f"wrote {out}")
    return 0


def _cmd_control(args) -> int:
    from .studies import control_eval as ce

    if args.plot:
        path = ce.plot_example(args.out, args.fmu_dir)
        print(f"wrote {path}")
        return 0
    sources = ce.SOURCES
    if args.source:
        known = {s.label: s for s in ce.SOURCES}
        missing = [s for s in args.source if s not in known]
        if missing:
            raise SystemExit(f"--source {missing[0]!r}: rows are {', '.join(known)}")
        sources = tuple(known[s] for s in args.source)
    factors = tuple(float(f) for f in args.factors.split(",")) if args.factors else (
        ce.QUICK_FACTORS if args.quick else ce.FMVSS_FACTORS)
    cases = ce.control_cases(sources, args.condition or ce.CONDITIONS, args.seeds or (1 if args.quick else 2),
                             factors, scenarios=args.scenario or ce.SCENARIOS)
    params = tuple(_kv(args.param, "--param").items())
    if params:
        cases = [ce.with_controller_params(c, params) for c in cases]
    rows = ce.control_evaluation(cases, args.engine, args.fmu_dir, args.workers, args.scheduler)
    summary = ce.summarise(rows)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "rows.json").write_text(json.dumps(rows, indent=1))
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    text = ce.format_control_evaluation(summary)
    (out / "control.md").write_text(text + "\n")
    wall = sum(r["wall_seconds"] for r in rows)
    print(json.dumps(summary, indent=2) if args.json else text)
    print(f"{len(rows)} closed loops, {sum(r['sim_seconds'] for r in rows):.0f} simulated s, {wall:.0f} s of "
          f"run time; wrote {out}/control.md, summary.json, rows.json", file=sys.stderr)
    return 0


def main(argv=None) -> int:
    """Entry point of ``python -m sideslip`` and the ``sideslip`` console script."""
    from .fmi.build import DEFAULT_OUT

    p = argparse.ArgumentParser(prog="python -m sideslip", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmu-dir", default=str(DEFAULT_OUT), help="folder of the built FMUs (default %(default)s)")
    sub = p.add_subparsers(dest="cmd", required=True)
    sub.add_parser("list", help="scenarios, FMUs, vehicles, maneuvers")

    def run_args(sp, scenario_required):
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

    def case_args(sp, quick, seeds, condition, scenario):
        sp.add_argument("--quick", action="store_true", help=quick)
        sp.add_argument("--seeds", type=int, help=f"seeds per scenario and condition ({seeds})")
        sp.add_argument("--condition", action="append", help=f"{condition} (repeatable)")
        sp.add_argument("--scenario", action="append", help=f"{scenario} (repeatable)")

    run = sub.add_parser("run", help="run a scenario in closed loop")
    run_args(run, True)
    run.add_argument("--estimator", action="append", help="estimator FMU (repeatable)")
    demo = sub.add_parser("demo", help=f"run {DEMO_SCENARIO} with every estimator, print metrics, write a plot")
    run_args(demo, False)
    bench = sub.add_parser("bench", help="microseconds per step per FMU and closed-loop real-time factor")
    bench.add_argument("--json", action="store_true")
    bench.add_argument("--duration", type=float, default=5.0, help="simulated seconds per measurement")
    bench.add_argument("--repeats", type=int, default=3, help="runs per measurement, the best reported (default 3)")
    paper = sub.add_parser("paper", help="reproduce a paper's result tables with the FMUs in closed loop")
    paper.add_argument("name", choices=("park2018", "kim2016", "nguyen2012", "pi2011", "yoon2014"),
                       help="the paper whose tables to reproduce")
    paper.add_argument("--workers", type=int, default=2, help="parallel runs (default %(default)s)")
    paper.add_argument("--param", action="append", metavar="INSTANCE.NAME=VALUE",
                       help="estimator parameter override for the accuracy table (ablations)")
    paper.add_argument("--extra", action="append", metavar="SCENARIO",
                       help="kim2016: more fault-free scenarios for the false-alarm check; yoon2014: run only these")
    paper.add_argument("--json", action="store_true")
    ctl = sub.add_parser("control", help="closed-loop evaluation of the yaw-moment controllers under realistic "
                         "sensors and model mismatch: FMVSS 126, brake in a turn on snow, acceleration in a turn, "
                         "launch into a turn, straight drive, changing friction")
    case_args(ctl, "1 seed, FMVSS 126 at 3.5A, 5A and 6.5A", "default 2, quick 1",
              "sensors or sensors+mismatch (default both)", "only this scenario besides FMVSS 126")
    ctl.add_argument("--source", action="append", help="only this row, e.g. 'LQR / truth' (repeatable)")
    ctl.add_argument("--factors", help="FMVSS 126 amplitudes in multiples of A, comma-separated "
                     "(default 1.5 to 6.5 in 0.5 steps)")
    ctl.add_argument("--param", action="append", metavar="NAME=VALUE",
                     help="controller parameter, for every row whose controller has it")
    ctl.add_argument("--engine", choices=("library", "fmpy"), default="library",
                     help="run the models in-process (default) or the FMUs through fmpy")
    ctl.add_argument("--plot", action="store_true", help="only write the command-split figure of the docs")
    ctl.add_argument("--out", default="out/control", help="output folder (default %(default)s)")
    ctl.add_argument("--workers", type=int, default=2)
    ctl.add_argument("--scheduler", help="address of a Dask scheduler instead of local processes")
    ctl.add_argument("--json", action="store_true")
    bench_e = sub.add_parser("benchmark", help="every estimator on every case of the benchmark (scenario x condition "
                             "x seed): leaderboard, JSON, heat map, error plots")
    case_args(bench_e, "2 seeds, conditions nominal and sensors+mismatch", "default 5, quick 2",
              "only this condition", "only this scenario")
    which = bench_e.add_mutually_exclusive_group()
    which.add_argument("--training", action="store_true", help="the training set instead of the test set")
    which.add_argument("--development", action="store_true", help="the development set (failure cases the training "
                       "set does not show) instead of the test set")
    bench_e.add_argument("--estimator", action="append", help="only this row, by label or estimator name, e.g. "
                         "Yoon2014DualKF/hardened or Yoon2014DualKF (repeatable; predict-zero always runs)")
    bench_e.add_argument("--param", action="append", metavar="NAME=VALUE", help="estimator parameter on every "
                         "selected row whose estimator has it, e.g. sigma_accel=0.2 (repeatable)")
    bench_e.add_argument("--sensor", action="append", metavar="NAME=VALUE", help="sensor value replacing what the "
                         "condition draws, in every case, e.g. ay_sigma=0.2 (repeatable; the sensors FMU's names)")
    bench_e.add_argument("--log", action="append", help="a recorded drive (CSV log with a reference sideslip) as a case; "
                         "alone, only the logs run (repeatable)")
    bench_e.add_argument("--map", help="column map of the logs (TOML, see the user guide)")
    bench_e.add_argument("--vehicle", help="the estimators' vehicle on the logs: a bundled name or a TOML file")
    bench_e.add_argument("--out", default="out/benchmark", help="output folder (default %(default)s)")
    bench_e.add_argument("--workers", type=int, default=2, help="parallel processes (default %(default)s)")
    bench_e.add_argument("--scheduler", help="address of a Dask scheduler instead of local processes")
    rep = sub.add_parser("replay", help="estimator FMUs on a recorded drive (CSV log): estimates, and metrics and a "
                         "plot against the log's reference sideslip")
    rep.add_argument("--csv", required=True, help="the log: a header row, one row per sample")
    rep.add_argument("--map", help="TOML map of columns to signals with units, scale and offset (see the user guide)")
    rep.add_argument("--estimator", action="append", required=True, help="estimator FMU, NAME or instance=NAME "
                     "(repeatable)")
    rep.add_argument("--vehicle", help="every estimator's vehicle: a bundled name or a TOML file of the logged car")
    rep.add_argument("--param", action="append", metavar="INSTANCE.NAME=VALUE", help="FMU parameter override")
    rep.add_argument("--step", type=float, default=1e-3, help="communication step [s] (default 1e-3)")
    rep.add_argument("--out", default="out/replay", help="output folder (default %(default)s)")
    docs = sub.add_parser("docs", help="write the per-FMU reference pages of the documentation (docs/fmus)")
    docs.add_argument("--out", default="docs/fmus", help="folder of the pages (default %(default)s)")
    ssp = sub.add_parser("export-ssp", help="write a scenario's closed loop as an SSP 1.0 package (FMUs inside)")
    ssp.add_argument("out", metavar="OUT.ssp", help="the package to write")
    ssp.add_argument("--scenario", required=True, help="scenario name (see list)")
    ssp.add_argument("--estimator", action="append", help="estimator FMU (repeatable)")
    ssp.add_argument("--controller", default="none", help="controller FMU or 'none'")
    ssp.add_argument("--control-source", help="estimator instance or 'truth' feeding the controller")
    ssp.add_argument("--duration", type=float, help="DefaultExperiment stop time [s] (default: the scenario's)")
    ssp.add_argument("--step", type=float, default=1e-3, help="fixed communication step [s] (default 1e-3)")
    ssp.add_argument("--set", action="append", metavar="KEY=VALUE", help="scenario override")
    ssp.add_argument("--param", action="append", metavar="INSTANCE.NAME=VALUE", help="FMU parameter override")
    build = sub.add_parser("build", help="build the FMUs")
    build.add_argument("names", nargs="*")
    build.add_argument("--force", action="store_true")
    args = p.parse_args(argv)
    try:
        return {"list": _cmd_list, "run": _cmd_run, "demo": _cmd_demo, "bench": _cmd_bench, "paper": _cmd_paper,
                "control": _cmd_control, "build": _cmd_build, "export-ssp": _cmd_export_ssp, "docs": _cmd_docs,
                "benchmark": _cmd_benchmark, "replay": _cmd_replay}[args.cmd](args)
    except (KeyError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
