"""Library-only closed loop of driver, plant and (optionally) sensors, without FMI.

Same execution order and step semantics as the fmpy master (Gauss-Seidel: driver, plant,
sensors), so library runs and FMU runs of a scenario can be compared sample for sample.
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
    n = int(round(duration / step))
    names = list(driver.output_names) + list(plant.output_names) + (
        list(sensors.output_names) if sensors else [])
    names = list(dict.fromkeys(names))   # driver and plant share no names; keep order
    rec = np.empty((n + 1, len(names)))
    plant_out = plant.output_dict()

    def record(k):
        row = {**driver.output_dict(), **plant.output_dict(), **(sensors.output_dict() if sensors else {})}
        rec[k] = [row[nm] for nm in names]

    record(0)
    plant_inputs = {name: 0.0 for name in plant.input_names}
    for k in range(n):
        driver.step(step, *(plant_out[nm] for nm in driver.input_names))
        for nm, val in driver.output_dict().items():      # connect by contract name
            if nm in plant_inputs:
                plant_inputs[nm] = val
        plant.step(step, **plant_inputs)
        plant_out = plant.output_dict()
        if sensors is not None:
            sensors.step(step, *(plant_out[nm] for nm in sensors.input_names))
        record(k + 1)
    out = {nm: rec[:, i] for i, nm in enumerate(names)}
    out["time"] = np.arange(n + 1) * step
    return out
