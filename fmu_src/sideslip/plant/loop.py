"""Library-only closed loop of driver, plant and (optionally) sensors, without FMI.

Same semantics as the fmpy master: Gauss-Seidel in the order driver, plant, sensors, each
model taking its inputs by contract name from the latest outputs of the others (inputs
nobody provides stay at 0, e.g. the plant's ``Mz_dyc`` without a controller).  FMU and
library runs of a scenario can therefore be compared sample for sample.
"""
from __future__ import annotations

import numpy as np

from .driver import Driver
from .sensors import SensorSuite
from .vehicle import VehiclePlant

__all__ = ["run_loop"]


def run_loop(plant: VehiclePlant, driver: Driver, duration: float, step: float = 1e-3,
             sensors: SensorSuite | None = None) -> dict[str, np.ndarray]:
    """Simulate ``duration`` [s] at communication step ``step`` [s].

    Returns
    -------
    dict
        ``"time"`` and every output of the driver, plant and sensors (arrays of length
        ``n + 1``, sample 0 being the initial outputs).
    """
    models = [m for m in (driver, plant, sensors) if m is not None]
    names = [nm for m in models for nm in m.output_names]
    if len(set(names)) != len(names):  # pragma: no cover - the catalogue keeps them distinct
        raise RuntimeError("output names of the models overlap")
    n = int(round(duration / step))
    latest: dict[str, float] = {}
    for m in models:
        latest.update(m.output_dict())
    rec = np.empty((n + 1, len(names)))
    rec[0] = [latest[nm] for nm in names]
    for k in range(n):
        for m in models:
            m.step(step, *(latest.get(nm, 0.0) for nm in m.input_names))
            latest.update(zip(m.output_names, m.outputs()))
        rec[k + 1] = [latest[nm] for nm in names]
    out = {nm: rec[:, i] for i, nm in enumerate(names)}
    out["time"] = np.arange(n + 1) * step
    return out
