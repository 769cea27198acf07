"""Command line of sideslip-fmu: ``python -m sideslip`` or the ``sideslip`` console script.

Every command builds the FMUs it needs on first use (into build/fmus) and prints what it
wrote.  An error is one line naming what is wrong (a parameter and its allowed range, a log's
column, an unknown name with the closest known ones), never a traceback; set SIDESLIP_DEBUG=1
to see the traceback of one.
"""
from __future__ import annotations

import argparse
import os
import sys

from . import accuracy, control, papers, replay, runs, speed, tools, vehicle

__all__ = ["main", "version"]

COMMANDS = (tools, runs, speed, papers, control, accuracy, replay, vehicle)
"""The modules that register the subcommands (each a ``register(subparsers)``), in the order of ``--help``."""

EXAMPLES = """examples:
  sideslip demo                                   closed loop, every estimator, metrics and a plot
  sideslip list scenarios --grep fmvss            scenarios whose name holds 'fmvss'
  sideslip run --scenario pi2011_medium --estimator SideslipFusion --controller LqrDycController
  sideslip replay --log drive.csv --map drive_map.toml --vehicle my_car.toml --estimator SideslipFusion
  sideslip vehicle check my_car.toml              what a vehicle file resolves to
  sideslip paper park2018                         a paper's tables with the FMUs
  sideslip benchmark --quick                      every estimator on the benchmark's cases
  sideslip control --quick                        the yaw-moment controllers' evaluation
  sideslip bench                                  microseconds per FMU step

'python -m sideslip' is the same command as 'sideslip'; '<command> --help' explains one.
"""


def version() -> str:
    """The installed package's version."""
    from importlib.metadata import PackageNotFoundError, version as _version

    try:
        return _version("sideslip-fmu")
    except PackageNotFoundError:
        return "unknown (not installed)"


def _message(exc: BaseException) -> str:
    """What an error says to a user: its text (a KeyError's without the quotes Python adds)."""
    if isinstance(exc, KeyError) and len(exc.args) == 1 and isinstance(exc.args[0], str):
        return exc.args[0]
    text = str(exc).strip()
    return text if text else type(exc).__name__


def main(argv=None) -> int:
    """Entry point of ``python -m sideslip`` and the ``sideslip`` console script.

    Returns
    -------
    int
        0 on success, 2 for an error the user can act on (its message printed), 130 when interrupted.
    """
    from ..fmi.build import DEFAULT_OUT

    prog = "python -m sideslip" if sys.argv[0].endswith("__main__.py") else "sideslip"
    p = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0].replace("``", "'"),
                                epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"sideslip-fmu {version()}")
    p.add_argument("--fmu-dir", default=str(DEFAULT_OUT), help="folder of the built FMUs (default %(default)s)")
    sub = p.add_subparsers(dest="cmd", required=True, metavar="COMMAND")
    for module in COMMANDS:
        module.register(sub)
    args = p.parse_args(argv)
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:                  # the output piped into a reader that stopped (| head)
        sys.stderr.close()
        return 0
    except Exception as exc:  # noqa: BLE001 - a user sees the message, a developer asks for the traceback
        if os.environ.get("SIDESLIP_DEBUG"):
            raise
        print(f"error: {_message(exc)}", file=sys.stderr)
        return 2
