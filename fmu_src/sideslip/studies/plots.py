"""Figures like the papers': true vs estimated sideslip and the estimation error.

Drawn with matplotlib's object API onto an Agg canvas, so no pyplot state or global
backend is touched (a user's interactive session keeps its own backend).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .metrics import EVAL_MIN_SPEED, wrap

__all__ = ["plot_sideslip"]

_DEG = 180.0 / math.pi


def plot_sideslip(results, estimators, path: str | Path, title: str = "", plant: str = "plant",
                  min_speed: float = EVAL_MIN_SPEED) -> Path:
    """Write a two-panel figure: sideslip (true and estimates) and estimation errors, in degrees.

    Samples below ``min_speed`` are blanked (sideslip is undefined at standstill).
    Without estimators the lower panel shows the lateral acceleration and yaw rate.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = results["time"]
    speed = np.hypot(results[f"{plant}.vx"], results[f"{plant}.vy"])
    blank = speed <= min_speed
    truth = np.where(blank, np.nan, results[f"{plant}.beta"] * _DEG)
    fig = Figure(figsize=(10, 6.5))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(t, truth, "k", lw=2.0, label="true")
    for name in estimators:
        est = np.where(blank, np.nan, results[f"{name}.beta_hat"] * _DEG)
        ax1.plot(t, est, lw=1.2, label=name)
        err = np.where(blank, np.nan, wrap(results[f"{name}.beta_hat"] - results[f"{plant}.beta"]) * _DEG)
        ax2.plot(t, err, lw=1.0, label=name)
    ax1.set_ylabel("sideslip angle [deg]")
    ax1.grid(True, alpha=0.3)
    ax1.legend(loc="best", fontsize=8)
    ax1.set_title(title)
    if estimators:
        ax2.set_ylabel("estimation error [deg]")
        ax2.axhline(0.0, color="k", lw=0.5)
    else:
        ax2.plot(t, results[f"{plant}.ay"], label="a_y [m/s2]")
        ax2.plot(t, results[f"{plant}.yaw_rate"] * _DEG, label="yaw rate [deg/s]")
        ax2.set_ylabel("truth")
    ax2.legend(loc="best", fontsize=8)
    ax2.grid(True, alpha=0.3)
    ax2.set_xlabel("time [s]")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path
