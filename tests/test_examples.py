"""Every example runs (short durations) and returns sensible results."""
import functools
import re
import importlib.util
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow          # every test here runs whole scenarios in closed loop

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name):
    spec = importlib.util.spec_from_file_location(f"sideslip_example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_closed_loop_demo(tmp_path):
    out = load("closed_loop_demo").run(show_plot=False, duration=2.0, out_dir=tmp_path)
    assert (tmp_path / "sideslip.png").is_file() and out.metrics["summary"]["duration"] == pytest.approx(2.0)


def test_fmpy_closed_loop():
    res = load("fmpy_closed_loop").run(show_plot=False, duration=3.0)
    assert np.abs(res["plant.beta"]).max() > 0.005 and res["sensors.gps_fresh"].sum() == 30


def test_library_only():
    res = load("library_only").run(show_plot=False)
    # steady turn, body-fixed accelerometer: centripetal part plus gravity through the body roll
    phi = res["roll"][-1]
    expected = np.cos(phi) * res["vx"][-1] * res["yaw_rate"][-1] + np.sin(phi) * 9.81
    assert res["ay"][-1] == pytest.approx(expected, rel=0.01)
    assert res["vx"][-1] == pytest.approx(9.0, abs=0.05)
    # the estimator stepped next to the plant (its default, hardened profile): the offset learnt on the
    # straight, sideslip within 0.1 deg RMS and 0.2 deg at most on the circle (2.6 deg of true sideslip)
    assert -res["park.offset_ay"][-1] == pytest.approx(0.1, abs=0.02)
    on = res["time"] > 12.0
    err = res["park.beta_hat"][on] - res["beta"][on]
    assert np.sqrt(np.mean(err ** 2)) < np.radians(0.1) and np.max(np.abs(err)) < np.radians(0.2)
    assert res["park.valid"][on].all()


# ------------------------------------------------------------------------------ tuning studies
_TINY = {"training": (("fmvss126_suv_mu05_a5.0", {"maneuver_t_start": 0.5, "duration": 1.5}),),
         "training_seeds": (100,), "development": (("bench_dev_jturn_suv_ice", {"duration": 1.5}),),
         "development_seeds": (200,), "dev_points": 1, "progress": False}


def test_tune_lqr_runs_on_a_process_pool_and_writes_the_chosen_point(tmp_path, fmu_dir):
    s = load("tune_lqr").run(tmp_path / "study", trials=2, workers=2, fmu_dir=fmu_dir, **_TINY)
    assert s["trials"] == 2 and s["workers"] == 2 and s["sim_seconds"] == 3.0
    assert {Path(f).name for f in s["files"]} == {"chosen.json", "chosen.ssv", "trials.csv", "pareto.png"}


def test_tune_lqr_runs_on_a_local_dask_cluster(tmp_path, fmu_dir):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
            distributed.Client(cl) as client:
        s = load("tune_lqr").run(tmp_path / "study", trials=2, scheduler=client, fmu_dir=fmu_dir, **_TINY)
    assert s["trials"] == 2 and s["sim_seconds"] == 3.0 and s["workers"].startswith("dask")


def test_tune_estimator_improves_the_training_objective(fmu_dir):
    out = load("tune_estimator").run(estimator="LinearBicycleObserver", names=("q_beta",), train=("pi2011_high",),
                                     test=("pi2011_medium",), max_evaluations=4, duration=4.0, workers=1,
                                     fmu_dir=fmu_dir)
    assert out["evaluations"] >= 2
    assert out["after"]["pi2011_high"] <= out["before"]["pi2011_high"]
    assert set(out["after"]) == {"pi2011_high", "pi2011_medium"}


def test_compare_masters(tmp_path, fmu_dir, monkeypatch):
    pytest.importorskip("libcosimpy")
    module = load("compare_masters")
    monkeypatch.setattr(module, "run_scenario", functools.partial(module.run_scenario, fmu_dir=fmu_dir))
    monkeypatch.setattr(module, "run_libcosim", functools.partial(module.run_libcosim, fmu_dir=fmu_dir))
    monkeypatch.setattr(module, "export_ssp", functools.partial(module.export_ssp, fmu_dir=fmu_dir))
    out = module.run(duration=0.5, out_dir=tmp_path)
    assert out["libcosim vs fmpy (jacobi)"]["max_scaled"] <= 1e-9
    assert out["libcosim on SSP vs fmpy (jacobi)"]["max_scaled"] <= 1e-9
    assert out["ssp"].is_file()


def test_the_notebook_runs_a_closed_loop_and_a_replay(fmu_dir, tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    nb = nbformat.read(EXAMPLES / "closed_loop_and_replay.ipynb", as_version=4)
    for cell in nb.cells:                   # the committed outputs are an earlier run's: run it afresh
        if cell.cell_type == "code":
            cell.outputs = []
    monkeypatch.setenv("SIDESLIP_FMU_DIR", str(fmu_dir))
    nbclient.NotebookClient(nb, timeout=900, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    text = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
    rms = {name: float(v) for name, v in re.findall(r"(fusion|pi) sideslip RMS error ([0-9.]+) deg", text)}
    assert rms["fusion"] < 0.2 and rms["pi"] < 1.0
    assert "vx stands in" in text and "| SideslipFusion |" in text
    assert any("image/png" in o.get("data", {}) for o in nb.cells[-1].outputs)      # the replay's plot


def test_getting_started_shows_what_the_demo_prints(fmu_dir, tmp_path, capsys):
    from sideslip.cli import main

    page = (EXAMPLES.parent / "docs" / "getting-started.md").read_text()
    shown = page.split("```text\n", 1)[1].split("```", 1)[0].splitlines()
    assert main(["--fmu-dir", str(fmu_dir), "demo", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out.splitlines()
    timing = re.compile(r"us per step|real time")
    assert [ln for ln in shown if not timing.search(ln)] == [ln for ln in printed[:len(shown)]
                                                             if not timing.search(ln)]
