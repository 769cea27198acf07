"""Nguyen, Wang, Fujimoto, Hori (2012), "Sideslip angle estimation using GPS and disturbance
accommodating multi-rate Kalman filter for electric vehicle stability control": Table III, with
the FMUs in closed loop.

* :func:`nguyen2012_accuracy` - RMSD of sideslip [rad] of the SRKF, MRKF and DACMRKF, and their
  error between GPS fixes.
"""
from __future__ import annotations


import numpy as np

from ...fmi.build import DEFAULT_OUT
from ...units import DEG
from ..runs import run_jobs



NGUYEN2012_TABLE3 = {"nguyen2012_lanechange": {"srkf": 1.02e-2, "mrkf": 0.86e-2, "dacmrkf": 0.38e-2},
                     "nguyen2012_cornering": {"srkf": 1.12e-2, "mrkf": 0.87e-2, "dacmrkf": 0.41e-2}}
"""Nguyen 2012 Table III: RMSD of the sideslip angle [rad]."""

NGUYEN_MODES = ("srkf", "mrkf", "dacmrkf")


def nguyen2012_accuracy(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None, bin_s: float = 0.02) -> dict:
    """Nguyen 2012 Table III: the three filters side by side (one FMU, three instances).

    Parameters
    ----------
    params : dict, optional
        ``{"<parameter>": value}`` applied to all three instances (e.g. ``discretization``).
    bin_s : float
        Width of the bins of time since the last GPS fix for the inter-sample error [s].

    Returns
    -------
    dict
        ``{scenario: {"rmsd": {mode: rad}, "paper": {mode: rad}, "inter_sample": {mode: [rad per
        bin]}, "bin_s": bin_s}}``.
    """
    ests = tuple(f"{m}=Nguyen2012DACMRKF" for m in NGUYEN_MODES)
    overrides = {f"{m}.{k}": v for m in NGUYEN_MODES for k, v in (params or {}).items()}
    overrides.update({f"{m}.mode": m for m in NGUYEN_MODES})
    fields = ["plant.beta", "sensors.gps_fresh", *(f"{m}.beta_hat" for m in NGUYEN_MODES),
              *(f"{m}.valid" for m in NGUYEN_MODES)]
    names = list(NGUYEN2012_TABLE3)
    out = {}
    for name, (metrics, arr) in zip(names, run_jobs([(n, ests, None, overrides, fields) for n in names],
                                                    fmu_dir, workers, as_published=True)):
        t = arr["time"]
        fixes = t[arr["sensors.gps_fresh"] > 0.5]
        last = np.searchsorted(fixes, t, side="right") - 1          # index of the last fix at or before t
        since = np.where(last >= 0, t - fixes[np.maximum(last, 0)], np.inf)
        bins = np.where(last >= 0, np.floor(np.where(last >= 0, since, 0.0) / bin_s), -1).astype(int)
        n_bins = int(round(0.2 / bin_s))
        row = {"rmsd": {}, "paper": NGUYEN2012_TABLE3[name], "inter_sample": {}, "bin_s": bin_s}
        for m in NGUYEN_MODES:
            row["rmsd"][m] = metrics["estimators"][m]["beta_hat"]["rms"] / DEG
            err = arr[f"{m}.beta_hat"] - arr["plant.beta"]
            ok = (arr[f"{m}.valid"] > 0.5) & (last >= 0)
            row["inter_sample"][m] = [float(np.sqrt(np.mean(err[ok & (bins == b)] ** 2))) for b in range(n_bins)]
        out[name] = row
    return out


def format_nguyen2012_accuracy(table: dict) -> str:
    """Markdown: RMSD per filter (paper in parentheses), then the error by time since the last fix."""
    lines = ["| scenario | " + " | ".join(m.upper() for m in NGUYEN_MODES) + " |",
             "|---|" + "---:|" * len(NGUYEN_MODES)]
    for name, row in table.items():
        lines.append(f"| {name} | " + " | ".join(f"{row['rmsd'][m] * 100:.3f}e-2 ({row['paper'][m] * 100:.2f}e-2)"
                                                  for m in NGUYEN_MODES) + " |")
    for name, row in table.items():
        b = row["bin_s"] * 1e3
        n = len(row["inter_sample"][NGUYEN_MODES[0]])
        lines += ["", f"{name}: RMS sideslip error [1e-3 rad] by time since the last GPS fix",
                  "| filter | " + " | ".join(f"{k * b:g}-{(k + 1) * b:g} ms" for k in range(n)) + " |",
                  "|---|" + "---:|" * n]
        for m in NGUYEN_MODES:
            lines.append(f"| {m.upper()} | " + " | ".join(f"{v * 1e3:.2f}" for v in row["inter_sample"][m]) + " |")
    return "\n".join(lines)


ACCEPTS_PARAMS = True
"""``--param NAME=VALUE`` (an instance prefix is ignored) applies to all three filters."""


def report(fmu_dir=DEFAULT_OUT, workers: int = 2, params=None, extra=()) -> tuple[dict, str]:
    """Table III: ``(figures, Markdown)`` for ``python -m sideslip paper nguyen2012``."""
    acc = nguyen2012_accuracy(fmu_dir, workers, params={k.split(".", 1)[-1]: v for k, v in (params or {}).items()})
    text = ["Nguyen 2012 Table III: sideslip RMSD [rad] (paper in parentheses)", "", format_nguyen2012_accuracy(acc)]
    return {"accuracy": acc}, "\n".join(text)
