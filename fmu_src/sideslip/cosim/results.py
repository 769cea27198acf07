"""Recorded co-simulation results, shared by every master."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["Results"]


@dataclass
class Results:
    """Recorded co-simulation: structured array ``data`` and run metadata ``meta``."""

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

    @property
    def names(self) -> tuple:
        return self.data.dtype.names

    def keys(self) -> tuple:
        """Field names (so that a Results reads like a mapping of arrays)."""
        return self.data.dtype.names

    def to_csv(self, path: str | Path) -> None:
        """Write all fields as CSV (Booleans as 0/1)."""
        cols = [self.data[n].astype(float) for n in self.names]
        np.savetxt(path, np.column_stack(cols), delimiter=",", header=",".join(self.names), comments="",
                   fmt="%.17g")          # exact round trip: a log replays to the same estimates
