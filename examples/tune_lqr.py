"""LQR weight sweep: hundreds of closed loops of FMUs, in parallel, resumable, with a Pareto plot.

Every point (q_beta, q_gamma, q_N) runs ``LqrDycController`` (drivable profile, on the true sideslip
by default) in closed loop with the plant, sensor and driver FMUs over the maneuver set
:data:`sideslip.studies.control_eval.TUNING_MANEUVERS` (three 5 s FMVSS 126 sine-with-dwell runs)
under the control evaluation's realistic condition ``sensors+mismatch`` (sensor offsets and noise,
the plant on Magic Formula tires, the controller's vehicle perturbed from the plant's; seed 0).
Points run on a local process pool, or on a Dask distributed cluster with ``--scheduler``;
each result is appended to the CSV as it finishes, so an interrupted study restarted with
the same CSV only runs the missing points.  The Pareto front of tracking error against
control effort is plotted with the chosen point marked: the front point closest to the
utopia point (both axes normalised by their range).

    python examples/tune_lqr.py                         # 125 points, 2 workers
    python examples/tune_lqr.py --scheduler tcp://host:8786 --csv out/sweep.csv
"""
import argparse
import itertools
import time
from pathlib import Path

import numpy as np

from sideslip.studies.control_eval import TUNING_MANEUVERS, evaluate_weights
from sideslip.studies.jobs import CsvLog, parallel_map
from sideslip.fmi.build import DEFAULT_OUT, ensure_fmus

OUT = Path("out") / "examples" / "tune_lqr"
GRID = {"q_beta": np.logspace(9, 12, 5), "q_gamma": np.logspace(7, 10, 5), "q_N": np.logspace(-0.5, 1.5, 5)}
FIELDS = ["q_beta", "q_gamma", "q_N", "tracking", "rms_beta_error_deg", "rms_yaw_rate_error_deg_s", "effort_Nms",
          "max_abs_beta_deg", "saturated_pct", "rms_dMz_dt", "fmvss_passes", "sim_seconds", "wall_seconds"]


def grid_points(grid=GRID) -> list[dict]:
    """Every combination of the grid's weights."""
    return [dict(zip(grid, values)) for values in itertools.product(*grid.values())]


def pareto(x, y) -> np.ndarray:
    """Indices of the points not dominated in (x, y), both minimised, sorted by x."""
    order = np.lexsort((y, x))
    front, best = [], np.inf
    for i in order:
        if y[i] < best:
            front.append(i)
            best = y[i]
    return np.array(front, dtype=int)


def run(show_plot=True, grid=GRID, csv=OUT / "sweep.csv", workers=2, scheduler=None, maneuvers=TUNING_MANEUVERS,
        duration=None, fmu_dir=DEFAULT_OUT, progress=True):
    """Run (or resume) the sweep; returns the result rows, the Pareto indices and the chosen row."""
    log = CsvLog(csv, FIELDS, n_key=3)
    done = log.done()
    todo = [p for p in grid_points(grid) if not log.is_done(p, done)]
    ensure_fmus(["VehiclePlant", "VehicleSensors", "ManeuverDriver", "LqrDycController"], fmu_dir)
    items = [{**p, "maneuvers": maneuvers, "duration": duration, "fmu_dir": str(fmu_dir)} for p in todo]
    t0, sim = time.perf_counter(), 0.0
    for item, res in parallel_map(evaluate_weights, items, workers, scheduler, progress, "LQR sweep"):
        # one tracking figure: sideslip and yaw-rate errors, each relative to 1 deg / 5 deg/s
        res["tracking"] = res["rms_beta_error_deg"] + res["rms_yaw_rate_error_deg_s"] / 5.0
        log.append({**{k: item[k] for k in ("q_beta", "q_gamma", "q_N")}, **res})
        sim += res["sim_seconds"]
    wall = time.perf_counter() - t0
    if todo:
        print(f"{len(todo)} points, {sim:.0f} simulated s in {wall:.1f} s wall: {sim / wall:.1f} simulated s per "
              f"wall s ({workers if scheduler is None else 'dask'} workers)")
    rows = [{k: float(v) for k, v in r.items()} for r in log.rows()]
    x = np.array([r["effort_Nms"] for r in rows])
    y = np.array([r["tracking"] for r in rows])
    front = pareto(x, y)
    span = lambda v: (v - v.min()) / (np.ptp(v) or 1.0)                              # noqa: E731
    chosen = rows[front[np.argmin(np.hypot(span(x)[front], span(y)[front]))]]
    print(f"chosen: q_beta {chosen['q_beta']:.3g}, q_gamma {chosen['q_gamma']:.3g}, q_N {chosen['q_N']:.3g}: "
          f"tracking {chosen['tracking']:.2f}, effort {chosen['effort_Nms'] / 1e3:.2f} kN m s, "
          f"{int(chosen['fmvss_passes'])}/{len(maneuvers)} FMVSS runs stable")
    _plot(rows, front, chosen, Path(csv).with_suffix(".png"), show_plot)
    return rows, front, chosen


def _plot(rows, front, chosen, path, show):
    import matplotlib
    if not show:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.array([r["effort_Nms"] for r in rows]) / 1e3
    y = np.array([r["tracking"] for r in rows])
    ok = np.array([r["fmvss_passes"] for r in rows])
    fig, ax = plt.subplots(figsize=(7, 5))
    sc = ax.scatter(x, y, c=ok, cmap="viridis", s=18, label="sweep points")
    ax.plot(x[front], y[front], "k-", lw=1, label="Pareto front")
    ax.plot(chosen["effort_Nms"] / 1e3, chosen["tracking"], "r*", ms=16, label="chosen")
    fig.colorbar(sc, ax=ax, label="FMVSS 126 runs yaw-stable")
    ax.set_xlabel("control effort  int |Mz| dt  [kN m s] (mean per maneuver)")
    ax.set_ylabel("tracking error  RMS beta [deg] + RMS r [deg/s] / 5")
    ax.set_title("LQR weight sweep (q_beta, q_gamma, q_N)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"plot: {path}")
    if show:
        plt.show()
    plt.close(fig)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--csv", default=str(OUT / "sweep.csv"), help="results CSV (resumed if it exists)")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--scheduler", help="Dask scheduler address (default: local process pool)")
    p.add_argument("--no-show", action="store_true")
    a = p.parse_args()
    run(show_plot=not a.no_show, csv=a.csv, workers=a.workers, scheduler=a.scheduler)
