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
             sensors: SensorSuite | None = None, observers: dict | None = None) -> dict[str, np.ndarray]:
    """Simulate ``duration`` [s] at communication step ``step`` [s].

    Parameters
    ----------
    observers : dict of name -> model, optional
        Models stepped after the sensors that only consume signals (estimators): their
        outputs are recorded as ``"<name>.<output>"`` and fed to nobody.

    Returns
    -------
    dict
        ``"time"`` and every output of the driver, plant, sensors and observers (arrays of
        length ``n + 1``, sample 0 being the initial outputs).
    """
    models = [m for m in (driver, plant, sensors) if m is not None]
    observers = observers or {}
    names = [nm for m in models for nm in m.output_names]
    if len(set(names)) != len(names):  # pragma: no cover - the catalogue keeps them distinct
        raise RuntimeError("output names of the models overlap")
    n = int(round(duration / step))
    latest: dict[str, float] = {}
    for m in models:
        latest.update(m.output_dict())
    obs_names = [f"{key}.{nm}" for key, m in observers.items() for nm in m.output_names]
    rec = np.empty((n + 1, len(names) + len(obs_names)))

    def row():
        return [latest[nm] for nm in names] + [y for m in observers.values() for y in m.outputs()]

    rec[0] = row()
    for k in range(n):
        for m in models:
            m.step(step, *(latest.get(nm, 0.0) for nm in m.input_names))
            latest.update(zip(m.output_names, m.outputs()))
        for m in observers.values():
            m.step(step, *(latest.get(nm, 0.0) for nm in m.input_names))
        rec[k + 1] = row()
    out = {nm: rec[:, i] for i, nm in enumerate(names + obs_names)}
    out["time"] = np.arange(n + 1) * step
    return out
