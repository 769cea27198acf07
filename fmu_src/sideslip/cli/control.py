"""``control``: the closed-loop evaluation of the yaw-moment controllers."""
from __future__ import annotations

import json
import sys
from pathlib import Path

from .common import EXAMPLES_FORMAT, case_args, count, kv

__all__ = ["register"]


def _cmd_control(args) -> int:
    from ..studies import control_eval as ce
    from ..studies.jobs import ResultLog

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
    params = tuple(kv(args.param, "--param").items())
    if params:
        cases = [ce.with_controller_params(c, params) for c in cases]
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
    ctl = sub.add_parser("control", help="closed-loop evaluation of the yaw-moment controllers under realistic "
                         "sensors and model mismatch: FMVSS 126, brake in a turn on snow, acceleration in a turn, "
                         "launch into a turn, straight drive, changing friction", formatter_class=EXAMPLES_FORMAT,
                         epilog="examples:\n  sideslip control --quick\n  sideslip control --source 'LQR / truth' "
                         "--source 'ESC / truth' --factors 5,6.5\n  sideslip control --param q_gamma=3e6 --workers 2\n"
                         "  sideslip control --resume   # go on where a stopped run stopped")
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
    ctl.add_argument("--out", default="out/control", help="output folder (default %(default)s); every case's "
                     "figures go to rows.jsonl in it as the case finishes")
    ctl.add_argument("--resume", action="store_true", help="keep the cases rows.jsonl in --out already holds (a run "
                     "that was stopped goes on where it stopped) instead of starting over")
    ctl.add_argument("--workers", type=count, default=2, help="parallel processes (default %(default)s)")
    ctl.add_argument("--scheduler", help="address of a Dask scheduler instead of local processes")
    ctl.add_argument("--json", action="store_true", help="print the summary as JSON instead of the tables")
    ctl.set_defaults(func=_cmd_control)
