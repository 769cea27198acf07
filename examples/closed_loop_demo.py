"""Closed-loop demo: a Park 2018 scenario with every registered estimator; prints metrics, writes a plot.

This is what ``python -m sideslip demo`` runs.  FMUs are built on first use (build/fmus).
"""
from pathlib import Path

from sideslip.studies.runs import run_scenario
from sideslip.fmi.catalogue import fmu_names

OUT = Path("out") / "examples" / "closed_loop_demo"


def run(show_plot=True, scenario="park2018_case2", duration=None, out_dir=OUT):
    """Run ``scenario`` with every estimator FMU; return the :class:`~sideslip.studies.runs.RunOutput`."""
    estimators = fmu_names("estimator")
    out = run_scenario(scenario, estimators, out_dir=out_dir, duration=duration)
    summary = out.metrics["summary"]
    print(f"{scenario}: max |beta| {summary['max_abs_beta_deg']:.2f} deg, "
          f"{out.metrics['real_time_factor']:.1f}x real time")
    if out.table():
        print(out.table())
    print(f"plot: {Path(out_dir) / 'sideslip.png'}")
    if show_plot:
        import matplotlib.pyplot as plt

        plt.imshow(plt.imread(Path(out_dir) / "sideslip.png"))
        plt.axis("off")
        plt.show()
    return out


if __name__ == "__main__":
    run()
