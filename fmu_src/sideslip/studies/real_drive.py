"""A real drive as benchmark cases: 420 s of a light car driven hard on a track, with INS-measured sideslip.

The data (``studies/data/stanford2014``, MIT licence, its ``LICENSE`` beside it) are the public dataset
``20140222_01_01_03_250lm`` of the repository ``MBDS/sideslip-angle-vehicle-estimation`` (cite: Leanza,
Reina, Blanco-Claraco, "A Factor-Graph-Based Approach to Vehicle Sideslip Angle Estimation", Sensors
21(16) 5409, 2021): from t = 280 s to the end at 100 Hz, the INS's velocity and sideslip (the
reference), the road-wheel angle, the yaw rate and the accelerations (ISO 8855 signs).  The
recording's t = 150-280 s are held out for an outside check and are not here.

What the log lacks is derived, honestly and with a seed, by the project's sensor models
(:class:`~sideslip.plant.sensors.SensorSuite` with the ``sensors`` condition's draws,
:func:`~sideslip.studies.accuracy.sensor_errors`) from what the log has:

* **wheel speeds** - each wheel's free-rolling spin from the INS velocity and the logged yaw rate at
  its contact point (front wheels in the steered axes), on the vehicle file's rolling radius: no drive
  or brake slip, which the log cannot give;
* **GNSS velocity** - the INS velocity turned into east and north by a heading integrated from the
  logged yaw rate: the heading has no truth in the log, so the GNSS course turns exactly as the logged
  gyro does and cannot reveal that gyro's offset (the estimators' gyro-offset states see none);
* **magnetometer** - the Earth field at that heading and a level body (the log has no roll).

The logged IMU and steering are used as they are (their own noise and offsets, unknown); the roll rate
is zero.  The drive is split by time into three disjoint slices: :data:`SLICES` (training,
development and test).
"""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..params import build
from ..plant.sensors import SensorConfig, SensorSuite
from ..recording import Recording
from ..signals import SENSOR_INPUTS, SENSOR_OUTPUTS
from ..vehicles import load_vehicle

__all__ = ["DATA", "VEHICLE", "SLICES", "REAL", "is_real_drive", "real_drive"]

DATA = Path(__file__).resolve().parent / "data" / "stanford2014" / "drive_280_700s.csv"
VEHICLE = "stanford_track_car"
"""The bundled vehicle file of the car (its dataset's parameters, the rest assumed)."""
REAL = "real"
"""The condition of a real-drive case: the logged IMU and steering, the derived sensors drawn by its seed."""
SLICES = {"stanford2014_train": (280.0, 420.0), "stanford2014_dev": (420.0, 560.0),
          "stanford2014_test": (560.0, 700.0)}
"""Real-drive slices by name: time span of the recording [s]."""

_LOGGED = {"ax_m": "ax", "ay_m": "ay", "yaw_rate_m": "yaw_rate", "delta_m": "delta"}


def is_real_drive(name: str) -> bool:
    """Whether ``name`` is a real-drive slice of :data:`SLICES`."""
    return name in SLICES


@lru_cache(maxsize=1)
def _log() -> dict:
    data = np.genfromtxt(DATA, delimiter=",", names=True)
    return {name: np.asarray(data[name], dtype=float) for name in data.dtype.names}


def real_drive(name: str, sensors: dict, step: float = 0.01) -> Recording:
    """A real-drive slice (:data:`SLICES`) with its derived sensors (module docstring).

    Parameters
    ----------
    name : str
        The slice.
    sensors : dict
        :class:`~sideslip.plant.sensors.SensorConfig` values of the derived sensors (seed, GNSS rate, delay and
        noise, wheel-speed noise and radius error, magnetometer).
    step : float
        Sample step [s]: the log's 10 ms.
    """
    t0, t1 = SLICES[name]
    log = _log()
    keep = (log["time"] >= t0 - 1e-9) & (log["time"] <= t1 + 1e-9)
    t = log["time"][keep]
    vx, vy, r, delta = log["vx"][keep], log["vy"][keep], log["yaw_rate"][keep], log["delta"][keep]
    v = load_vehicle(VEHICLE)
    half_f, half_r, radius = 0.5 * v.t_f, 0.5 * v.t_r, v.R_w
    # free-rolling spins at the contact points, the front ones in the steered wheels' axes
    vyf = vy + v.l_f * r
    spins = ((((vx - half_f * r) * np.cos(delta) + vyf * np.sin(delta)) / radius),
             (((vx + half_f * r) * np.cos(delta) + vyf * np.sin(delta)) / radius),
             (vx - half_r * r) / radius, (vx + half_r * r) / radius)
    yaw = np.concatenate(([0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * np.diff(t))))
    yaw = np.pi - np.mod(np.pi - yaw, 2.0 * np.pi)
    zero = np.zeros_like(t)
    truth = {"ax": log["ax"][keep], "ay": log["ay"][keep], "yaw_rate": r, "roll_rate": zero, "delta_f": delta,
             "omega_fl": spins[0], "omega_fr": spins[1], "omega_rl": spins[2], "omega_rr": spins[3],
             "vx": vx, "vy": vy, "yaw": yaw, "roll": zero}
    suite = SensorSuite(build(SensorConfig, sensors))
    inputs = np.column_stack([truth[nm] for nm in SENSOR_INPUTS]).tolist()
    out = np.empty((len(t), len(SENSOR_OUTPUTS)))
    out[0] = suite.outputs()
    for k in range(1, len(t)):
        suite.step(float(t[k] - t[k - 1]), *inputs[k])
        out[k] = suite.outputs()
    signals = {nm: out[:, i] for i, nm in enumerate(SENSOR_OUTPUTS)}
    for contract, column in _LOGGED.items():         # the car's own sensors, as logged
        signals[contract] = log[column][keep].copy()
    signals["mu"] = np.ones_like(t)
    reference = {"beta": log["beta"][keep], "vx": vx, "vy": vy, "yaw_rate": r, "ay": log["ay"][keep]}
    rec = Recording(t - t[0], signals, reference, name)
    if not math.isclose(float(np.median(np.diff(t))), step, rel_tol=1e-6):
        rec = rec.on_grid(step)
    return rec
