"""Benchmark: microseconds per communication step of every FMU in fmpy, and the closed-loop speed.

Each FMU is timed inside a real closed loop (driver, plant, sensors and, for estimators and
controllers, the FMU under test) with the master's profiler: the time to set its inputs,
``doStep`` and get its outputs, averaged over 100-step blocks; a run's figure is the median
over blocks.  The machine is a shared VM whose speed varies by up to 2x between runs, so each
measurement is repeated and the best run is reported (all runs are kept in the output).  The
closed-loop real-time factor comes from separate, unprofiled runs of driver + plant + sensors.
The estimators run in their default (hardened) profile, at their default sample period.

Multiples of the call floor (:data:`FLOOR_FMU`): every FMU's figure over the floor's of the same run, and for the
five-FMU loop and its FMUs, over the floor measured in the same 100-step blocks (the floor FMU runs beside them),
which is what to compare across runs on a machine whose speed moves within a minute.
"""
from __future__ import annotations

import dataclasses
import statistics

from ..cosim.assembly import scenario_components
from ..cosim.master import CoSimulation
from ..fmi.build import DEFAULT_OUT, ensure_fmus
from ..fmi.catalogue import fmu_names, fmu_spec
from ..progress import progress_bar
from ..scenarios import get_scenario

__all__ = ["run_bench", "format_bench", "instantiation_times", "instruction_counts", "loop_breakdown", "FLOOR_FMU",
           "FIVE_FMU_LOOP"]

BENCH_SCENARIO = "park2018_case2"
FLOOR_FMU = "OpenLoopKinematic"
"""The call floor: its filter runs every 10 ms and does little, so its per-step cost is the FMI call, the port
moves and the range checks that every FMU pays."""
FIVE_FMU_LOOP = ("SideslipFusion", "LqrDycController")
"""The estimator and the controller of the five-FMU loop (with driver, plant and sensors)."""


def run_bench(duration: float = 5.0, scenario: str = BENCH_SCENARIO, fmu_dir=DEFAULT_OUT, repeats: int = 3,
              progress: bool = True) -> dict:
    """Benchmark every FMU of the catalogue and the driver + plant + sensors loop (a progress bar on stderr when it
    is a terminal and ``progress``).

    Returns
    -------
    dict
        ``{"scenario", "step", "fmus": {name: {"median_us", "p90_us"}}, "closed_loop": {...}}``.
    """
    # what a user gets by default: the hardened profiles (a paper's scenario would choose the published ones)
    sc = dataclasses.replace(get_scenario(scenario), estimator_profile=1)
    step = 1e-3
    out = {"scenario": scenario, "step": step, "duration": duration, "fmus": {}, "closed_loop": {}}
    loops = repeats * (5 + len(fmu_names("estimator")) + len(fmu_names("controller")))
    bar = progress_bar(loops * duration, "bench", "sim s", enabled=None if progress else False)
    # closed loop, unprofiled: best of `repeats` runs (the machine is shared)
    rtfs = []
    for _ in range(repeats):
        comps, conns = scenario_components(sc)
        with CoSimulation(comps, conns, step=step, fmu_dir=fmu_dir) as sim:
            res = sim.run(duration)
        rtfs.append(res.meta["real_time_factor"])
        bar.update(duration)
    best = max(rtfs)
    out["closed_loop"] = {"components": [c.name for c in comps], "real_time_factor": best,
                          "us_per_step": step / best * 1e6, "all_real_time_factors": rtfs}
    rtfs = []
    comps, conns = scenario_components(sc, [FIVE_FMU_LOOP[0]], FIVE_FMU_LOOP[1])
    for _ in range(repeats):
        with CoSimulation(comps, conns, step=step, fmu_dir=fmu_dir) as sim:
            rtfs.append(sim.run(duration).meta["real_time_factor"])
        bar.update(duration)
    best = max(rtfs)
    out["five_fmu_loop"] = {"components": [c.fmu for c in comps], "real_time_factor": best,
                            "us_per_step": step / best * 1e6, "all_real_time_factors": rtfs,
                            **_paired_with_floor(sc, step, duration, fmu_dir, repeats, bar)}
    # per FMU, profiled inside the loop: median over blocks, best of `repeats` runs
    runs: dict[str, list[float]] = {}
    p90: dict[str, list[float]] = {}

    def profile(estimators, controller, names):
        # every estimator at its own default sample period, not the scenario's hint for Park 2018
        params = {f"{e}.Ts": fmu_spec(e).config_class().Ts for e in estimators}
        comps, conns = scenario_components(sc, estimators, controller, params=params)
        for _ in range(repeats):
            with CoSimulation(comps, conns, step=step, fmu_dir=fmu_dir) as sim:
                prof = sim.run(duration, profile=True).meta["profile"]
            bar.update(duration)
            for inst, fmu in names:
                blocks = sorted(prof[inst])
                runs.setdefault(fmu, []).append(statistics.median(blocks))
                p90.setdefault(fmu, []).append(blocks[int(0.9 * (len(blocks) - 1))])

    comps, conns = scenario_components(sc)
    profile([], None, [(c.name, c.fmu) for c in comps])
    # the third-party plant in the same loop, in place of the project's (vehicle set 2, the BMW 320i)
    plant = next(c for c in comps if c.name == "plant")
    third = [dataclasses.replace(c, fmu="CommonRoadPlant",
                                 parameters={"vehicle_set": 2, "vx0": float(plant.parameters.get("vx0", 0.0))})
             if c.name == "plant" else c for c in comps]
    for _ in range(repeats):
        with CoSimulation(third, conns, step=step, fmu_dir=fmu_dir) as sim:
            blocks = sorted(sim.run(duration, profile=True).meta["profile"]["plant"])
        bar.update(duration)
        runs.setdefault("CommonRoadPlant", []).append(statistics.median(blocks))
        p90.setdefault("CommonRoadPlant", []).append(blocks[int(0.9 * (len(blocks) - 1))])
    for name in fmu_names("estimator"):
        profile([name], None, [(name, name)])
    for name in fmu_names("controller"):
        profile([], name, [("controller", name)])
    for fmu, medians in runs.items():
        best = min(range(len(medians)), key=medians.__getitem__)
        out["fmus"][fmu] = {"median_us": medians[best], "p90_us": p90[fmu][best], "all_run_medians_us": medians}
    bar.close()
    floor = out["fmus"][FLOOR_FMU]["median_us"]
    out["floor_us"] = floor
    for m in out["fmus"].values():
        m["x_floor"] = m["median_us"] / floor
    out["closed_loop"]["x_floor"] = out["closed_loop"]["us_per_step"] / floor
    out["instantiation_s"] = instantiation_times(fmu_names("controller"), fmu_dir, repeats)
    return out


def _paired_with_floor(sc, step, duration, fmu_dir, repeats, bar) -> dict:
    """The five-FMU loop and its FMUs as multiples of the floor measured in the same 100-step blocks.

    The floor FMU runs in the loop beside the five (fed, feeding nothing); in every block of the master's profile
    the loop's cost is the whole step less the floor FMU's calls, and each figure is divided by the floor FMU's
    cost in that block: the machine's speed, which moves by 1.5x within a minute on a shared VM, cancels block
    by block.  Medians over the blocks of ``repeats`` runs.
    """
    floor_ts = fmu_spec(FLOOR_FMU).config_class().Ts
    comps, conns = scenario_components(sc, [FIVE_FMU_LOOP[0], FLOOR_FMU], FIVE_FMU_LOOP[1],
                                       params={f"{FLOOR_FMU}.Ts": floor_ts})
    names = {c.name: c.fmu for c in comps if c.fmu != FLOOR_FMU}
    ratios: dict[str, list[float]] = {name: [] for name in (*names.values(), "loop")}
    loop_us = []
    for _ in range(repeats):
        with CoSimulation(comps, conns, step=step, fmu_dir=fmu_dir) as sim:
            meta = sim.run(duration, profile=True).meta
        bar.update(duration)
        prof, whole = meta["profile"], meta["profile_step"]
        for b, total in enumerate(whole):
            floor = prof[FLOOR_FMU][b]
            loop_us.append(total - floor)
            ratios["loop"].append((total - floor) / floor)
            for inst, fmu in names.items():
                ratios[fmu].append(prof[inst][b] / floor)
    return {"x_floor": statistics.median(ratios.pop("loop")), "us_per_step_profiled": statistics.median(loop_us),
            "x_floor_by_fmu": {fmu: statistics.median(r) for fmu, r in ratios.items()}}


_INSTANTIATE = """
import sys, time
if sys.argv[2] == "warm":
    import scipy.linalg  # noqa: F401 - a host that already runs another of the project's FMUs
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
unzipped = extract(sys.argv[1])
t = time.perf_counter()
s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
              instanceName="x")
s.instantiate()
s.setupExperiment(startTime=0.0)
s.enterInitializationMode()
s.exitInitializationMode()
print(time.perf_counter() - t)
"""


def instantiation_times(names, fmu_dir=DEFAULT_OUT, repeats: int = 3) -> dict:
    """Seconds from ``fmi2Instantiate`` to the end of initialisation of each FMU, in a fresh process each time:
    ``cold`` (the host has imported only fmpy and numpy: the FMU's first instance imports SciPy and the rest) and
    ``warm`` (SciPy already imported, as in a host that runs another of the project's FMUs); medians of
    ``repeats``."""
    import subprocess
    import sys

    paths = ensure_fmus(list(names), fmu_dir)
    out = {}
    for name in names:
        times = {mode: [] for mode in ("cold", "warm")}
        for _ in range(repeats):
            for mode in times:             # alternately: the machine's speed drifts
                proc = subprocess.run([sys.executable, "-c", _INSTANTIATE, str(paths[name]), mode],
                                      capture_output=True, text=True, check=True)
                times[mode].append(float(proc.stdout.strip().splitlines()[-1]))
        out[name] = {mode: statistics.median(v) for mode, v in times.items()}
    return out


_PLANT_STEPS = """
import sys
from sideslip.plant.vehicle import PlantConfig, VehiclePlant
plant = VehiclePlant(PlantConfig(vehicle="park2018_sonata", vx0=18.0))
for k in range(int(sys.argv[1])):
    plant.step(1e-3, delta_f=0.03 if (k // 500) % 2 else -0.03, T_drive=120.0, mu=0.9)
"""

_DRIVER_STEPS = """
import sys
from sideslip.params import build
from sideslip.plant.driver import Driver, DriverConfig
from sideslip.scenarios import get_scenario
driver = Driver(build(DriverConfig, get_scenario("park2018_case2").driver_params()))
for k in range(int(sys.argv[1])):
    driver.step(1e-3, 18.0, 0.018 * k, 0.002 * k, 0.0)
"""

_CONTROLLER_STEPS = """
import math, sys
from sideslip.control.dyc import LqrDycController
controller = LqrDycController()
for k in range(int(sys.argv[1])):
    w = math.sin(k / 150.0)
    controller.step(1e-3, 0.03 * w, 20.0, 0.01 * w, 0.2 * w, 0.0, True, True, 0.0, 0.0)
"""

_FUSION_STEPS = """
import sys
from sideslip.estimators import ESTIMATORS
from sideslip.params import build
from sideslip.scenarios import get_scenario, scenario_params
from sideslip.studies.runs import run_library
scenario = get_scenario("park2018_case2", estimator_profile=1)
fusion = ESTIMATORS["SideslipFusion"]
recorded = run_library(scenario, [], duration=2.0)
inputs = list(zip(*(recorded["sensors." + name].tolist() for name in fusion.input_names)))
estimator = fusion(build(fusion.config_class, scenario_params(fusion.config_class, scenario)))
for row in inputs[:1000] + inputs[1000:1000 + int(sys.argv[1])]:       # after 1 s: started, heading known
    estimator.step(1e-3, *row)
"""

_LOOP_STEPS = """
import sys
from sideslip.cosim.assembly import scenario_components
from sideslip.cosim.master import CoSimulation
from sideslip.scenarios import get_scenario
comps, conns = scenario_components(get_scenario("park2018_case2"), sys.argv[3:4], sys.argv[4] if len(sys.argv) > 4
                                   else None)
with CoSimulation(comps, conns, step=1e-3, fmu_dir=sys.argv[2]) as sim:
    sim.run(int(sys.argv[1]) * 1e-3)
"""


def _instructions(code: str, args) -> int:
    """Instructions a Python process running ``code`` executes (valgrind's callgrind).  One BLAS thread: OpenBLAS's
    idle threads spin for as long as the scheduler lets them, millions of instructions that differ from run to run;
    string hashing seeded, so that two runs lay out their dicts alike."""
    import os
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable, "-c", code,
                        *map(str, args)], capture_output=True, text=True, check=True,
                       env={**os.environ, "PYTHONHASHSEED": "0", "OPENBLAS_NUM_THREADS": "1",
                            "OMP_NUM_THREADS": "1"})
        for line in out.read_text().splitlines():
            if line.startswith(("summary:", "totals:")):
                return int(line.split()[1])
    raise RuntimeError("callgrind wrote no total")


def instruction_counts(fmu_dir=DEFAULT_OUT, short: int = 200, long: int = 700) -> dict:
    """Instructions per 1 ms step, counted by callgrind (independent of the machine's load), as the difference of a
    ``long`` and a ``short`` run (start-up cancels): the library ``VehiclePlant.step``, ``Driver.step`` (following
    ``park2018_case2``'s path), ``LqrDycController.step`` (a sine steer at 20 m/s), ``SideslipFusion.step`` (on
    ``park2018_case2``'s sensor signals, after its first second) and the driver + plant + sensors FMU loop in fmpy
    (the five-FMU loop takes over ten minutes to start under callgrind).  Needs valgrind (``apt install
    valgrind``)."""
    import shutil

    if shutil.which("valgrind") is None:
        raise RuntimeError("counting instructions needs valgrind on the PATH (apt install valgrind)")
    ensure_fmus(["ManeuverDriver", "VehiclePlant", "VehicleSensors"], fmu_dir)
    cases = {"VehiclePlant.step (library)": (_PLANT_STEPS, ()), "Driver.step (library)": (_DRIVER_STEPS, ()),
             "LqrDycController.step (library)": (_CONTROLLER_STEPS, ()),
             "SideslipFusion.step (library)": (_FUSION_STEPS, ()),
             "driver + plant + sensors (FMUs)": (_LOOP_STEPS, (fmu_dir,))}
    return {name: (_instructions(code, (long, *extra)) - _instructions(code, (short, *extra))) / (long - short)
            for name, (code, extra) in cases.items()}


def loop_breakdown(duration: float = 3.0, fmu_dir=DEFAULT_OUT, scenario: str = BENCH_SCENARIO) -> dict:
    """Where each microsecond of a five-FMU loop step goes, per FMU [us per 1 ms step].

    The loop runs in this process (fmpy loads the FMUs' Python into this interpreter) with the master's per-FMU
    timer (set inputs, ``doStep``, get outputs) and timers wrapped around the FMUs' Python: the whole
    ``do_step``, the model's ``step``, the model's ``outputs`` with their range checks and port writes
    (``_write_outputs``).  What ``do_step`` spends besides those is the lifecycle and input range checks;
    what the master's time holds besides ``do_step`` is the FMI call itself (ctypes, the shim, pythonfmu) and the
    master's port moves.  Everything comes from the one timed run (the timers add about 1 us per FMU step, in
    the parts they wrap), means over the run.

    Returns
    -------
    dict
        ``{fmu: {"total", "fmi_call_and_ports", "checks", "model_step", "outputs"}}``.
    """
    import gc
    import time

    sc = dataclasses.replace(get_scenario(scenario), estimator_profile=1)
    comps, conns = scenario_components(sc, [FIVE_FMU_LOOP[0]], FIVE_FMU_LOOP[1])
    spent: dict[str, dict[str, float]] = {}
    clock = time.perf_counter

    def timed(key, fn, fmu):
        acc = spent.setdefault(fmu, {})

        def wrapper(*args, **kw):
            t0 = clock()
            try:
                return fn(*args, **kw)
            finally:
                acc[key] = acc.get(key, 0.0) + clock() - t0
        return wrapper

    with CoSimulation(comps, conns, step=1e-3, fmu_dir=fmu_dir) as sim:
        # the loop's slave objects (a freed instance kept for reuse has no model, and is not stepped)
        slaves = [o for o in gc.get_objects() if type(o).__name__ in {c.fmu for c in comps}
                  and getattr(o, "model", None) is not None and hasattr(o, "do_step")]
        for slave in slaves:
            fmu, model = type(slave).__name__, slave.model
            slave.do_step = timed("do_step", slave.do_step, fmu)
            slave._write_outputs = timed("outputs", slave._write_outputs, fmu)
            model.step = timed("model_step", model.step, fmu)
            model.outputs = timed("outputs", model.outputs, fmu)
        n = int(round(duration / 1e-3))
        prof = sim.run(duration, profile=True).meta["profile"]
    total = {c.fmu: sum(prof[c.name]) / len(prof[c.name]) for c in comps}       # mean: the parts are sums
    out = {}
    for fmu, t in total.items():
        acc = {k: v / n * 1e6 for k, v in spent.get(fmu, {}).items()}
        inner = acc.get("model_step", 0.0) + acc.get("outputs", 0.0)
        out[fmu] = {"total": t, "fmi_call_and_ports": max(t - acc.get("do_step", 0.0), 0.0),
                    "checks": max(acc.get("do_step", 0.0) - inner, 0.0), "model_step": acc.get("model_step", 0.0),
                    "outputs": acc.get("outputs", 0.0)}
    return out


def format_bench(b: dict) -> str:
    """Text table of :func:`run_bench` results."""
    lines = [f"benchmark: scenario {b['scenario']}, communication step {b['step'] * 1e3:g} ms, "
             f"{b['duration']:g} s simulated per measurement", "",
             f"{'FMU':24s} {'median us/step':>15s} {'p90 us/step':>12s} {'x floor':>8s}"]
    for name, m in b["fmus"].items():
        lines.append(f"{name:24s} {m['median_us']:15.1f} {m['p90_us']:12.1f} {m['x_floor']:8.2f}")
    lines += ["", f"(median over 100-step blocks, best of {len(next(iter(b['fmus'].values()))['all_run_medians_us'])} "
              f"runs; the floor is {FLOOR_FMU}'s {b['floor_us']:.1f} us in this run)", ""]
    cl = b["closed_loop"]
    lines.append(f"loop {' + '.join(cl['components'])}: {cl['us_per_step']:.1f} us/step = {cl['x_floor']:.1f}x "
                 f"the floor, {cl['real_time_factor']:.1f}x real time (best of {len(cl['all_real_time_factors'])})")
    five = b["five_fmu_loop"]
    lines += [f"five-FMU loop {' + '.join(five['components'])}: {five['us_per_step']:.1f} us/step, "
              f"{five['real_time_factor']:.1f}x real time (best of {len(five['all_real_time_factors'])}); "
              f"{five['x_floor']:.2f}x the floor measured beside it",
              "  per FMU in it, x the floor of the same 100-step blocks: "
              + ", ".join(f"{fmu} {x:.2f}" for fmu, x in five["x_floor_by_fmu"].items())]
    if b.get("instantiation_s"):
        lines += ["", "instantiation to the end of initialisation [s], median, fresh process each "
                  "(cold: the host has only fmpy; warm: SciPy already loaded)"]
        lines += [f"  {name:24s} cold {t['cold']:.3f}  warm {t['warm']:.3f}" for name, t in b["instantiation_s"].items()]
    if b.get("instructions_per_step"):
        lines += ["", "instructions per 1 ms step (callgrind, difference of two run lengths)"]
        lines += [f"  {name:34s} {n:12,.0f}" for name, n in b["instructions_per_step"].items()]
    return "\n".join(lines)
