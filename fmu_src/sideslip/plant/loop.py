"""Library-only closed loop of driver, plant, sensors, estimators and a controller, without FMI.

Same semantics as the fmpy master: Gauss-Seidel in the order driver, plant, sensors, then the
models of the chain (estimators, controller), each model taking its inputs by contract name from
the latest outputs of the others; inputs nobody provides keep their catalogue start value (e.g.
the plant's ``Mz_dyc`` without a controller), as an FMU's unconnected inputs do.  FMU and library
runs of a scenario can therefore be compared sample for sample.
"""
from __future__ import annotations

import numpy as np

from ..signals import SIGNALS
from .driver import Driver
from .sensors import SensorSuite
from .vehicle import VehiclePlant

__all__ = ["run_loop"]


def run_loop(plant: VehiclePlant, driver: Driver, duration: float, step: float = 1e-3,
             sensors: SensorSuite | None = None, observers: dict | None = None, chain=(),
             links: dict | None = None, until_failure: bool = False) -> dict[str, np.ndarray]:
    """Simulate ``duration`` [s] at communication step ``step`` [s].

    Parameters
    ----------
    observers : dict of name -> model, optional
        Models stepped after the sensors that only consume signals (estimators): their
        outputs are recorded as ``"<name>.<output>"`` and fed to nobody.
    chain : sequence of (name, model, wiring)
        Models stepped after the sensors (and before the observers), in order, whose outputs
        feed the loop as ``"<name>.<output>"``: an estimator, then a controller.  ``wiring`` maps
        an input to the key that feeds it (e.g. ``{"beta_hat": "plant.beta"}`` or
        ``{"beta_hat": "est.beta_hat"}``); other inputs read the output of their own name.
    links : dict, optional
        The same for the driver, plant and sensors, e.g. ``{"Mz_dyc": "controller.Mz_cmd"}``.
    until_failure : bool
        A model's ``ValueError`` in a step (a plant's state it has no answer for) ends the run there: the arrays
        stop at the last complete sample and ``"failure"`` holds the message (otherwise the error propagates).

    Returns
    -------
    dict
        ``"time"`` and every output of the driver, plant, sensors, chain and observers (arrays
        of length ``n + 1``, sample 0 being the initial outputs).
    """
    models = [m for m in (driver, plant, sensors) if m is not None]
    observers = observers or {}
    links = links or {}
    names = [nm for m in models for nm in m.output_names]
    if len(set(names)) != len(names):  # pragma: no cover - the catalogue keeps them distinct
        raise RuntimeError("output names of the models overlap")
    n = int(round(duration / step))
    latest: dict[str, float] = {}
    for m in models:
        latest.update(m.output_dict())
    for key, m, _ in chain:
        latest.update({f"{key}.{nm}": y for nm, y in zip(m.output_names, m.outputs())})
    plant_keys = [f"plant.{nm}" for nm in plant.output_names] if chain else None   # truth for a chain
    if plant_keys:
        latest.update(zip(plant_keys, plant.outputs()))
    start = {nm: s.start for nm, s in SIGNALS.items()}
    base = [(m, [links.get(nm, nm) for nm in m.input_names]) for m in models]
    steps = [(key, m, [wiring.get(nm, nm) for nm in m.input_names]) for key, m, wiring in chain]
    chain_names = [f"{key}.{nm}" for key, m, _ in chain for nm in m.output_names]
    obs_names = [f"{key}.{nm}" for key, m in observers.items() for nm in m.output_names]
    rec = np.empty((n + 1, len(names) + len(chain_names) + len(obs_names)))

    def row():
        return ([latest[nm] for nm in names] + [latest[nm] for nm in chain_names]
                + [y for m in observers.values() for y in m.outputs()])

    rec[0] = row()
    failure = None
    for k in range(n):
        try:
            _advance(step, latest, start, base, steps, observers, plant, plant_keys)
        except ValueError as exc:
            if not until_failure:
                raise
            failure, n = str(exc), k
            rec = rec[:k + 1]
            break
        rec[k + 1] = row()
    out = {nm: rec[:, i] for i, nm in enumerate(names + chain_names + obs_names)}
    out["time"] = np.arange(n + 1) * step
    if failure is not None:
        out["failure"] = failure
    return out


def _advance(step, latest, start, base, steps, observers, plant, plant_keys) -> None:
    """One communication step of every model, Gauss-Seidel (see :func:`run_loop`)."""
    for m, keys in base:
        m.step(step, *(latest.get(key, start.get(key, 0.0)) for key in keys))
        latest.update(zip(m.output_names, m.outputs()))
        if m is plant and plant_keys:
            latest.update(zip(plant_keys, m.outputs()))
    for key, m, keys in steps:
        m.step(step, *(latest.get(k2, start.get(k2.rpartition(".")[2], 0.0)) for k2 in keys))
        latest.update(zip((f"{key}.{nm}" for nm in m.output_names), m.outputs()))
    for m in observers.values():
        m.step(step, *(latest.get(nm, 0.0) for nm in m.input_names))
