"""One closed loop, three ways: the project's fmpy master, DNV's libcosim, and libcosim on the
exported SSP package; prints the largest differences between them.

    python examples/compare_masters.py [--scenario nguyen2012_cornering] [--estimator Nguyen2012DACMRKF]
                                       [--controller LqrDycController] [--duration 5] [--out out/masters]

Needs ``pip install libcosimpy`` (or ``pip install -e '.[cosim]'``).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from sideslip.cosim.libcosim_master import run_libcosim, run_libcosim_ssp
from sideslip.studies.metrics import trajectory_difference
from sideslip.cosim.assembly import scenario_components
from sideslip.studies.runs import run_scenario
from sideslip.scenarios import get_scenario
from sideslip.cosim.ssp import export_ssp


def run(scenario="nguyen2012_cornering", estimator="Nguyen2012DACMRKF", controller="LqrDycController",
        duration=5.0, out_dir="out/masters") -> dict:
    """Run the loop with every master; returns the differences and the wall times."""
    timing = {}
    t0 = time.perf_counter()
    ref = {scheme: run_scenario(scenario, [estimator], controller, duration=duration, scheme=scheme).results
           for scheme in ("jacobi", "gauss-seidel")}
    timing["fmpy (both schemes)"] = time.perf_counter() - t0
    comps, conns = scenario_components(get_scenario(scenario), [estimator], controller)
    t0 = time.perf_counter()
    lc = run_libcosim(comps, conns, duration=duration)
    timing["libcosim"] = time.perf_counter() - t0
    ssp = export_ssp(Path(out_dir) / f"{scenario}.ssp", scenario, [estimator], controller, duration=duration)
    t0 = time.perf_counter()
    lc_ssp = run_libcosim_ssp(ssp)
    timing["libcosim on the SSP package"] = time.perf_counter() - t0
    return {"libcosim vs fmpy (jacobi)": trajectory_difference(ref["jacobi"], lc),
            "libcosim on SSP vs fmpy (jacobi)": trajectory_difference(ref["jacobi"], lc_ssp),
            "libcosim vs fmpy (gauss-seidel, for scale)": trajectory_difference(ref["gauss-seidel"], lc),
            "timing": timing, "ssp": ssp, "signals": len(lc.names) - 1}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenario", default="nguyen2012_cornering")
    p.add_argument("--estimator", default="Nguyen2012DACMRKF")
    p.add_argument("--controller", default="LqrDycController")
    p.add_argument("--duration", type=float, default=5.0)
    p.add_argument("--out", default="out/masters")
    a = p.parse_args()
    out = run(a.scenario, a.estimator, a.controller, a.duration, a.out)
    print(f"{a.scenario}, {a.duration:g} s, 1 ms step, {out['signals']} outputs compared; SSP: {out['ssp']}")
    print(f"{'comparison':44s} {'max |diff|':>11s}  where{'':22s} {'max scaled':>11s}  where")
    for key, d in out.items():
        if isinstance(d, dict) and "max_abs" in d:
            print(f"{key:44s} {d['max_abs']:11.3g}  {d['max_abs_field']:27s} {d['max_scaled']:11.3g}  "
                  f"{d['max_scaled_field']}")
    print("wall time: " + ", ".join(f"{k} {v:.1f} s" for k, v in out["timing"].items()))


if __name__ == "__main__":
    main()
