"""``replay``: estimator FMUs on a recorded drive."""
from __future__ import annotations

from .common import kv

__all__ = ["register"]


def _cmd_replay(args) -> int:
    from ..studies.logs import format_replay, replay_log

    # a bad log raises LogError (a ValueError naming the column): main prints it as "error: ..."
    summary = replay_log(args.csv, args.estimator, args.map, args.vehicle, kv(args.param, "--param"), args.step,
                         args.out, args.fmu_dir)
    print(format_replay(summary))
    print("\nwrote " + ", ".join(summary["files"]))
    return 0


def register(sub) -> None:
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
    rep.set_defaults(func=_cmd_replay)
