"""One point of an LQR tuning study: closed loops on a maneuver set, the metrics' means."""
from __future__ import annotations

import time

import numpy as np

from ...fmi.build import DEFAULT_OUT
from .cases import ControlCase, Source
from .engines import run_control_case
from .measures import MEASURES


TUNING_MANEUVERS = (("fmvss126_suv_mu08_a5.0", {"maneuver_t_start": 1.0, "duration": 5.0}),
                    ("fmvss126_suv_mu08_a6.5_right", {"maneuver_t_start": 1.0, "duration": 5.0}),
                    ("fmvss126_suv_mu05_a6.5", {"maneuver_t_start": 1.0, "duration": 5.0}))
"""The LQR tuning set: three 5-second sine-with-dwell runs (steer from 1 s, so that the 1.75 s
criterion falls inside the 5 s), left and right, mu 0.8 and 0.5."""


def evaluate_weights(item: dict) -> dict:
    """One point of an LQR tuning study: closed loops of FMUs on a maneuver set under realistic sensors.

    Parameters
    ----------
    item : dict
        ``q_beta``, ``q_gamma``, ``q_N`` and optionally ``maneuvers`` (``(scenario, overrides)``
        pairs, default :data:`TUNING_MANEUVERS`), ``source`` (an estimator name, default
        None: the truth), ``condition`` (default ``sensors+mismatch``), ``seed`` (0), ``fmu_dir``,
        ``duration`` (overrides every maneuver's), ``engine`` (``fmpy``, the default, or ``library``).

    Returns
    -------
    dict
        Means over the maneuvers of the :func:`control_metrics` values, ``fmvss_passes`` (how
        many maneuvers meet the FMVSS 126 yaw-rate criteria), ``sim_seconds`` and ``wall_seconds``.
    """
    t0 = time.perf_counter()
    params = tuple((k, item[k]) for k in ("q_beta", "q_gamma", "q_N"))
    est = item.get("source")
    source = Source(f"LQR / {est or 'truth'}", "LqrDycController", est)
    rows = []
    for name, overrides in item.get("maneuvers", TUNING_MANEUVERS):
        overrides = dict(overrides)
        if item.get("duration"):
            overrides["duration"] = item["duration"]
        case = ControlCase(name, item.get("condition", "sensors+mismatch"), item.get("seed", 0), source, params,
                           tuple(overrides.items()))
        rows.append(run_control_case((case, item.get("engine", "fmpy"), item.get("fmu_dir", str(DEFAULT_OUT)))))
    out = {k: float(np.mean([r[k] for r in rows])) for k in MEASURES}
    out.update(fmvss_passes=int(sum(r.get("yaw_stable", False) for r in rows)),
               sim_seconds=float(sum(r["sim_seconds"] for r in rows)), wall_seconds=time.perf_counter() - t0)
    return out
