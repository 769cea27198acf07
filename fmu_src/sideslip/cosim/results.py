"""Recorded co-simulation results, shared by every master, and their ways into other tools.

Every recorded field is ``<instance>.<port>`` (or ``time``); its unit is the port's in the signal
catalogue (:data:`sideslip.signals.SIGNALS`: SI, Booleans ``1``), so a result carries its units
wherever it goes: ``Results.units``, a pandas DataFrame's ``attrs["units"]``, a ``# units:`` line in
the CSV header and a JSON sidecar, the channels' units in an MDF4 file.
"""
from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["Results", "unit_of_field"]


def unit_of_field(name: str) -> str:
    """The unit of a recorded field ``<instance>.<port>`` by the signal catalogue (``""`` when it has none)."""
    from ..signals import SIGNALS

    if name == "time":
        return "s"
    sig = SIGNALS.get(name.rsplit(".", 1)[-1])
    if sig is None:
        return ""
    return sig.unit if sig.kind == "Real" else "1"


@dataclass(eq=False)
class Results(Mapping):
    """Recorded co-simulation: structured array ``data`` and run metadata ``meta``.

    It is a mapping of field names to arrays (``res["plant.beta"]``, ``res.keys()``, ``dict(res)``; ``len(res)``
    fields): ``pandas.DataFrame(dict(res))`` works, and :meth:`to_pandas` adds the units and the time index
    (pandas' constructor takes a ``dict``, not any mapping).
    """

    data: np.ndarray
    meta: dict

    @classmethod
    def from_columns(cls, columns: dict, meta: dict) -> "Results":
        """Results of equally long columns by name (``time`` first; Boolean arrays stay Boolean)."""
        arrays = {name: np.asarray(values) for name, values in columns.items()}
        n = len(arrays["time"])
        data = np.empty(n, dtype=[(name, bool if a.dtype == bool else float) for name, a in arrays.items()])
        for name, a in arrays.items():
            data[name] = a
        return cls(data, meta)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.data[name]

    def __contains__(self, name) -> bool:
        return name in self.data.dtype.names

    def __len__(self) -> int:
        return len(self.data.dtype.names)

    def __iter__(self):
        return iter(self.data.dtype.names)

    @property
    def names(self) -> tuple:
        return self.data.dtype.names

    def keys(self) -> tuple:
        """Field names."""
        return self.data.dtype.names

    @property
    def units(self) -> dict:
        """``{field: unit}`` of every field (:func:`unit_of_field`)."""
        return {name: unit_of_field(name) for name in self.names}

    def window(self, t0: float = -np.inf, t1: float = np.inf) -> "Results":
        """The samples with ``t0 <= time <= t1`` [s] (the same metadata, its ``window`` noted).

        Raises
        ------
        ValueError
            When the window holds fewer than two samples, naming the recorded span.
        """
        t = self.data["time"]
        keep = (t >= t0) & (t <= t1)
        if keep.sum() < 2:
            raise ValueError(f"window {t0:g}:{t1:g} s holds fewer than two samples; the run covers "
                             f"{t[0]:g} to {t[-1]:g} s")
        return Results(self.data[keep], {**self.meta, "window": [float(t0), float(t1)]})

    def to_pandas(self):
        """A pandas DataFrame indexed by ``time`` [s], one column per field, the units in ``attrs["units"]``
        and the run's metadata in ``attrs["meta"]`` (pandas is an optional dependency: ``pip install pandas``)."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("Results.to_pandas needs pandas: pip install pandas (or sideslip-fmu[data])") from None
        frame = pd.DataFrame({name: self.data[name] for name in self.names if name != "time"},
                             index=pd.Index(self.data["time"], name="time"))
        frame.attrs["units"] = self.units
        frame.attrs["meta"] = self.meta
        return frame

    def to_csv(self, path: str | Path) -> Path:
        """Write all fields as CSV (Booleans as 0/1) and their units as ``<path>.units.json``.

        The header is the field names, so that the file reads back as a log
        (:func:`sideslip.recording.read_log`); the units go in the sidecar, a ``{field: unit}`` JSON.
        """
        path = Path(path)
        cols = [self.data[n].astype(float) for n in self.names]
        np.savetxt(path, np.column_stack(cols), delimiter=",", header=",".join(self.names), comments="",
                   fmt="%.17g")          # exact round trip: a log replays to the same estimates
        path.with_name(path.name + ".units.json").write_text(json.dumps(self.units, indent=1))
        return path

    def to_mdf(self, path: str | Path) -> Path:
        """Write all fields as an ASAM MDF4 file (``.mf4``), one channel per field with its unit, the run's
        components in the file comment (asammdf is an optional dependency: ``pip install asammdf``)."""
        try:
            from asammdf import MDF, Signal
        except ImportError:
            raise ImportError("Results.to_mdf needs asammdf: pip install asammdf (or sideslip-fmu[data])") from None
        t = self.data["time"]
        signals = [Signal(np.asarray(self.data[n], dtype=np.uint8 if self.data[n].dtype == bool else float), t,
                          name=n, unit=unit_of_field(n)) for n in self.names if n != "time"]
        mdf = MDF(version="4.10")
        mdf.append(signals, comment="sideslip-fmu results")
        mdf.header.comment = json.dumps({"master": self.meta.get("master"),
                                         "components": self.meta.get("components", [])})
        path = Path(path)
        mdf.save(path, overwrite=True)
        mdf.close()
        return path
