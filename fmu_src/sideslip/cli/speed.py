"""``bench``: microseconds per FMU step and the closed-loop real-time factor."""
from __future__ import annotations

from .common import EXAMPLES_FORMAT, count, positive

import json

__all__ = ["register"]


def _cmd_bench(args) -> int:
    from ..studies.speed import format_bench, run_bench

    b = run_bench(duration=args.duration, fmu_dir=args.fmu_dir, repeats=args.repeats)
    if args.instructions:
        from ..studies.speed import instruction_counts

        b["instructions_per_step"] = instruction_counts(args.fmu_dir)
    print(json.dumps(b, indent=2) if args.json else format_bench(b))
    return 0


def register(sub) -> None:
    bench = sub.add_parser("bench", help="microseconds per step per FMU and closed-loop real-time factor",
                           formatter_class=EXAMPLES_FORMAT, epilog="examples:\n  sideslip bench\n  sideslip bench "
                           "--duration 2 --repeats 1 --json > bench.json")
    bench.add_argument("--json", action="store_true", help="print the figures as JSON instead of the table")
    bench.add_argument("--duration", type=positive, default=5.0, help="simulated seconds per measurement "
                       "(default %(default)s)")
    bench.add_argument("--instructions", action="store_true", help="also count the instructions per step of the "
                       "plant and the loops with valgrind's callgrind (minutes; needs valgrind)")
    bench.add_argument("--repeats", type=count, default=3, help="runs per measurement, the best reported (default 3)")
    bench.set_defaults(func=_cmd_bench)
