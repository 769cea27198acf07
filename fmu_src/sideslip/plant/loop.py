"""Library-only closed loop of driver, plant, sensors, estimators and a controller, without FMI.

Same semantics as the fmpy master: Gauss-Seidel in the order driver, plant, sensors, then the
models of the chain (estimators, controller), each model taking its inputs by contract name from
the latest outputs of the others; inputs nobody provides keep their catalogue start value (e.g.
the plant's ``Mz_dyc`` without a controller), as an FMU's unconnected inputs do.  FMU and library
runs of a scenario can therefore be compared sample for sample.
"""
from __future__ import annotations

from operator import itemgetter

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
    for m in (*models, *(m for _, m, _ in chain)):   # slices of the slot list are written with a model's outputs
        if len(m.outputs()) != len(m.output_names):
            raise RuntimeError(f"{type(m).__name__}: {len(m.outputs())} outputs for {len(m.output_names)} names")
    links = links or {}
    names = [nm for m in models for nm in m.output_names]
    if len(set(names)) != len(names):  # pragma: no cover - the catalogue keeps them distinct
        raise RuntimeError("output names of the models overlap")
    n = int(round(duration / step))
    # every signal has a slot in one flat list: the outputs of the driver, plant, sensors and chain first (in the
    # order recorded), the plant's truth for a chain, then one constant slot per input nobody provides (its start)
    chain_names = [f"{key}.{nm}" for key, m, _ in chain for nm in m.output_names]
    plant_keys = [f"plant.{nm}" for nm in plant.output_names] if chain else []     # truth for a chain
    keys = names + chain_names + plant_keys
    slots = {key: i for i, key in enumerate(keys)}
    values = [*(y for m in models for y in m.outputs()), *(y for _, m, _ in chain for y in m.outputs()),
              *(plant.outputs() if plant_keys else ())]
    start = {nm: s.start for nm, s in SIGNALS.items()}

    def reader(wanted, default):
        """A function of the slots returning the values of ``wanted`` keys (``default(key)`` if nobody provides
        one) as a tuple."""
        idx = []
        for key in wanted:
            if key not in slots:
                slots[key] = len(values)
                values.append(default(key))
            idx.append(slots[key])
        get = itemgetter(*idx) if idx else (lambda _: ())
        return get if len(idx) != 1 else (lambda v, g=get: (g(v),))

    stages, at = [], 0
    for m in models:
        ins = reader([links.get(nm, nm) for nm in m.input_names], lambda key: start.get(key, 0.0))
        end = at + len(m.output_names)
        truth = (len(names) + len(chain_names), len(keys)) if m is plant and plant_keys else None
        stages.append((m, ins, at, end, truth))
        at = end
    for key, m, wiring in chain:
        ins = reader([wiring.get(nm, nm) for nm in m.input_names],
                     lambda k2: start.get(k2.rpartition(".")[2], 0.0))
        end = at + len(m.output_names)
        stages.append((m, ins, at, end, None))
        at = end
    watchers = [(m, reader(list(m.input_names), lambda key: 0.0)) for m in observers.values()]
    obs_names = [f"{key}.{nm}" for key, m in observers.items() for nm in m.output_names]
    recorded = len(names) + len(chain_names)
    rec = np.empty((n + 1, recorded + len(obs_names)))

    def record(k):
        rec[k, :recorded] = values[:recorded]
        if watchers:
            rec[k, recorded:] = [y for m, _ in watchers for y in m.outputs()]

    record(0)
    failure = None
    for k in range(n):
        try:
            _advance(step, values, stages, watchers)
        except ValueError as exc:
            if not until_failure:
                raise
            failure, n = str(exc), k
            rec = rec[:k + 1]
            break
        record(k + 1)
    out = {nm: rec[:, i] for i, nm in enumerate(names + chain_names + obs_names)}
    out["time"] = np.arange(n + 1) * step
    if failure is not None:
        out["failure"] = failure
    return out


def _advance(step, values, stages, watchers) -> None:
    """One communication step of every model, Gauss-Seidel (see :func:`run_loop`)."""
    for m, ins, a, b, truth in stages:
        m.step(step, *ins(values))
        values[a:b] = m.outputs()
        if truth is not None:
            values[truth[0]:truth[1]] = values[a:b]
    for m, ins in watchers:
        m.step(step, *ins(values))
