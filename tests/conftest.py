"""Shared fixtures: a fresh build of every FMU per session and an fmpy harness by variable name."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sideslip.fmi.build import build_fmus
from sideslip.fmi.catalogue import HELD_OUTPUT
from sideslip.fmi.variables import fmi_value


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    """Every registered FMU, built from scratch into a session folder (exercises the builder)."""
    out = tmp_path_factory.mktemp("fmus")
    build_fmus(None, out, force=True, log=lambda msg: None)
    return out


class FmuHarness:
    """One FMU instance driven through fmpy by variable name, collecting log messages."""

    def __init__(self, path: Path, instance: str = "inst", logging: bool = False):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
        from fmpy.fmi2 import fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE
        from fmpy import calloc, free

        self.md = read_model_description(str(path))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.unzip = extract(str(path))
        self.messages: list[tuple[int, str]] = []
        self.categories: list[str] = []

        def logger(env, name, status, category, message):
            self.messages.append((status, message.decode() if message else ""))
            self.categories.append(category.decode() if category else "")

        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(logger)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._cb = cb
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzip,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=instance)
        self.fmu.instantiate(callbacks=cb, loggingOn=logging)
        self.t = 0.0

    def set(self, **values):
        for name, value in values.items():
            v = self.vars[name]
            getattr(self.fmu, f"set{v.type}")([v.valueReference], [fmi_value(v.type, value, name)])

    def get(self, *names):
        out = []
        for name in names:
            v = self.vars[name]
            value = getattr(self.fmu, f"get{v.type}")([v.valueReference])[0]
            out.append(float(value) if v.type == "Boolean" else value)
        return out

    def outputs(self):
        """The model's outputs (every output but the toolkit's ``inputs_held``), in order."""
        names = [v.name for v in self.md.modelVariables if v.causality == "output" and v.name != HELD_OUTPUT]
        return self.get(*names)

    def init(self, **params):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.set(**params)
        self.fmu.exitInitializationMode()

    def step(self, h=1e-3, **inputs):
        self.set(**inputs)
        status = self.fmu.fmi2DoStep(self.fmu.component, self.t, h, 1)
        self.t += h
        return status

    def close(self):
        from fmpy.fmi1 import FMICallException

        try:
            self.fmu.terminate()
        except FMICallException:            # not initialised: fmi2Terminate is refused in that state
            pass
        finally:
            self.fmu.fmi2FreeInstance(self.fmu.component)


@pytest.fixture
def harness(fmu_dir):
    """Factory of FMU harnesses, freed at the end of the test."""
    made = []

    def make(name: str, instance: str = "inst", logging: bool = False) -> FmuHarness:
        h = FmuHarness(fmu_dir / f"{name}.fmu", instance, logging)
        made.append(h)
        return h

    yield make
    for h in made:
        h.close()


def assert_save_restore_repeats(fmu: FmuHarness, drive) -> None:
    """Save the FMU state, run ``drive()``, restore it (directly and through serialisation) and
    assert that ``drive()`` returns the same outputs again."""
    state = fmu.fmu.getFMUstate()
    blob = fmu.fmu.serializeFMUstate(state)
    t = fmu.t
    first = drive()
    fmu.fmu.setFMUstate(state)
    fmu.t = t
    assert drive() == first
    fmu.fmu.setFMUstate(fmu.fmu.deSerializeFMUstate(blob))
    fmu.t = t
    assert drive() == first
    fmu.fmu.freeFMUstate(state)


def finite(values) -> bool:
    return all(math.isfinite(v) for v in values if isinstance(v, float))


def numeric_jacobian(f, x, eps=1e-6):
    """Central differences of ``f`` at ``x``, each state's step ``eps`` times its size (at least ``eps``)."""
    x = np.asarray(x, dtype=float)
    cols = []
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = eps * max(1.0, abs(x[i]))
        cols.append((np.asarray(f(x + d)) - np.asarray(f(x - d))) / (2 * d[i]))
    return np.column_stack(cols)
