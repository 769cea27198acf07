"""Every example runs (short durations) and returns sensible results."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

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
    res = load("library_only").run(show_plot=False, duration=20.0)
    # steady turn, body-fixed accelerometer: centripetal part plus gravity through the body roll
    phi = res["roll"][-1]
    expected = np.cos(phi) * res["vx"][-1] * res["yaw_rate"][-1] + np.sin(phi) * 9.81
    assert res["ay"][-1] == pytest.approx(expected, rel=0.01)
    assert res["vx"][-1] == pytest.approx(9.0, abs=0.05)
    # the estimator stepped next to the plant: offset found, sideslip within 0.1 deg on the circle
    assert -res["park.offset_ay"][-1] == pytest.approx(0.1, abs=0.02)
    on = res["time"] > 6.0
    assert np.max(np.abs(res["park.beta_hat"][on] - res["beta"][on])) < np.radians(0.1)
