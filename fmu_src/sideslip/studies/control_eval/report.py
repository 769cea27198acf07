"""The evaluation's tables: aggregates over seeds and their Markdown."""
from __future__ import annotations


import numpy as np

from .cases import LAUNCH, fmvss_family
from .measures import MEASURES




def summarise(rows: list[dict]) -> dict:
    """Aggregate over seeds: ``{condition: {scenario_or_family: {source: {...}}}}``.

    Every metric is given as ``[mean, min, max]`` over the seeds.  The FMVSS family entry of a row
    holds ``passes`` (seeds where it passes every amplitude at which the uncontrolled car fails, in
    the same condition and seed), ``seeds``, ``failed`` (amplitudes failed in some seed), the worst
    yaw-rate ratios and smallest displacement, and the other metrics' worst (max |beta|, saturated,
    max rate) or mean values over the runs.
    """
    out: dict = {}
    fam_runs: dict = {}
    for r in rows:
        if r["factor"] is not None and "pass" in r:
            fam = fmvss_family(r["scenario"])
            fam_runs.setdefault((r["condition"], fam, r["source"], r["seed"]), []).append(r)
        else:
            out.setdefault(r["condition"], {}).setdefault(r["scenario"], {}).setdefault(r["source"], []).append(r)
    for cond, scen in out.items():
        for name, by_src in scen.items():
            for src, rs in by_src.items():
                by_src[src] = {k: [float(np.mean(v)), float(np.min(v)), float(np.max(v))]
                               for k in MEASURES for v in [[x[k] for x in rs]]}
    none_fails = {(c, f, s): {r["scenario"].split(f + "_")[1] for r in rs if not r["pass"]}
                  for (c, f, src, s), rs in fam_runs.items() if src == "none"}
    fams: dict = {}
    for (cond, fam, src, seed), rs in sorted(fam_runs.items(), key=lambda kv: kv[0][3]):
        failed = {r["scenario"].split(fam + "_")[1] for r in rs if not r["pass"]}
        must = none_fails.get((cond, fam, seed), set())
        e = fams.setdefault((cond, fam, src), {"passes": 0, "seeds": 0, "failed": set(), "runs": []})
        e["seeds"] += 1
        e["passes"] += int(not (failed & must)) if src != "none" else int(not failed)
        e["failed"] |= failed
        e["runs"] += rs
    for (cond, fam, src), e in fams.items():
        rs = e.pop("runs")
        e["failed"] = sorted(e["failed"], key=lambda n: (float(n.split("_")[0][1:]), n))
        e.update(factors=sorted({r["factor"] for r in rs}),
                 yaw_rate_ratio_1s=max(r["yaw_rate_ratio_1s"] for r in rs),
                 yaw_rate_ratio_1p75s=max(r["yaw_rate_ratio_1p75s"] for r in rs),
                 lateral_1p07s=min((r["lateral_1p07s"] for r in rs if r["factor"] >= 5.0), default=float("nan")),
                 **{k: max(r[k] for r in rs) for k in ("max_abs_beta_deg", "saturated_pct", "max_dMz_dt")},
                 **{k: float(np.mean([r[k] for r in rs])) for k in
                    ("rms_yaw_rate_error_deg_s", "rms_beta_error_deg", "effort_Nms", "rms_dMz_dt")})
        out.setdefault(cond, {}).setdefault(fam, {})[src] = e
    return out


def _mmm(v, fmt="{:.2f}") -> str:
    mean, lo, hi = v
    return fmt.format(mean) + (f" ({fmt.format(lo)}-{fmt.format(hi)})" if hi - lo > 1e-9 else "")


def format_control_evaluation(summary: dict) -> str:
    """Markdown tables of :func:`summarise` (mean over seeds, the range in brackets)."""
    out = []
    for cond, scen in summary.items():
        for name, rows in scen.items():
            if name.startswith("fmvss126_"):
                factors = next(iter(rows.values())).get("factors", [])
                amplitudes = ", ".join(f"{f:g}A" for f in factors) if len(factors) <= 4 else \
                    f"{factors[0]:g}A-{factors[-1]:g}A"
                out += [f"**FMVSS 126 sine with dwell, {name}, {cond}** (amplitudes {amplitudes}; worst values over "
                        "amplitudes, directions and seeds)", "",
                        "| row | passes where uncontrolled fails | r(1.00 s) | r(1.75 s) | lateral 1.07 s [m] | "
                        "max abs beta [deg] | RMS yaw-rate err [deg/s] | RMS beta err [deg] | effort [kN m s] | "
                        "saturated [%] | RMS dMz/dt [kN m/s] | max dMz/dt [kN m/s] | failed |",
                        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
                for src, r in rows.items():
                    passes = f"{r['passes']} of {r['seeds']} seeds" if src != "none" else (
                        f"passes all in {r['passes']} of {r['seeds']}")
                    failed = ", ".join(r["failed"][:6]) + (" ..." if len(r["failed"]) > 6 else "")
                    out.append(f"| {src} | {passes} | {100 * r['yaw_rate_ratio_1s']:.1f} % | "
                               f"{100 * r['yaw_rate_ratio_1p75s']:.1f} % | {r['lateral_1p07s']:.2f} | "
                               f"{r['max_abs_beta_deg']:.1f} | {r['rms_yaw_rate_error_deg_s']:.2f} | "
                               f"{r['rms_beta_error_deg']:.2f} | {r['effort_Nms'] / 1e3:.2f} | "
                               f"{r['saturated_pct']:.1f} | {r['rms_dMz_dt'] / 1e3:.1f} | "
                               f"{r['max_dMz_dt'] / 1e3:.1f} | {failed} |")
                out.append("")
                continue
            launch = name == LAUNCH
            out += [f"**{name}, {cond}** (mean over seeds, range in brackets)", "",
                    "| row | max abs beta [deg] | RMS yaw-rate err [deg/s] | RMS beta err [deg] | effort [kN m s] | "
                    "saturated [%] | RMS Mz_cmd [N m] | RMS dMz/dt [kN m/s] | max dMz/dt [kN m/s] |"
                    + (" max Mz against the steer, launch [N m] |" if launch else ""),
                    "|---|---:|---:|---:|---:|---:|---:|---:|---:|" + ("---:|" if launch else "")]
            for src, r in rows.items():
                out.append(f"| {src} | {_mmm(r['max_abs_beta_deg'])} | {_mmm(r['rms_yaw_rate_error_deg_s'])} | "
                           f"{_mmm(r['rms_beta_error_deg'])} | {r['effort_Nms'][0] / 1e3:.2f} | "
                           f"{_mmm(r['saturated_pct'], '{:.1f}')} | {_mmm(r['rms_Mz_cmd'], '{:.0f}')} | "
                           f"{r['rms_dMz_dt'][0] / 1e3:.2f} | {r['max_dMz_dt'][0] / 1e3:.1f} |"
                           + (f" {_mmm(r['max_counter_Mz_launch'], '{:.0f}')} |" if launch else ""))
            out.append("")
    return "\n".join(out)
