"""``replay``: estimator FMUs on a recorded drive."""
from __future__ import annotations

from ..recording import WHEEL_SPEED_STAND_INS
from .common import EXAMPLES_FORMAT, kv, positive, window

__all__ = ["register"]


def _cmd_replay(args) -> int:
    from ..studies.logs import format_replay, replay_log

    # a bad log raises LogError (a ValueError naming the column): main prints it as "error: ..."
    summary = replay_log(args.log, args.estimator, args.map, args.vehicle, kv(args.param, "--param"), args.step,
                         args.out, args.fmu_dir, args.wheel_speeds_from, args.window)
    print(format_replay(summary))
    print("\nwrote " + ", ".join(summary["files"]))
    return 0


def register(sub) -> None:
    rep = sub.add_parser("replay", help="estimator FMUs on a recorded drive (CSV, Parquet or MDF4 log): estimates, and "
                         "metrics and a plot against the log's reference sideslip",
                         description="Run estimator FMUs on a recorded drive. The log's columns are named by the "
                         "signal contract or mapped by a TOML map file (units, scale, offset); see the user guide, "
                         "'Your own drive'. metrics.json records what reproduces the run.",
                         epilog="examples:\n  sideslip replay --log drive.csv --estimator SideslipFusion\n"
                         "  sideslip replay --log drive.mf4 --map drive_map.toml --vehicle my_car.toml \\\n"
                         "      --estimator SideslipFusion --param SideslipFusion.use_gnss=false --window 120:300\n"
                         "  sideslip replay --log no_wheels.csv --wheel-speeds-from vx --estimator Kim2016SteeringEKF",
                         formatter_class=EXAMPLES_FORMAT)
    rep.add_argument("--log", "--csv", dest="log", required=True, help="the log: CSV (a header row, one row per "
                     "sample), Parquet (.parquet, needs pyarrow) or MDF (.mf4/.mdf, needs asammdf)")
    rep.add_argument("--map", help="TOML map of columns to signals with units, scale and offset (see the user guide)")
    rep.add_argument("--estimator", action="append", required=True, help="estimator FMU, NAME or instance=NAME "
                     "(repeatable)")
    rep.add_argument("--vehicle", help="every estimator's vehicle: a bundled name or a TOML file of the logged car")
    rep.add_argument("--param", action="append", metavar="INSTANCE.NAME=VALUE", help="FMU parameter override")
    rep.add_argument("--step", type=positive, default=1e-3, help="communication step [s] (default 1e-3)")
    rep.add_argument("--wheel-speeds-from", choices=WHEEL_SPEED_STAND_INS, metavar="SIGNAL", help="stand in for "
                     "missing wheel speeds: vx (a logged speed over ground) or one wheel's speed, e.g. omega_rl_m "
                     "(free rolling; every estimator reads the wheels only as an axle's mean speed)")
    rep.add_argument("--window", type=window, metavar="T0:T1", help="only this time span [s] in the metrics and the "
                     "plot (the estimators run over the whole log)")
    rep.add_argument("--out", default="out/replay", help="output folder (default %(default)s)")
    rep.set_defaults(func=_cmd_replay)
