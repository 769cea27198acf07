"""Closed-loop evaluation of the LQR direct-yaw-moment controller (FMVSS 126 and two more scenarios).

Every scenario runs with no control, with ``LqrDycController`` on the plant's true sideslip,
and with the controller on each estimator's ``beta_hat`` (every estimator FMU of the catalogue).

* FMVSS 126 (49 CFR 571.126 S5.2, S7.7, S7.11): the yaw rate 1.00 s and 1.75 s after the
  completion of steer must be below 35 % and 20 % of the first yaw-rate peak after the steering
  wheel changes sign; for amplitudes of 5A and more the lateral displacement of the CG 1.07 s
  after the beginning of steer, perpendicular to the initial heading, must be at least 1.83 m.
  A vehicle passes when every amplitude passes.
* Every run: max ``|beta|``, RMS yaw-rate and sideslip tracking errors against the reference
  model of :mod:`sideslip.control.reference` (computed here from the driver's steering and the
  plant speed, so that runs without a controller have a reference too), control effort
  ``int |Mz_act| dt`` (the yaw moment the motors realised) - all while ``v > v_min``.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..bicycle import BicycleModel
from ..control.dyc import LqrDycConfig
from ..control.reference import ReferenceModel
from ..fmi.build import DEFAULT_OUT
from ..fmi.catalogue import fmu_names
from ..plant.maneuvers import parse_maneuver
from ..scenarios import FMVSS_FACTORS, get_scenario
from ..vehicles import load_vehicle
from .runs import run_jobs, run_scenario

__all__ = ["TUNING_MANEUVERS", "evaluate_weights", "steer_times", "FMVSS_FACTORS", "fmvss126_metrics", "control_metrics", "control_evaluation", "format_control_evaluation",
           "scenario_mu", "CONTROLLER"]

CONTROLLER = "LqrDycController"
FMVSS_FAMILY = "fmvss126_suv_mu08"
OTHER_SCENARIOS = ("park2018_case5", "nguyen2012_cornering")
_FIELDS = ("plant.yaw_rate", "plant.beta", "plant.vx", "plant.X", "plant.Y", "plant.yaw", "plant.Mz_act",
           "driver.delta_f", "driver.delta_sw")
_DEG = 180.0 / math.pi


def steer_times(scenario) -> tuple[float, float, float]:
    """Beginning of steer, completion of steer [s] and sine frequency [Hz] of a sine-with-dwell scenario
    (from its maneuver, so that overrides such as ``maneuver_t_start`` are followed)."""
    man = parse_maneuver(scenario.maneuver)
    return man.t_start, man.completion_of_steer, man.frequency


def scenario_mu(scenario) -> float:
    """Friction of a scenario for the controller: its ``mu`` hint, else its (constant) road friction."""
    return float(scenario.hints.get("mu", scenario.road_mu))


def fmvss126_metrics(a: dict, t_bos: float, t_cos: float, factor: float, frequency: float = 0.7) -> dict:
    """FMVSS 126 yaw-stability and responsiveness measures of one sine-with-dwell run.

    Parameters
    ----------
    a : dict
        Arrays ``time``, ``plant.yaw_rate``, ``plant.X``, ``plant.Y``, ``plant.yaw``,
        ``driver.delta_sw``.
    t_bos, t_cos : float
        Beginning and completion of steer [s].
    factor : float
        Amplitude in multiples of A (the displacement criterion applies from 5A).
    frequency : float
        Frequency of the sine [Hz] (0.7 in S7.7).
    """
    t, r, dsw = a["time"], a["plant.yaw_rate"], a["driver.delta_sw"]
    i_bos, i_cos = np.searchsorted(t, t_bos), np.searchsorted(t, t_cos)
    # direction of the first half-wave: handwheel at its first peak (a quarter period after the
    # beginning of steer) against the handwheel at the beginning (the driver may hold a small trim)
    first = np.sign(np.interp(t_bos + 0.25 / frequency, t, dsw) - np.interp(t_bos, t, dsw))
    i_rev = i_bos + int(np.argmax(np.sign(dsw[i_bos:i_cos]) == -first))   # steering wheel changes sign
    window = r[i_rev:i_cos + 1]
    peak = float(window[np.argmax(np.abs(window))])
    r100 = float(np.interp(t_cos + 1.00, t, r)) / peak
    r175 = float(np.interp(t_cos + 1.75, t, r)) / peak
    x0, y0, yaw0 = (float(np.interp(t_bos, t, a[k])) for k in ("plant.X", "plant.Y", "plant.yaw"))
    x1, y1 = (float(np.interp(t_bos + 1.07, t, a[k])) for k in ("plant.X", "plant.Y"))
    lateral = first * (-(x1 - x0) * math.sin(yaw0) + (y1 - y0) * math.cos(yaw0))
    yaw_ok = r100 < 0.35 and r175 < 0.20
    lat_ok = lateral >= 1.83 or factor < 5.0
    return {"yaw_rate_ratio_1s": r100, "yaw_rate_ratio_1p75s": r175, "lateral_1p07s": float(lateral),
            "yaw_stable": bool(yaw_ok), "responsive": bool(lat_ok), "pass": bool(yaw_ok and lat_ok)}


def control_metrics(a: dict, vehicle: str, mu: float, v_min: float = 5.0, Ts: float = 1e-3) -> dict:
    """Max ``|beta|`` [deg], RMS tracking errors [deg, deg/s], effort [N m s] and peak ``|Mz|`` [N m]."""
    cfg = LqrDycConfig()
    model = BicycleModel.from_vehicle(load_vehicle(vehicle), mu, nominal=True)
    ref = ReferenceModel(model, cfg.tau_beta, cfg.tau_gamma, Ts, mu)
    vx, delta = a["plant.vx"], a["driver.delta_f"]
    beta_ref, gamma_ref = np.empty_like(vx), np.empty_like(vx)
    for k, (d, v) in enumerate(zip(delta.tolist(), vx.tolist())):
        beta_ref[k], gamma_ref[k] = ref.step(d, max(v, v_min))
    mask = vx > v_min
    mz = np.abs(a["plant.Mz_act"])
    dt = float(a["time"][1] - a["time"][0])
    return {"max_abs_beta_deg": float(np.max(np.abs(a["plant.beta"][mask])) * _DEG),
            "rms_yaw_rate_error_deg_s": float(np.sqrt(np.mean((a["plant.yaw_rate"] - gamma_ref)[mask] ** 2)) * _DEG),
            "rms_beta_error_deg": float(np.sqrt(np.mean((a["plant.beta"] - beta_ref)[mask] ** 2)) * _DEG),
            "effort_Nms": float(mz.sum() * dt), "max_abs_Mz": float(mz.max())}


def _sources(sources):
    return list(sources) if sources else ["none", "truth", *fmu_names("estimator")]


def control_evaluation(fmu_dir=DEFAULT_OUT, workers: int = 2, sources=None, factors=FMVSS_FACTORS,
                       directions=("", "_right"), others=OTHER_SCENARIOS, params=None) -> dict:
    """Run the evaluation.

    Parameters
    ----------
    sources : list of str, optional
        ``"none"`` (no controller), ``"truth"`` or estimator FMU names (default: all).
    factors, directions
        FMVSS 126 amplitudes (multiples of A) and directions (``""`` left first, ``"_right"``).
    others : tuple of str
        Further scenarios (metrics without the FMVSS criteria).
    params : dict, optional
        ``{"controller.<name>": value}`` overrides of the controller (tuning).

    Returns
    -------
    dict
        ``{scenario_or_family: {source: {...}}}``; the FMVSS family entry holds ``pass``,
        the worst ratios, the smallest displacement and ``runs`` per amplitude.
    """
    sources = _sources(sources)
    fmvss = [f"{FMVSS_FAMILY}_a{f:.1f}{d}" for f in factors for d in directions]
    jobs, keys = [], []
    for name in (*fmvss, *others):
        sc = get_scenario(name)
        for src in sources:
            p = {}
            opts = {}
            if src != "none":
                p = {"controller.mu": scenario_mu(sc), **(params or {})}
                opts = {"controller": CONTROLLER, "control_source": "truth" if src == "truth" else src}
            jobs.append((name, [] if src in ("none", "truth") else [src], None, p, _FIELDS, None, opts))
            keys.append((name, src))
    runs = run_jobs(jobs, fmu_dir, workers)
    table: dict = {}
    for (name, src), (metrics, arrays) in zip(keys, runs):
        sc = get_scenario(name)
        row = control_metrics(arrays, sc.vehicle, scenario_mu(sc))
        if src not in ("none", "truth"):
            row["beta_hat_rms_deg"] = metrics["estimators"][src].get("beta_hat", {}).get("rms", float("nan"))
        if name in fmvss:
            factor = float(name.split("_a")[-1].split("_")[0])
            t_bos, t_cos, freq = steer_times(sc)
            row.update(fmvss126_metrics(arrays, t_bos, t_cos, factor, freq))
            fam = table.setdefault(FMVSS_FAMILY, {}).setdefault(src, {"runs": {}})
            fam["runs"][name] = row
        else:
            table.setdefault(name, {})[src] = row
    for src, fam in table.get(FMVSS_FAMILY, {}).items():
        rows = list(fam["runs"].values())
        fam.update({"pass": all(r["pass"] for r in rows),
                    "failed": [n.split(FMVSS_FAMILY + "_")[1] for n, r in fam["runs"].items() if not r["pass"]],
                    "yaw_rate_ratio_1s": max(r["yaw_rate_ratio_1s"] for r in rows),
                    "yaw_rate_ratio_1p75s": max(r["yaw_rate_ratio_1p75s"] for r in rows),
                    "lateral_1p07s": min((r["lateral_1p07s"] for n, r in fam["runs"].items()
                                          if float(n.split("_a")[-1].split("_")[0]) >= 5.0), default=float("nan")),
                    **{k: max(r[k] for r in rows) for k in ("max_abs_beta_deg", "max_abs_Mz")},
                    **{k: float(np.mean([r[k] for r in rows])) for k in
                       ("rms_yaw_rate_error_deg_s", "rms_beta_error_deg", "effort_Nms")}})
        if src not in ("none", "truth"):
            fam["beta_hat_rms_deg"] = float(np.mean([r["beta_hat_rms_deg"] for r in rows]))
    return table


def format_control_evaluation(table: dict) -> str:
    """Markdown tables of :func:`control_evaluation`."""
    out = []
    fam = table.get(FMVSS_FAMILY)
    if fam:
        out += [f"FMVSS 126 sine with dwell, {FMVSS_FAMILY} (all amplitudes and directions run; worst values)", "",
                "| beta source | pass | r(1.00 s) < 35 % | r(1.75 s) < 20 % | lateral 1.07 s >= 1.83 m | max abs beta "
                "[deg] | RMS yaw-rate err [deg/s] | RMS beta err [deg] | effort [kN m s] | beta_hat RMS [deg] | failed |",
                "|---|---|---|---|---|---|---|---|---|---|---|"]
        for src, r in fam.items():
            out.append(f"| {src} | {'PASS' if r['pass'] else 'FAIL'} | {100 * r['yaw_rate_ratio_1s']:.1f} % | "
                       f"{100 * r['yaw_rate_ratio_1p75s']:.1f} % | {r['lateral_1p07s']:.2f} m | "
                       f"{r['max_abs_beta_deg']:.1f} | {r['rms_yaw_rate_error_deg_s']:.2f} | "
                       f"{r['rms_beta_error_deg']:.2f} | {r['effort_Nms'] / 1e3:.2f} | "
                       f"{r.get('beta_hat_rms_deg', float('nan')):.2f} | {', '.join(r['failed'][:4])}"
                       f"{' ...' if len(r['failed']) > 4 else ''} |")
        out.append("")
    for name, rows in table.items():
        if name == FMVSS_FAMILY:
            continue
        out += [f"{name}", "", "| beta source | max abs beta [deg] | RMS yaw-rate err [deg/s] | RMS beta err [deg] | "
                "effort [kN m s] | max abs Mz [N m] | beta_hat RMS [deg] |", "|---|---|---|---|---|---|---|"]
        for src, r in rows.items():
            out.append(f"| {src} | {r['max_abs_beta_deg']:.2f} | {r['rms_yaw_rate_error_deg_s']:.2f} | "
                       f"{r['rms_beta_error_deg']:.3f} | {r['effort_Nms'] / 1e3:.3f} | {r['max_abs_Mz']:.0f} | "
                       f"{r.get('beta_hat_rms_deg', float('nan')):.3f} |")
        out.append("")
    return "\n".join(out)


# ------------------------------------------------------------------------------ tuning
TUNING_MANEUVERS = (("fmvss126_suv_mu08_a5.0", {"maneuver_t_start": 1.0, "duration": 5.0}),
                    ("fmvss126_suv_mu08_a6.5_right", {"maneuver_t_start": 1.0, "duration": 5.0}),
                    ("fmvss126_suv_mu05_a6.5", {"maneuver_t_start": 1.0, "duration": 5.0}))
"""The LQR tuning set: three 5-second sine-with-dwell runs (steer from 1 s, so that the 1.75 s
criterion falls inside the 5 s), left and right, mu 0.8 and 0.5."""


def evaluate_weights(item: dict) -> dict:
    """One point of an LQR tuning study: closed loops of FMUs on a maneuver set.

    Parameters
    ----------
    item : dict
        ``q_beta``, ``q_gamma``, ``q_N`` and optionally ``maneuvers`` (``(scenario, overrides)``
        pairs, default :data:`TUNING_MANEUVERS`), ``source`` (``"truth"`` or an estimator FMU),
        ``fmu_dir``, ``duration`` (overrides every maneuver's).

    Returns
    -------
    dict
        Means over the maneuvers of the :func:`control_metrics` values, ``fmvss_passes`` (how
        many maneuvers meet the FMVSS 126 yaw-rate criteria), ``sim_seconds`` and ``wall_seconds``.
    """
    t0 = time.perf_counter()
    rows, passes, sim = [], [], 0.0
    params = {f"controller.{k}": item[k] for k in ("q_beta", "q_gamma", "q_N")}
    source = item.get("source", "truth")
    for name, overrides in item.get("maneuvers", TUNING_MANEUVERS):
        overrides = dict(overrides)
        if item.get("duration"):
            overrides["duration"] = item["duration"]
        sc = get_scenario(name, **overrides)
        run = run_scenario(sc, [] if source == "truth" else [source], CONTROLLER, control_source=source,
                           fmu_dir=item.get("fmu_dir", DEFAULT_OUT), params={**params, "controller.mu": scenario_mu(sc)})
        a = {f: np.asarray(run.results[f], dtype=float) for f in ("time", *_FIELDS)}
        rows.append(control_metrics(a, sc.vehicle, scenario_mu(sc)))
        t_bos, t_cos, freq = steer_times(sc)
        if t_cos + 1.75 <= sc.duration:
            passes.append(fmvss126_metrics(a, t_bos, t_cos, 0.0, freq)["yaw_stable"])
        sim += sc.duration
    out = {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}
    out.update(fmvss_passes=int(sum(passes)), sim_seconds=sim, wall_seconds=time.perf_counter() - t0)
    return out
