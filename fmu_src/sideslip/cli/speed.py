"""``bench``: microseconds per FMU step and the closed-loop real-time factor."""
from __future__ import annotations

import json

__all__ = ["register"]


def _cmd_bench(args) -> int:
    from ..studies.speed import format_bench, run_bench

    b = run_bench(duration=args.duration, fmu_dir=args.fmu_dir, repeats=args.repeats)
    print(json.dumps(b, indent=2) if args.json else format_bench(b))
    return 0


def register(sub) -> None:
    bench = sub.add_parser("bench", help="microseconds per step per FMU and closed-loop real-time factor")
    bench.add_argument("--json", action="store_true")
    bench.add_argument("--duration", type=float, default=5.0, help="simulated seconds per measurement")
    bench.add_argument("--repeats", type=int, default=3, help="runs per measurement, the best reported (default 3)")
    bench.set_defaults(func=_cmd_bench)
