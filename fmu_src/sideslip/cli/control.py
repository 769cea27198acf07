"""``control``: the closed-loop evaluation of the yaw-moment controllers."""
from __future__ import annotations

import json
import sys
from pathlib import Path

from .common import EXAMPLES_FORMAT, case_args, count, kv, params_file_arg

__all__ = ["register", "control_case_set"]


def _cmd_control(args) -> int:
    from ..studies import control_eval as ce
    from ..studies.jobs import ResultLog

    if args.plot:
        path = ce.plot_example(args.out, args.fmu_dir)
        print(f"wrote {path}")
        return 0
    cases = control_case_set(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    journal = out / "rows.jsonl"
    if not args.resume:
        journal.unlink(missing_ok=True)
    rows = ce.control_evaluation(cases, args.engine, args.fmu_dir, args.workers, args.scheduler,
                                 log=ResultLog(journal))
    summary = ce.summarise(rows)
    (out / "rows.json").write_text(json.dumps(rows, indent=1))
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    text = ce.format_control_evaluation(summary)
    (out / "control.md").write_text(text + "\n")
    wall = sum(r["wall_seconds"] for r in rows)
    print(json.dumps(summary, indent=2) if args.json else text)
    print(f"{len(rows)} closed loops, {sum(r['sim_seconds'] for r in rows):.0f} simulated s, {wall:.0f} s of "
          f"run time; wrote {out}/control.md, summary.json, rows.json", file=sys.stderr)
    return 0


def register(sub) -> None:
    _register_control(sub)
    register_tune(sub)


def _register_control(sub) -> None:
    ctl = sub.add_parser("control", help="closed-loop evaluation of the yaw-moment controllers under realistic "
                         "sensors and model mismatch (the held-out test set of sideslip tune): FMVSS 126, brake in a "
                         "turn on snow, acceleration in a turn, "
                         "launch into a turn, straight drive, changing friction", formatter_class=EXAMPLES_FORMAT,
                         epilog="examples:\n  sideslip control --quick\n  sideslip control --source 'LQR / truth' "
                         "--source 'ESC / truth' --factors 5,6.5\n  sideslip control --param q_gamma=3e6 --workers 2\n"
                         "  sideslip control --resume   # go on where a stopped run stopped\n"
                         "  sideslip control --params examples/lqr_tuned.json   # a tuned file, drivable LQR rows")
    case_args(ctl, "1 seed, FMVSS 126 at 3.5A, 5A and 6.5A", "default 2, quick 1",
              "sensors or sensors+mismatch (default both)", "only this scenario besides FMVSS 126")
    ctl.add_argument("--source", action="append", help="only this row, e.g. 'LQR / truth' (repeatable)")
    ctl.add_argument("--factors", help="FMVSS 126 amplitudes in multiples of A, comma-separated "
                     "(default 1.5 to 6.5 in 0.5 steps)")
    ctl.add_argument("--plant", action="append", help="own (the project's plant) or commonroad1-3 (CommonRoad's "
                     "Ford Escort, BMW 320i, VW Vanagon, each known by its identified vehicle file: FMVSS 126 and "
                     "the brake in a turn on snow, five rows; quick: 5A and 6.5A); repeatable, default own and "
                     "commonroad3")
    ctl.add_argument("--wheel-slip-max", type=float, metavar="SLIP", help="the project's plant's wheel-slip control "
                     "(ABS, the motors' slip limit): torque cut from this slip to twice it; 0: none, the wheels lock "
                     "and spin freely (default: the evaluation's, WHEEL_SLIP_MAX)")
    ctl.add_argument("--param", action="append", metavar="NAME=VALUE",
                     help="controller parameter, for every row whose controller has it")
    params_file_arg(ctl)
    ctl.add_argument("--engine", choices=("library", "fmpy"), default="library",
                     help="run the models in-process (default) or the FMUs through fmpy")
    ctl.add_argument("--plot", action="store_true", help="only write the command-split figure of the docs")
    ctl.add_argument("--out", default="out/control", help="output folder (default %(default)s); every case's "
                     "figures go to rows.jsonl in it as the case finishes")
    ctl.add_argument("--resume", action="store_true", help="keep the cases rows.jsonl in --out already holds (a run "
                     "that was stopped goes on where it stopped) instead of starting over")
    ctl.add_argument("--workers", type=count, default=2, help="parallel processes (default %(default)s)")
    ctl.add_argument("--scheduler", help="address of a Dask scheduler instead of local processes")
    ctl.add_argument("--json", action="store_true", help="print the summary as JSON instead of the tables")
    ctl.set_defaults(func=_cmd_control)


def control_case_set(args) -> list:
    """The cases the options of ``control`` choose (rows, amplitudes, plants, seeds, parameters)."""
    from ..scenarios import FMVSS_FACTORS
    from ..studies import control_eval as ce
    from ..studies.drives import OWN, PLANTS

    sources = ce.SOURCES
    if args.source:
        known = {s.label: s for s in ce.SOURCES}
        missing = [s for s in args.source if s not in known]
        if missing:
            raise SystemExit(f"--source {missing[0]!r}: rows are {', '.join(known)}")
        sources = tuple(known[s] for s in args.source)
    factors = tuple(float(f) for f in args.factors.split(",")) if args.factors else (
        ce.QUICK_FACTORS if args.quick else FMVSS_FACTORS)
    plants = list(dict.fromkeys(args.plant or [OWN, ce.OFF_PLANT]))
    unknown = [p for p in plants if p not in PLANTS]
    if unknown:
        raise ValueError(f"--plant {unknown[0]!r}: plants are {', '.join(PLANTS)}")
    off_plants = tuple(p for p in plants if p != OWN)
    if args.wheel_slip_max is not None and not 0.0 <= args.wheel_slip_max <= 0.5:
        raise ValueError(f"--wheel-slip-max {args.wheel_slip_max:g}: a slip in [0, 0.5]")
    cases = ce.control_cases(sources, args.condition or ce.CONDITIONS, args.seeds or (1 if args.quick else 2),
                             factors, scenarios=args.scenario or ce.SCENARIOS, off_plant=bool(off_plants),
                             off_plant_factors=ce.QUICK_OFF_PLANT_FACTORS if args.quick and not args.factors else None,
                             off_plants=off_plants, wheel_slip_max=ce.WHEEL_SLIP_MAX if args.wheel_slip_max is None
                             else args.wheel_slip_max)
    if OWN not in plants:
        cases = [c for c in cases if c.plant != OWN]
    if args.params:
        from ..fmi.param_file import read_param_file

        fmu, values = read_param_file(args.params, "LqrDycController" if args.params.lower().endswith(".ssv")
                                      else None)
        # a file is a drivable controller's: the published profile's row stays the paper's form
        cases = [ce.with_controller_params(c, tuple(values.items()))
                 if c.source.controller == fmu and ("control_profile", 0) not in c.source.params else c
                 for c in cases]
    params = tuple(kv(args.param, "--param").items())
    if params:
        cases = [ce.with_controller_params(c, params) for c in cases]
    return cases


def _cmd_tune(args) -> int:
    from ..fmi.param_file import read_param_file
    from ..studies.control_eval.study import run_study
    from ..studies.control_eval.tuning import EFFORT_CAP, OBJECTIVES

    from ..estimators import ESTIMATORS
    from ..params import one_of
    for source in args.source or ():
        if source != "truth" and source not in ESTIMATORS:
            raise ValueError(one_of(source, ESTIMATORS, "estimator"))
    out = Path(args.out)
    start = [read_param_file(f, "LqrDycController")[1] for f in args.start]
    s = run_study(out, args.trials, args.workers, args.scheduler, args.source, args.sampler, args.seed, args.study,
                  args.dev_points, fmu_dir=args.fmu_dir, start=start)
    names = {"rms_yaw_rate_error_deg_s": "RMS yaw-rate error [deg/s]", "effort_kNms": "effort [kN m s]",
             "max_abs_beta_deg": "max |beta| [deg]"}
    chosen, shipped = s["chosen"], s["shipped"]
    print(f"study {s['study']} ({s['sampler']}, LQR / {s['source']}): {s['trials']} points, Pareto front "
          f"{len(s['pareto'])}; chosen trial {chosen['trial']} on the development set")
    print(f"  {'':28s} {'training':>9s} {'dev':>9s} {'shipped dev':>12s} {'ESC dev':>9s}")
    for k in OBJECTIVES:
        ref = shipped["development"][k] if shipped["development"] else float("nan")
        print(f"  {names[k]:28s} {chosen['training'][k]:9.3f} {chosen['development'][k]:9.3f} {ref:12.3f} "
              f"{s['esc']['development'][k]:9.3f}")
    if not chosen["within_effort_cap"]:
        print(f"  no point kept within the constraints and {EFFORT_CAP:g}x the ESC's effort on the development set; "
              f"chosen: the least beyond the constraints ({chosen['development_excess']:.3g})")
    print("  " + ", ".join(f"{k} {v:.4g}" for k, v in chosen["parameters"].items()))
    if s["sim_seconds"]:
        total = s['sim_seconds'] + s['development_sim_seconds']
        print(f"{total:.0f} simulated s in {s['wall_seconds']:.0f} s: {s['sim_per_wall']:.1f} simulated s "
              f"per wall s ({s['workers']} workers)", file=sys.stderr)
    print(f"wrote {out}/chosen.json, chosen.ssv, trials.csv, pareto.png, summary.json; held out: "
          f"sideslip control --params {out}/chosen.json", file=sys.stderr)
    return 0


def register_tune(sub) -> None:
    from ..studies.control_eval.study import SAMPLERS, STUDY_NAME

    tune = sub.add_parser("tune", help="tune the LQR (weights, speed and friction schedule, command shaping) with "
                          "Optuna on a training set, choose on a development set, write a parameter file",
                          formatter_class=EXAMPLES_FORMAT, epilog="examples:\n  sideslip tune --trials 80\n"
                          "  sideslip tune --trials 120   # the same study goes on to 120 points\n"
                          "  sideslip tune --source SideslipFusion --out out/tune_fusion\n"
                          "  sideslip tune --source truth --source SideslipFusion   # one file for both\n"
                          "  sideslip tune --scheduler local --workers 2   # a local Dask cluster\n"
                          "  sideslip tune --start out/tune_a/chosen.json --out out/tune_b   # warm start\n"
                          "  sideslip control --params out/tune/chosen.json   # the held-out evaluation")
    tune.add_argument("--trials", type=count, default=60, help="points the study should hold when done, those of "
                      "earlier runs and of other processes on the same --out included (default %(default)s)")
    tune.add_argument("--source", action="append", help="estimator feeding the LQR (hardened) or 'truth' "
                      "(default); repeatable: every point runs on each, within the constraints on each")
    tune.add_argument("--sampler", choices=SAMPLERS, default="tpe", help="Optuna sampler: multi-objective TPE "
                      "(default) or NSGA-II")
    tune.add_argument("--seed", type=int, default=0, help="the sampler's seed (default %(default)s)")
    tune.add_argument("--study", default=STUDY_NAME, help="study name in the storage (default %(default)s)")
    tune.add_argument("--dev-points", type=count, default=10, help="Pareto-front points run on the development set "
                      "(default %(default)s)")
    tune.add_argument("--start", action="append", default=[], metavar="FILE", help="parameter file of a point the "
                      "study asks first (e.g. another study's chosen.json; repeatable): it runs on the training set "
                      "and always on the development set")
    tune.add_argument("--out", default="out/tune", help="the study's folder: its Optuna journal (shared by every "
                      "process tuning into it; a stopped study goes on), runs.jsonl and the files "
                      "(default %(default)s)")
    tune.add_argument("--workers", type=count, default=2, help="parallel processes (default %(default)s)")
    tune.add_argument("--scheduler", help="address of a Dask scheduler, or 'local' for a Dask cluster of --workers "
                      "processes here")
    tune.set_defaults(func=_cmd_tune)
