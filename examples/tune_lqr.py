"""LQR tuning study from a script: ``sideslip tune`` as a function, on a local pool or a Dask cluster.

The study (:mod:`sideslip.studies.control_eval.study`) searches the LQR's weights, speed and friction schedule
and command shaping with Optuna on the training maneuvers, chooses a point of the Pareto front on the development
maneuvers and writes it as a parameter file; several processes may tune into the same folder, and a stopped study
goes on where it stopped.  The held-out figures come from the control evaluation with that file.

    python examples/tune_lqr.py --trials 40                         # 2 local workers
    python examples/tune_lqr.py --trials 200 --scheduler tcp://host:8786
    python -m sideslip control --params out/examples/tune_lqr/chosen.json --quick
"""
import argparse
from pathlib import Path

from sideslip.studies.control_eval.study import run_study

OUT = Path("out") / "examples" / "tune_lqr"


def run(out=OUT, trials: int = 40, workers: int = 2, scheduler=None, **options) -> dict:
    """Run (or go on with) the study in ``out``; returns its summary (the chosen point, throughput, files)."""
    summary = run_study(out, trials, workers, scheduler, **options)
    c = summary["chosen"]
    print(f"{summary['trials']} points; chosen trial {c['trial']}: " + ", ".join(
        f"{k} {v:.3g}" for k, v in c["development"].items() if k in ("rms_yaw_rate_error_deg_s", "effort_kNms",
                                                                    "max_abs_beta_deg")) + " on the development set")
    print(f"{summary['sim_per_wall']:.1f} simulated s per wall s; files: {', '.join(summary['files'])}")
    return summary


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=str(OUT), help="the study's folder (resumed if it holds a study)")
    p.add_argument("--trials", type=int, default=40)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--scheduler", help="Dask scheduler address, or 'local' (default: local process pool)")
    a = p.parse_args()
    run(a.out, a.trials, a.workers, a.scheduler)
