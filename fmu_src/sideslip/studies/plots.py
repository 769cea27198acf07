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



def _robust_limits(truth: np.ndarray, estimates: list, margin_deg: float = 1.0) -> tuple[float, float]:
    """A y-range that shows the truth and the estimates that follow it: the truth's span and the estimates' 2-98 %
    percentiles, the estimates allowed at most the truth's span again beyond it (a drifting estimate leaves the
    frame instead of squashing the others)."""
    finite = truth[np.isfinite(truth)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (-1.0, 1.0)
    span = max(hi - lo, 2.0 * margin_deg)
    for est in estimates:
        e = est[np.isfinite(est)]
        if e.size:
            p_lo, p_hi = np.percentile(e, [2.0, 98.0])
            lo, hi = min(lo, max(float(p_lo), lo - span)), max(hi, min(float(p_hi), hi + span))
    pad = 0.08 * (hi - lo) + 0.2 * margin_deg
    return lo - pad, hi + pad


def plot_sideslip(results, estimators, path: str | Path, title: str = "", plant: str = "plant",
                  min_speed: float = MOVING_SPEED, controller: str | None = None) -> Path:
    """Write a figure of the sideslip (true and estimates) and the estimation errors in degrees, and, with a
    ``controller``, its yaw rate against the reference and its yaw-moment command.

    The truth is drawn on top in black, one legend serves every panel, the y-ranges follow the truth and the
    estimates that track it (an estimate that drifts off leaves the frame, marked "off scale" in the legend), and
    the figure widens with the time span.  Samples below ``min_speed`` are blanked (sideslip is undefined at
    standstill).  Without estimators the error panel shows the lateral acceleration and yaw rate.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = np.asarray(results["time"])
    speed = np.hypot(results[f"{plant}.vx"], results[f"{plant}.vy"])
    blank = speed <= min_speed
    truth = np.where(blank, np.nan, results[f"{plant}.beta"] * DEG)
    panels = 2 + (controller is not None)
    width = float(np.clip((t[-1] - t[0]) / 12.0, 10.0, 24.0))
    fig = Figure(figsize=(width, 3.2 * panels + 0.6))
    FigureCanvasAgg(fig)
    axes = fig.subplots(panels, 1, sharex=True)
    ax1, ax2 = axes[0], axes[1]
    estimates = {name: np.where(blank, np.nan, results[f"{name}.beta_hat"] * DEG) for name in estimators}
    errors = {name: np.where(blank, np.nan, wrap_angle(results[f"{name}.beta_hat"] - results[f"{plant}.beta"]) * DEG)
              for name in estimators}
    lo, hi = _robust_limits(truth, list(estimates.values()))
    e_lo, e_hi = _robust_limits(np.zeros(1), list(errors.values()), margin_deg=0.5)
    for name in estimators:
        est, err = estimates[name], errors[name]
        off = np.nanmax(est, initial=lo) > hi or np.nanmin(est, initial=hi) < lo
        line, = ax1.plot(t, est, lw=1.0, label=name + (" (off scale)" if off else ""), zorder=2)
        ax2.plot(t, err, lw=0.9, color=line.get_color(), zorder=2)
    ax1.plot(t, truth, "k", lw=2.2, label="truth", zorder=5)
    ax1.set_ylim(lo, hi)
    ax1.set_ylabel("sideslip angle [deg]")
    ax1.set_title(title)
    if estimators:
        ax2.set_ylim(e_lo, e_hi)
        ax2.set_ylabel("estimation error [deg]")
        ax2.axhline(0.0, color="k", lw=0.6, zorder=4)
    else:
        ax2.plot(t, results[f"{plant}.ay"], label="a_y [m/s2]")
        ax2.plot(t, results[f"{plant}.yaw_rate"] * DEG, label="yaw rate [deg/s]")
        ax2.set_ylabel("truth")
    if controller is not None:
        ax3 = axes[2]
        ax3.plot(t, results[f"{plant}.yaw_rate"] * DEG, color="k", lw=1.6, label="yaw rate [deg/s]", zorder=5)
        ax3.plot(t, results[f"{controller}.yaw_rate_ref"] * DEG, "k--", lw=1.0, label="yaw-rate reference [deg/s]")
        ax3.set_ylabel("yaw rate [deg/s]")
        mz = ax3.twinx()
        mz.plot(t, results[f"{controller}.Mz_cmd"], color="tab:red", lw=1.0, label="Mz_cmd [N m] (right axis)")
        mz.set_ylabel("yaw moment command [N m]", color="tab:red")
        (h3, l3), (hm, lm) = ax3.get_legend_handles_labels(), mz.get_legend_handles_labels()
        ax3.legend(h3 + hm, l3 + lm, loc="upper right", fontsize=8, ncol=3)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    axes[-1].set_xlim(t[0], t[-1])
    handles, labels = ax1.get_legend_handles_labels()
    if not estimators:
        h2, l2 = ax2.get_legend_handles_labels()
        handles, labels = handles + h2, labels + l2
    order = sorted(range(len(labels)), key=lambda i: labels[i] != "truth")      # the truth first
    fig.legend([handles[i] for i in order], [labels[i] for i in order], loc="upper center", fontsize=8,
               ncol=min(len(labels), 6), bbox_to_anchor=(0.5, 1.0), frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 1.0 - 0.35 / fig.get_figheight() * (1 + len(labels) // 6)))
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
