"""The benchmark's results as a leaderboard: tables per condition, a heat map, error-vs-time plots.

:func:`summarise` averages each row's figures over the seeds of every (scenario, condition) and
scores it across scenarios; :func:`write_report` writes ``leaderboard.md``, ``benchmark.json``
(every case and the summary), ``heatmap.png`` (RMS per estimator x scenario for a condition) and
``errors_<scenario>.png`` (true and estimated sideslip over time, seed 0) into a folder.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

__all__ = ["short_name", "group", "summarise", "leaderboard_markdown", "write_report"]

_FIELDS = ("rms", "max", "zero_rms", "rms_valid", "zero_rms_valid", "restarts", "valid", "time_to_valid", "std_ratio",
           "nees", "coverage95", "off_while_valid", "max_abs_beta", "not_valid_when_worse")


def short_name(scenario: str) -> str:
    """A benchmark scenario without its ``bench_`` prefix, a recorded drive by its file's stem."""
    return Path(scenario).stem if scenario.endswith(".csv") else scenario.replace("bench_", "")


def _nanmean(values):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(values)) if values else float("nan")


def group(result: dict) -> str:
    """The table a case's result belongs to: its condition, on a CommonRoad car ``"<condition> on <plant>"``."""
    plant = result.get("plant", "own")
    return result["condition"] if plant == "own" else f"{result['condition']} on {plant}"


KNOWS = 0.8
"""Share of the samples where a row is worse than predicting zero that it must call not valid, on a case where it does
not beat predict-zero, to count as knowing it."""


def _pooled_ratio(metrics: list[dict]) -> float:
    """RMS error over RMS reported std over every moving sample of the cases (each case's RMS figures weighed by its
    moving time)."""
    num = den = 0.0
    for m in metrics:
        ratio, n = m.get("std_ratio", float("nan")), m.get("moving_s", 1.0)
        if not (math.isfinite(ratio) and ratio > 0.0 and math.isfinite(m["rms"])):
            continue
        num += n * m["rms"] ** 2
        den += n * (m["rms"] / ratio) ** 2
    return math.sqrt(num / den) if den > 0.0 else float("nan")


def _beats(rms: float, zero_rms: float) -> bool:
    """Below predict-zero's RMS by more than rounding (predict-zero itself, summed in another order, never beats)."""
    return rms < zero_rms * (1.0 - 1e-9)


def summarise(results: list[dict]) -> dict:
    """``{condition: {"scenarios": [...], "rows": {label: {"per_scenario": {scenario: {field: mean,
    "rms_min", "rms_max"}}, "mean_rms", "beats_zero", "cases_beta_1deg", "std_ratio", "coverage95",
    "worst_off_while_valid", "total_off_while_valid", "valid"}}}}`` per :func:`group`: means over seeds (the
    longest stretch more than 3 deg off while valid: the worst case's, and the sum over the cases);
    ``beats_zero`` counts the scenarios with a true sideslip of at least 1 deg where the row's mean RMS is below
    predict-zero's on the same samples, ``beats_zero_05`` the same over the cases (seeds apart) with a peak of
    0.5 deg or more, ``knows_05`` those of the rest where the row calls at least :data:`KNOWS` of the samples where it
    is worse than zero not valid, ``std_ratio_pooled`` RMS error over RMS std over every case (:func:`_pooled_ratio`)."""
    out: dict = {}
    for r in results:
        cond = out.setdefault(group(r), {"scenarios": [], "rows": {}, "mu_min": {}})
        if r["scenario"] not in cond["scenarios"]:
            cond["scenarios"].append(r["scenario"])
        cond["mu_min"][r["scenario"]] = r["mu_min"]
        for label, m in r["rows"].items():
            row = cond["rows"].setdefault(label, {"per_scenario": {}})
            row["per_scenario"].setdefault(r["scenario"], []).append(m)
    for cond in out.values():
        for label, row in cond["rows"].items():
            per = {}
            every = [m for ms in row["per_scenario"].values() for m in ms]
            big = [m for m in every if m["max_abs_beta"] >= 0.5]
            lost = [m for m in big if not _beats(m["rms"], m["zero_rms"])]
            row.update(beats_zero_05=len(big) - len(lost), cases_beta_05=len(big),
                       knows_05=sum(1 for m in lost if m.get("not_valid_when_worse", 0.0) >= KNOWS),
                       total_off_while_valid=float(sum(m["off_while_valid"] for m in every)),
                       worst_off_while_valid=max((m["off_while_valid"] for m in every), default=0.0),
                       not_valid_when_worse=_nanmean([m.get("not_valid_when_worse", float("nan")) for m in every]),
                       std_ratio_pooled=_pooled_ratio(every))
            for sc, ms in row["per_scenario"].items():
                rms = [m["rms"] for m in ms]
                per[sc] = {f: _nanmean([m.get(f, float("nan")) for m in ms]) for f in _FIELDS}
                per[sc].update(rms_min=float(np.nanmin(rms)) if np.isfinite(rms).any() else float("nan"),
                               rms_max=float(np.nanmax(rms)) if np.isfinite(rms).any() else float("nan"),
                               seeds=len(ms))
            row["per_scenario"] = per
            big = [sc for sc, v in per.items() if v["max_abs_beta"] >= 1.0]
            row.update(mean_rms=_nanmean([v["rms"] for v in per.values()]),
                       beats_zero=sum(1 for sc in big if _beats(per[sc]["rms"], per[sc]["zero_rms"])),
                       cases_beta_1deg=len(big),
                       std_ratio=_nanmean([v["std_ratio"] for v in per.values()]),
                       coverage95=_nanmean([v["coverage95"] for v in per.values()]),
                       valid=_nanmean([v["valid"] for v in per.values()]))
    return out


def leaderboard_markdown(summary: dict, title: str = "") -> str:
    """Markdown tables: per condition, sideslip RMS [deg] per scenario (mean over seeds, the spread in
    brackets), then the summary columns."""
    lines = [f"# {title}" if title else ""]
    for cond, data in summary.items():
        scenarios = data["scenarios"]
        short = [short_name(sc) for sc in scenarios]
        lines += ["", f"## {cond}", "",
                  "Sideslip RMS error [deg] over every sample the car moves (valid or not), mean over seeds "
                  "(min-max); the true sideslip's peak and the road's lowest friction under each scenario.  "
                  "*beats predict-zero*: scenarios with a peak of 1 deg or more where the mean RMS is below "
                  "predict-zero's; *cases beating it*: the same per case (seeds apart) with a peak of 0.5 deg or more, "
                  "and of the others those where the row calls 80 % or more of the samples where it is worse than "
                  "zero not valid (*knows*); *RMS err / RMS std* (over every case's moving samples) and *within 1.96 "
                  "std*: the consistency of beta_hat_std (1 and 95 % when consistent); *valid*: share of moving "
                  "samples; *longest > 3 deg while valid*: the worst case's longest stretch, and their sum.", "",
                  "| estimator | " + " | ".join(short) + " | mean | beats predict-zero | cases beating it (peak >= "
                  "0.5 deg) / knows | RMS err / RMS std | within 1.96 std | valid | not valid where worse than zero "
                  "| longest > 3 deg while valid [s] | summed [s] |",
                  "|---|" + "---:|" * (len(scenarios) + 10)]
        first = next(iter(data["rows"].values()))["per_scenario"]
        lines.append("| *peak beta [deg], mu* | " + " | ".join(
            f"*{first[sc]['max_abs_beta']:.1f}, {data['mu_min'][sc]:.2g}*" for sc in scenarios) + " |" * 11)
        order = sorted(data["rows"].items(), key=lambda kv: (kv[0] != "predict-zero", kv[1]["mean_rms"]))
        for label, row in order:
            cells = []
            for sc in scenarios:
                v = row["per_scenario"][sc]
                spread = f" ({v['rms_min']:.2f}-{v['rms_max']:.2f})" if v["seeds"] > 1 else ""
                cells.append(f"{v['rms']:.2f}{spread}")
            lines.append(f"| {label} | " + " | ".join(cells) +
                         f" | **{row['mean_rms']:.2f}** | {row['beats_zero']} of {row['cases_beta_1deg']} | "
                         f"{row['beats_zero_05']} of {row['cases_beta_05']} / "
                         f"{row['knows_05']} of {row['cases_beta_05'] - row['beats_zero_05']} | "
                         f"{row['std_ratio_pooled']:.2f} | {100 * row['coverage95']:.0f} % | {100 * row['valid']:.0f} % | "
                         f"{_percent(row['not_valid_when_worse'])} | "
                         f"{row['worst_off_while_valid']:.1f} | {row['total_off_while_valid']:.1f} |")
    return "\n".join(lines).lstrip() + "\n"


def _percent(share: float) -> str:
    return f"{100 * share:.0f} %" if math.isfinite(share) else "-"


def _heatmap(data: dict, condition: str, path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    scenarios = data["scenarios"]
    labels = sorted(data["rows"], key=lambda k: data["rows"][k]["mean_rms"])
    grid = np.array([[data["rows"][lb]["per_scenario"][sc]["rms"] for sc in scenarios] for lb in labels])
    fig = Figure(figsize=(max(6.0, 3.0 + 0.75 * len(scenarios)), 1.5 + 0.42 * len(labels)))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    im = ax.imshow(np.clip(grid, 0.01, 100.0), norm=LogNorm(0.03, 30.0), cmap="RdYlGn_r", aspect="auto")
    for i in range(len(labels)):
        for j in range(len(scenarios)):
            ax.text(j, i, f"{grid[i, j]:.2f}" if grid[i, j] < 10 else f"{grid[i, j]:.0f}", ha="center", va="center",
                    fontsize=7)
    ax.set_xticks(range(len(scenarios)), [short_name(s) for s in scenarios], rotation=55, ha="right",
                  fontsize=8)
    ax.set_yticks(range(len(labels)), labels, fontsize=8)
    ax.set_title(f"sideslip RMS error [deg], {condition}, mean over seeds", fontsize=9)
    fig.colorbar(im, ax=ax, shrink=0.8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _error_plot(result: dict, path: Path) -> None:
    """True and estimated sideslip and the error over time: hardened profiles and references solid, the
    published ones dashed, samples the estimator calls not valid left out."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    tr = result["traces"]
    fig = Figure(figsize=(10, 6.5))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(tr["time"], tr["beta"], "k", lw=2, label="true")
    t_true = np.asarray(tr["time"])
    beta = np.asarray(tr["beta"])
    colours = iter(f"C{i}" for i in range(10))
    colour_of: dict = {}
    for label, row in tr.items():
        if label in ("time", "beta") or label == "predict-zero":
            continue
        method = label.split("/")[0]
        colour = colour_of.setdefault(method, next(colours, "grey"))
        style = "--" if label.endswith("/published") else "-"
        t = np.asarray(row["time"])
        est = np.asarray(row["beta_hat"], dtype=float)
        ax1.plot(t, est, style, color=colour, lw=1, label=label)
        ax2.plot(t, est - np.interp(t, t_true, beta), style, color=colour, lw=1)
    ax1.set_ylabel("sideslip [deg]")
    ax1.set_title(result["case"] + " (gaps: not valid)", fontsize=9)
    ax1.legend(fontsize=6, ncol=3)
    ax2.set_ylabel("error [deg]")
    ax2.set_ylim(-5, 5)
    ax2.axhline(0, color="k", lw=0.5)
    ax2.set_xlabel("time [s]")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def write_report(results: list[dict], out_dir: str | Path, title: str = "Sideslip estimator benchmark",
                 heatmap_condition: str = "sensors+mismatch", meta: dict | None = None) -> dict:
    """Write the leaderboard, the JSON, the heat map and the error plots; returns the summary."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarise(results)
    (out / "leaderboard.md").write_text(leaderboard_markdown(summary, title))
    (out / "benchmark.json").write_text(json.dumps(
        {"meta": meta or {}, "summary": summary,
         "cases": [{k: v for k, v in r.items() if k != "traces"} for r in results]}, indent=1, default=float))
    cond = heatmap_condition if heatmap_condition in summary else next(iter(summary))
    _heatmap(summary[cond], cond, out / "heatmap.png")
    for key in summary:                              # the same condition on another plant
        if key.startswith(f"{cond} on "):
            _heatmap(summary[key], key, out / f"heatmap_{key.rpartition(' on ')[2]}.png")
    for r in results:
        if "traces" in r and r["condition"] == cond:
            plant = "" if r.get("plant", "own") == "own" else f"_{r['plant']}"
            _error_plot(r, out / f"errors_{short_name(r['scenario'])}{plant}.png")
    return summary
