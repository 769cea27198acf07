"""Pi, Chen, Wang, Zhang (2011), "Design and evaluation of sideslip angle observer for vehicle
stability control": Table 4, with the FMUs in closed loop.

* :func:`pi2011_accuracy` - normalised error (eq 48) of the method and the model- and
  kinematics-based baselines on three roads.
"""
from __future__ import annotations



from ...fmi.build import DEFAULT_OUT
from ..runs import run_jobs



PI2011_TABLE4 = {"pi2011_high": {"method": (5.1, 0.388), "model": (35.5, 6.4), "kinematic": (16.3, 7.0)},
                 "pi2011_medium": {"method": (8.0, 0.307), "model": (41.7, 7.8), "kinematic": (9.9, 4.7)},
                 "pi2011_low": {"method": (12.2, 1.5), "model": (135.2, 28.0), "kinematic": (164.9, 102.4)}}
"""Pi 2011 Table 4: road -> estimator -> (max, mean) normalised error of eq 48 [%]."""

PI_COLUMNS = (("method", "Pi2011FuzzyEKF"), ("model", "LinearBicycleObserver"), ("kinematic", "OpenLoopKinematic"))


def pi2011_accuracy(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None) -> dict:
    """Pi 2011 Table 4: max and mean normalised sideslip error (eq 48) of the method and the two baselines.

    Returns
    -------
    dict
        ``{road: {column: {"max": %, "mean": %}, "paper": {column: (max, mean)}}}``.
    """
    names = list(PI2011_TABLE4)
    ests = tuple(fmu for _, fmu in PI_COLUMNS)
    out = {}
    for name, (metrics, _) in zip(names, run_jobs([(n, ests, None, params, ()) for n in names], fmu_dir, workers, as_published=True)):
        row = {}
        for label, fmu in PI_COLUMNS:
            b = metrics["estimators"][fmu]["beta_hat"]
            row[label] = {"max": b["norm_max_pct"], "mean": b["norm_mean_pct"]}
        row["paper"] = PI2011_TABLE4[name]
        out[name] = row
    return out


def format_pi2011_accuracy(table: dict) -> str:
    """Markdown: max / mean normalised error [%] per road, the paper's in parentheses."""
    lines = ["| road | " + " | ".join(f"{label} ({fmu})" for label, fmu in PI_COLUMNS) + " |",
             "|---|" + "---:|" * len(PI_COLUMNS)]
    for name, row in table.items():
        cells = [f"{row[lb]['max']:.1f} / {row[lb]['mean']:.2f} ({row['paper'][lb][0]:g} / {row['paper'][lb][1]:g})"
                 for lb, _ in PI_COLUMNS]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


ACCEPTS_PARAMS = True
"""``--param INSTANCE.NAME=VALUE`` overrides of the three estimators."""


def report(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None, extra=()) -> tuple[dict, str]:
    """Table 4: ``(figures, Markdown)`` for ``python -m sideslip paper pi2011``."""
    acc = pi2011_accuracy(fmu_dir, workers, params=params or None)
    text = ["Pi 2011 Table 4: normalised sideslip error (eq 48), max / mean [%] (paper in parentheses)", "",
            format_pi2011_accuracy(acc)]
    return {"accuracy": acc}, "\n".join(text)
