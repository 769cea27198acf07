"""Figures like the papers': true vs estimated sideslip and the estimation error.

Drawn with matplotlib's object API onto an Agg canvas, so no pyplot state or global
backend is touched (a user's interactive session keeps its own backend).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..units import DEG, wrap_angle
from .metrics import MOVING_SPEED

__all__ = ["plot_sideslip", "plot_command_split"]



def plot_sideslip(results, estimators, path: str | Path, title: str = "", plant: str = "plant",
                  min_speed: float = MOVING_SPEED) -> Path:
    """Write a two-panel figure: sideslip (true and estimates) and estimation errors, in degrees.

    Samples below ``min_speed`` are blanked (sideslip is undefined at standstill).
    Without estimators the lower panel shows the lateral acceleration and yaw rate.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = results["time"]
    speed = np.hypot(results[f"{plant}.vx"], results[f"{plant}.vy"])
    blank = speed <= min_speed
    truth = np.where(blank, np.nan, results[f"{plant}.beta"] * DEG)
    fig = Figure(figsize=(10, 6.5))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(t, truth, "k", lw=2.0, label="true")
    for name in estimators:
        est = np.where(blank, np.nan, results[f"{name}.beta_hat"] * DEG)
        ax1.plot(t, est, lw=1.2, label=name)
        err = np.where(blank, np.nan, wrap_angle(results[f"{name}.beta_hat"] - results[f"{plant}.beta"]) * DEG)
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
        ax2.plot(t, results[f"{plant}.yaw_rate"] * DEG, label="yaw rate [deg/s]")
        ax2.set_ylabel("truth")
    ax2.legend(loc="best", fontsize=8)
    ax2.grid(True, alpha=0.3)
    ax2.set_xlabel("time [s]")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def plot_command_split(runs: dict, path: str | Path, title: str = "") -> Path:
    """Write a figure of yaw-moment commands split into their parts, one panel per run, over the yaw rate.

    Parameters
    ----------
    runs : dict
        ``{label: arrays}`` with ``time``, ``plant.yaw_rate``, ``controller.yaw_rate_ref``,
        ``controller.Mz_cmd`` and the controller's two parts (``Mz_ff``/``Mz_fb`` or ``Mz_yaw``/``Mz_beta``).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 2.4 * (len(runs) + 1)))
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(runs) + 1, 1, sharex=True)
    for (label, a), ax in zip(runs.items(), axes[1:]):
        t = a["time"]
        axes[0].plot(t, a["plant.yaw_rate"] * DEG, lw=1.2, label=f"yaw rate, {label}")
        ax.plot(t, a["controller.Mz_cmd"], "k", lw=1.6, label="Mz_cmd")
        for part in ("Mz_ff", "Mz_fb", "Mz_yaw", "Mz_beta"):
            if f"controller.{part}" in a:
                ax.plot(t, a[f"controller.{part}"], lw=1.0, label=part)
        ax.set_ylabel("yaw moment [N m]")
        ax.set_title(label, fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    first = next(iter(runs.values()))
    axes[0].plot(first["time"], first["controller.yaw_rate_ref"] * DEG, "k--", lw=1.0, label="reference")
    axes[0].set_ylabel("yaw rate [deg/s]")
    axes[0].grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title(title)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path
