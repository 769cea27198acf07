"""Registry of the project's FMUs: every ``*_fmu.py`` wrapper in ``plant_fmus/`` and ``fmu_src/``.

A wrapper module defines one :class:`~sideslip.fmi.slave.SideslipSlave` subclass whose class
name is the FMU name and whose ``role`` is one of ``plant, sensors, driver, estimator,
controller``.  Dropping a new wrapper file in is the whole registration: the builder and
the co-simulation master find it here.
"""
from __future__ import annotations

import importlib.util
import inspect
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

__all__ = ["FmuEntry", "REPO_ROOT", "PACKAGE_DIR", "fmu_entries", "fmu_entry", "fmu_names"]

PACKAGE_DIR = Path(__file__).resolve().parents[1]
REPO_ROOT = PACKAGE_DIR.parents[1]
WRAPPER_DIRS = (REPO_ROOT / "plant_fmus", REPO_ROOT / "fmu_src")
ROLES = ("driver", "plant", "sensors", "estimator", "controller")


@dataclass(frozen=True)
class FmuEntry:
    """One FMU of the project."""

    name: str          #: FMU (model identifier) name, e.g. ``VehiclePlant``
    role: str          #: plant, sensors, driver, estimator or controller
    script: Path       #: the wrapper module file
    slave_class: type  #: the wrapper class

    @property
    def inputs(self) -> tuple:
        return tuple(self.slave_class.model_class.input_names)

    @property
    def outputs(self) -> tuple:
        return tuple(self.slave_class.model_class.output_names)


def _load(path: Path):
    from .slave import SideslipSlave

    name = path.stem
    module = sys.modules.get(name)
    if module is None or getattr(module, "__file__", None) != str(path):
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    classes = [c for _, c in inspect.getmembers(module, inspect.isclass)
               if issubclass(c, SideslipSlave) and c is not SideslipSlave and c.__module__ == name]
    if len(classes) != 1:
        raise RuntimeError(f"{path} must define exactly one SideslipSlave subclass, found {classes}")
    cls = classes[0]
    role = getattr(cls, "role", None)
    if role not in ROLES:
        raise RuntimeError(f"{path}: class {cls.__name__} has role {role!r}, expected one of {ROLES}")
    return FmuEntry(cls.__name__, role, path, cls)


@lru_cache(maxsize=1)
def fmu_entries() -> dict[str, FmuEntry]:
    """All FMUs by name (wrappers are imported once)."""
    entries = {}
    for folder in WRAPPER_DIRS:
        for path in sorted(folder.glob("*_fmu.py")):
            entry = _load(path.resolve())
            if entry.name in entries:
                raise RuntimeError(f"duplicate FMU name {entry.name} in {path} and {entries[entry.name].script}")
            entries[entry.name] = entry
    return entries


def fmu_entry(name: str) -> FmuEntry:
    """Entry of FMU ``name``.

    Raises
    ------
    KeyError
        Listing the known FMU names.
    """
    entries = fmu_entries()
    if name not in entries:
        raise KeyError(f"unknown FMU {name!r}; known: {', '.join(sorted(entries))}")
    return entries[name]


def fmu_names(role: str | None = None) -> list[str]:
    """Names of all FMUs, or of those with ``role``."""
    return sorted(n for n, e in fmu_entries().items() if role is None or e.role == role)
