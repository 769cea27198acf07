"""Command line: ``python -m sideslip {list,run,demo,bench,benchmark,replay,identify,calibrate,paper,control,export-ssp,build,docs}``.

``run`` writes ``DIR/results.csv``, ``DIR/metrics.json`` and ``DIR/sideslip.png`` and prints
a metrics table; ``demo`` is ``run`` on a default scenario with every estimator of the FMU
catalogue; ``bench`` prints microseconds per communication step per FMU and the closed-loop
real-time factor; ``paper`` reproduces a paper's result tables with the FMUs (dispatching to
:data:`sideslip.studies.papers.PAPERS`); ``control`` evaluates the yaw-moment controller;
``benchmark`` scores every estimator on the benchmark's cases (:mod:`sideslip.studies.accuracy`);
``replay`` runs estimator FMUs on a recorded drive (:mod:`sideslip.studies.logs`); ``identify`` writes a
vehicle file from a calibration drive and ``calibrate`` drives one on a simulated plant
(:mod:`sideslip.studies.identify`);
``export-ssp`` writes a scenario's closed loop as an SSP 1.0 package; ``run --master libcosim`` or
``--master omsimulator`` runs the loop in another master; ``docs`` writes the per-FMU reference pages.  FMUs are built on first
use (``build/fmus``).
"""
from __future__ import annotations

import argparse
import sys

from . import accuracy, control, papers, replay, runs, speed, tools, vehicle

__all__ = ["main"]

COMMANDS = (tools, runs, speed, papers, control, accuracy, replay, vehicle)
"""The modules that register the subcommands (each a ``register(subparsers)``), in the order of ``--help``."""


def main(argv=None) -> int:
    """Entry point of ``python -m sideslip`` and the ``sideslip`` console script."""
    from ..fmi.build import DEFAULT_OUT

    p = argparse.ArgumentParser(prog="python -m sideslip", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmu-dir", default=str(DEFAULT_OUT), help="folder of the built FMUs (default %(default)s)")
    sub = p.add_subparsers(dest="cmd", required=True)
    for module in COMMANDS:
        module.register(sub)
    args = p.parse_args(argv)
    try:
        return args.func(args)
    except (KeyError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
