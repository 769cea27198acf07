"""``benchmark``: every estimator on every case of the accuracy benchmark."""
from __future__ import annotations

import sys
from pathlib import Path

from .common import EXAMPLES_FORMAT, case_args, count, kv

__all__ = ["register"]


def _cmd_benchmark(args) -> int:
    import time

    from ..studies import accuracy as bm
    from ..studies.leaderboard import write_report

    seeds = args.seeds or (2 if args.quick else 5)
    conditions = args.condition or (("sensors+mismatch", bm.REAL) if args.quick else bm.CONDITIONS)
    sensors, params = kv(args.sensor, "--sensor"), kv(args.param, "--param")
    cases = [] if args.log and not args.scenario else bm.cases(args.scenario or None, conditions, seeds,
                                                                training=args.training, development=args.development,
                                                                sensors=sensors, plants=args.plant)
    cases += [bm.log_case(path, args.map, args.vehicle) for path in args.log or ()]
    print(f"benchmark: {len(cases)} cases ({len({c.scenario for c in cases})} scenarios x {len(conditions)} "
          f"conditions x {seeds} seeds on {', '.join(sorted({c.plant for c in cases}))}) -> {args.out}",
          file=sys.stderr)
    t0 = time.perf_counter()
    rows = bm.with_params(bm.select_rows(args.estimator), params)
    results = bm.run_benchmark(cases, rows, args.workers, args.scheduler, progress=sys.stderr.isatty())
    wall = time.perf_counter() - t0
    which = "training" if args.training else "development" if args.development else "test"
    meta = {"seeds": seeds, "conditions": list(conditions), "plants": sorted({c.plant for c in cases}), "training": args.training, "set": which, "wall_s": wall,
            "cases": len(cases), "quick": args.quick, "sensors": bm.sensor_overrides(sensors),
            "params": {k: v for row in rows for k, v in row.params if k in params}}
    write_report(results, args.out, title=f"Sideslip estimator benchmark ({which} set)", meta=meta)
    print((Path(args.out) / "leaderboard.md").read_text())
    print(f"{len(cases)} cases in {wall:.0f} s; wrote {args.out}/leaderboard.md, benchmark.json, heatmap.png, "
          "errors_*.png")
    return 0


def register(sub) -> None:
    bench_e = sub.add_parser("benchmark", help="every estimator on every case of the benchmark (scenario x condition "
                             "x seed): leaderboard, JSON, heat map, error plots", formatter_class=EXAMPLES_FORMAT,
                             epilog="examples:\n  sideslip benchmark --quick\n  sideslip benchmark --training "
                             "--estimator SideslipFusion --param sigma_accel=0.2\n  sideslip benchmark --log drive.csv "
                             "--map map.toml --vehicle my_car.toml")
    case_args(bench_e, "2 seeds, sensors+mismatch on both plants and the real drive", "default 5, quick 2",
              "only this condition (real: the real drive's slice)", "only this scenario")
    which = bench_e.add_mutually_exclusive_group()
    which.add_argument("--training", action="store_true", help="the training set instead of the test set")
    which.add_argument("--development", action="store_true", help="the development set (failure cases the training "
                       "set does not show) instead of the test set")
    bench_e.add_argument("--plant", action="append", choices=("own", "commonroad"), help="only this plant: the "
                         "project's, or the set's CommonRoad car (training 1, development 2, test 3; condition "
                         "sensors+mismatch only) (repeatable; default both)")
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
    bench_e.add_argument("--workers", type=count, default=2, help="parallel processes (default %(default)s)")
    bench_e.add_argument("--scheduler", help="address of a Dask scheduler instead of local processes")
    bench_e.set_defaults(func=_cmd_benchmark)
