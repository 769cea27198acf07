"""``paper``: a paper's result tables reproduced with the FMUs in closed loop."""
from __future__ import annotations

import json

from .common import EXAMPLES_FORMAT, count, kv

__all__ = ["register"]


def _cmd_paper(args) -> int:
    from ..studies.papers import PAPERS

    paper = PAPERS[args.name]
    params = kv(args.param, "--param")
    if params and not paper.ACCEPTS_PARAMS:
        accepting = ", ".join(n for n, m in PAPERS.items() if m.ACCEPTS_PARAMS)
        raise SystemExit(f"--param applies to {accepting}, not {args.name}")
    figures, text = paper.report(args.fmu_dir, args.workers, params, args.extra or ())
    print(json.dumps(figures, indent=2, default=str) if args.json else text)
    return 0


def register(sub) -> None:
    paper = sub.add_parser("paper", help="reproduce a paper's result tables with the FMUs in closed loop",
                           formatter_class=EXAMPLES_FORMAT, epilog="examples:\n  sideslip paper park2018\n  sideslip "
                           "paper nguyen2012 --param discretization=euler\n  sideslip paper kim2016 --json")
    paper.add_argument("name", choices=("park2018", "kim2016", "nguyen2012", "pi2011", "yoon2014"),
                       help="the paper whose tables to reproduce")
    paper.add_argument("--workers", type=count, default=2, help="parallel runs (default %(default)s)")
    paper.add_argument("--param", action="append", metavar="INSTANCE.NAME=VALUE",
                       help="estimator parameter override for the accuracy table (ablations)")
    paper.add_argument("--extra", action="append", metavar="SCENARIO",
                       help="kim2016: more fault-free scenarios for the false-alarm check; yoon2014: run only these")
    paper.add_argument("--json", action="store_true", help="print the figures as JSON instead of the tables")
    paper.set_defaults(func=_cmd_paper)
