"""Recorded drives: contract signals over time, read from a CSV log or made by a simulation, replayed
into the library models.

A :class:`Recording` holds the time and the signals by their contract names (SI units, Booleans as
0/1) and, when the log has them, reference signals (``beta`` from an optical or INS sensor, or the
plant's truth).  :func:`read_log` reads a CSV log whose columns are either named by the contract
(a column ``ay_m`` in m/s2; an instance prefix such as ``sensors.ay_m`` is accepted) or mapped by a
TOML file::

    time = { column = "t_ms", unit = "ms" }
    [signals.ay_m]
    column = "AccY"
    unit = "g"
    [signals.yaw_rate_m]
    column = "GyroZ"
    unit = "deg/s"
    scale = -1.0            # the logger's z axis points down: si = value * unit factor * scale + offset
    [reference.beta]
    column = "Beta_Correvit"
    unit = "deg"

Units are SI, their display units (``deg``, ``deg/s``, ``km/h``, ``g``) or ``ms``, ``rpm``, ``mph``,
``mrad`` (:data:`sideslip.units.LOG_UNITS`).  When a log has no ``gps_fresh``, a fix is taken to
arrive whenever the GPS velocity changes (loggers repeat the held value between fixes); without
``gps_valid``, GPS is valid where its columns are finite.

:meth:`Recording.on_grid` resamples onto a uniform step by zero-order hold (a fix is fresh in the
first step it is held), and :func:`replay` steps a library model through it.  Bad logs fail with
a :class:`LogError` naming the column: a missing required column, time that does not increase,
NaN runs longer than ``max_gap``, values no vehicle reaches (wrong units).
"""
from __future__ import annotations

import csv
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .signals import SENSOR_OUTPUTS, SIGNALS
from .units import si_factor

__all__ = ["Recording", "LogError", "read_log", "write_log", "replay", "OPTIONAL_INPUTS", "LOGGED_INPUTS", "REFERENCES",
           "PLAUSIBLE"]

OPTIONAL_INPUTS = {"Mz_cmd": 0.0, "mu": 1.0, "mag_x": 0.0, "mag_y": 0.0, "mag_z": 0.0}
"""Inputs a log may lack, with the value used then: no stability controller, a dry road, no magnetometer (a zero
field, which every estimator takes as disturbed: Yoon 2014 never starts its heading and stays invalid,
SideslipFusion ignores it)."""

LOGGED_INPUTS = SENSOR_OUTPUTS + tuple(OPTIONAL_INPUTS)
"""Estimator inputs a log's columns are looked up for by contract name."""

REFERENCES = ("beta", "vx", "vy", "yaw_rate", "yaw", "roll", "ay")
"""Reference signals (an optical or INS sensor, a simulation's truth) looked up by contract name."""

PLAUSIBLE = {"Velocity": 100.0, "Acceleration": 40.0, "AngularVelocity": 6.0, "Angle": 3.2}
"""Largest magnitude a car's signal of each quantity reaches [SI]; wheel speeds are checked as
speeds (``omega R`` with R up to 0.5 m).  A log beyond it has a unit wrong."""

_WHEEL_SPEED_LIMIT = 250.0
"""[rad/s]: 100 m/s on a 0.4 m wheel."""


class LogError(ValueError):
    """A recorded log that cannot be used, with the column (or file) and the reason."""


@dataclass
class Recording:
    """Signals over time, by contract name (SI units, Booleans as 0.0/1.0).

    Attributes
    ----------
    time : ndarray
        Increasing sample times [s].
    signals : dict of str -> ndarray
        Contract signals (inputs of the estimators).
    reference : dict of str -> ndarray
        Reference signals (``beta`` [rad] and any truth a simulation adds).
    source : str
        Where it came from (file name or scenario).
    """

    time: np.ndarray
    signals: dict
    reference: dict = field(default_factory=dict)
    source: str = ""

    @property
    def duration(self) -> float:
        """Time span [s]."""
        return float(self.time[-1] - self.time[0])

    def on_grid(self, step: float) -> "Recording":
        """The recording on the uniform grid ``t_0 + k step`` by zero-order hold.

        A ``gps_fresh`` pulse lands in the grid step that first covers it (never lost, never
        repeated): a 1 ms replay of a 100 Hz log and a 10 ms replay of a 1 ms recording both see
        each GPS fix once.
        """
        t = self.time
        n = int(math.floor((t[-1] - t[0]) / step + 1e-9)) + 1
        grid = t[0] + step * np.arange(n)
        idx = np.searchsorted(t, grid + 1e-9 * step, side="right") - 1        # last sample at or before
        out = {name: np.asarray(v)[idx] for name, v in self.signals.items()}
        if "gps_fresh" in self.signals:
            # fresh in a grid step when a fix arrived since the previous grid step: on a finer grid in
            # the first step that holds the fix's sample, on a coarser one in the step that covers it
            arrivals = np.cumsum(np.asarray(self.signals["gps_fresh"]) > 0.5)
            seen = arrivals[idx]
            out["gps_fresh"] = np.r_[seen[0] > 0, np.diff(seen) > 0].astype(float)
        ref = {name: np.asarray(v)[idx] for name, v in self.reference.items()}
        return Recording(grid, out, ref, self.source)

    def inputs(self, names) -> np.ndarray:
        """Rows of the signals ``names`` (a model's ``input_names``), optional ones filled in.

        Raises
        ------
        LogError
            Naming the inputs the recording lacks.
        """
        missing = [n for n in names if n not in self.signals and n not in OPTIONAL_INPUTS]
        if missing:
            raise LogError(f"{self.source}: no column for {', '.join(missing)} (needed by the estimator; name the "
                           "columns by the contract or map them in a map file)")
        cols = [np.asarray(self.signals[n], dtype=float) if n in self.signals
                else np.full(len(self.time), OPTIONAL_INPUTS[n]) for n in names]
        return np.column_stack(cols)


# ---------------------------------------------------------------------------------------- reading
def _read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    try:
        with path.open(newline="") as fh:
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader)]
            rows = [r for r in reader if r and any(c.strip() for c in r)]
    except (OSError, StopIteration, UnicodeDecodeError, csv.Error) as exc:
        raise LogError(f"{path}: cannot be read as a CSV log with a header row ({exc})") from None
    if not rows:
        raise LogError(f"{path}: no data rows")
    data = np.full((len(rows), len(header)), np.nan)
    for i, row in enumerate(rows):
        if len(row) != len(header):
            raise LogError(f"{path}: row {i + 2} has {len(row)} fields, the header {len(header)}")
        for j, cell in enumerate(row):
            cell = cell.strip()
            if cell:
                try:
                    data[i, j] = float(cell)
                except ValueError:
                    raise LogError(f"{path}: column {header[j]!r}, row {i + 2}: {cell!r} is not a number") from None
    return header, data


def _column(header, name: str, path: Path, required: bool = True) -> int | None:
    """Index of column ``name``, or of the one column ``<instance>.name``."""
    if name in header:
        return header.index(name)
    suffixed = [i for i, h in enumerate(header) if h.endswith("." + name)]
    if len(suffixed) == 1:
        return suffixed[0]
    if len(suffixed) > 1:
        raise LogError(f"{path}: several columns end in '.{name}' ({', '.join(header[i] for i in suffixed)}): map "
                       "the one to use in a map file")
    if required:
        raise LogError(f"{path}: no column {name!r}")
    return None


def _entry(spec, where: str) -> tuple[str, str | None, float, float]:
    if isinstance(spec, str):
        return spec, None, 1.0, 0.0
    if not isinstance(spec, dict) or "column" not in spec:
        raise LogError(f"{where}: expected a table with 'column' (and optional 'unit', 'scale', 'offset')")
    unknown = set(spec) - {"column", "unit", "scale", "offset"}
    if unknown:
        raise LogError(f"{where}: unknown keys {', '.join(sorted(unknown))}")
    try:
        return str(spec["column"]), spec.get("unit"), float(spec.get("scale", 1.0)), float(spec.get("offset", 0.0))
    except (TypeError, ValueError):
        raise LogError(f"{where}: 'scale' and 'offset' must be numbers") from None


def _load_map(map_path: Path | None) -> dict:
    if map_path is None:
        return {}
    try:
        data = tomllib.loads(Path(map_path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise LogError(f"map file {map_path}: {exc}") from None
    unknown = set(data) - {"time", "signals", "reference"}
    if unknown:
        raise LogError(f"map file {map_path}: unknown keys {', '.join(sorted(unknown))} (time, signals, reference)")
    return data


def _convert(values, name: str, column: str, unit: str | None, scale: float, offset: float, path) -> np.ndarray:
    sig = SIGNALS.get(name)
    si = sig.unit if sig is not None and sig.kind == "Real" else ("rad" if name == "beta" else "1")
    try:
        factor = si_factor(unit or si, si)
    except KeyError as exc:
        raise LogError(f"{path}: column {column!r} ({name}): {exc.args[0]}") from None
    return values * factor * scale + offset


def _check(name: str, column: str, values: np.ndarray, time: np.ndarray, path, max_gap: float) -> np.ndarray:
    """NaN runs up to ``max_gap`` held, longer ones refused; magnitudes no car reaches refused."""
    bad = ~np.isfinite(values)
    if bad.all():
        raise LogError(f"{path}: column {column!r} ({name}) holds no number")
    if bad.any():
        edges = np.flatnonzero(np.diff(np.r_[0, bad.astype(int), 0]))
        for start, stop in zip(edges[::2], edges[1::2]):
            t0 = time[max(start - 1, 0)]
            t1 = time[min(stop, len(time) - 1)]
            if t1 - t0 > max_gap:
                raise LogError(f"{path}: column {column!r} ({name}) has no value from t = {time[start]:.3f} s to "
                               f"{time[stop - 1]:.3f} s (longer than {max_gap:g} s)")
        idx = np.where(bad, 0, np.arange(len(values)))
        np.maximum.accumulate(idx, out=idx)
        first = np.flatnonzero(~bad)[0]
        values = values[np.where(idx < first, first, idx)]
    sig = SIGNALS.get(name)
    if sig is not None and sig.kind == "Real":
        limit = _WHEEL_SPEED_LIMIT if name.startswith("omega_") else PLAUSIBLE.get(sig.quantity)
        peak = float(np.max(np.abs(values)))
        if limit is not None and peak > limit:
            raise LogError(f"{path}: column {column!r} ({name}) reaches {peak:g} {sig.unit}, more than a car's "
                           f"{limit:g} {sig.unit}: is its unit right?")
    return values


def read_log(csv_path: str | Path, map_path: str | Path | None = None, max_gap: float = 0.5) -> Recording:
    """Read a CSV log (see module docstring).

    Parameters
    ----------
    csv_path : path
        The log: a header row, then one row per sample.
    map_path : path, optional
        TOML map of columns to contract signals, units, scale and offset.
    max_gap : float
        Longest run of missing values in a column that is held over [s].

    Raises
    ------
    LogError
        Naming the file and the column.
    """
    path = Path(csv_path)
    header, data = _read_csv(path)
    mapping = _load_map(Path(map_path) if map_path else None)
    tcol, tunit, tscale, toff = _entry(mapping.get("time", "time"), "map file: time")
    ti = _column(header, tcol, path)
    time = data[:, ti] * si_factor(tunit or "s", "s") * tscale + toff
    if not np.isfinite(time).all():
        raise LogError(f"{path}: time column {header[ti]!r} has missing values")
    steps = np.diff(time)
    if len(time) < 2 or (steps <= 0).any():
        row = int(np.argmax(steps <= 0)) + 3 if len(time) >= 2 else 2
        raise LogError(f"{path}: time column {header[ti]!r} does not increase (row {row})")
    used = {ti}
    signals, reference = {}, {}
    mapped = mapping.get("signals", {})
    for name, spec in mapped.items():
        if name not in SIGNALS:
            raise LogError(f"map file: signals.{name} is not a signal of the catalogue")
        col, unit, scale, off = _entry(spec, f"map file: signals.{name}")
        j = _column(header, col, path)
        used.add(j)
        signals[name] = _check(name, header[j], _convert(data[:, j], name, header[j], unit, scale, off, path),
                               time, path, max_gap)
    for name, spec in mapping.get("reference", {}).items():
        col, unit, scale, off = _entry(spec, f"map file: reference.{name}")
        j = _column(header, col, path)
        used.add(j)
        reference[name] = _check(name, header[j], _convert(data[:, j], name, header[j], unit, scale, off, path),
                                 time, path, max_gap)
    for name in LOGGED_INPUTS + REFERENCES:           # contract-named columns (SI) not in the map
        if name in signals or name in reference:
            continue
        j = _column(header, name, path, required=False)
        if j is None or j in used:
            continue
        values = _check(name, header[j], data[:, j], time, path, max_gap)
        if name in REFERENCES:                        # the truth of a simulated drive is a reference
            reference[name] = values
        else:
            signals[name] = values
    if "gps_ve" in signals and "gps_vn" in signals:
        ve, vn = signals["gps_ve"], signals["gps_vn"]
        if "gps_valid" not in signals:
            signals["gps_valid"] = np.ones(len(time))
        if "gps_fresh" not in signals:           # a fix is a change of the held GPS velocity
            signals["gps_fresh"] = np.r_[1.0, ((np.diff(ve) != 0) | (np.diff(vn) != 0)).astype(float)]
        if "gps_speed" not in signals:
            signals["gps_speed"] = np.hypot(ve, vn)
        if "gps_course" not in signals:
            signals["gps_course"] = np.arctan2(vn, ve)
    return Recording(time, signals, reference, str(path))


def write_log(recording: Recording, path: str | Path, every: int = 1) -> Path:
    """Write a recording as a CSV log :func:`read_log` reads without a map: a ``time`` column, then its signals
    and references by contract name in SI units, every ``every``-th sample."""
    names = list(recording.signals) + [n for n in recording.reference if n not in recording.signals]
    columns = [recording.time] + [recording.signals[n] if n in recording.signals else recording.reference[n]
                                  for n in names]
    data = np.column_stack([np.asarray(c, dtype=float)[::every] for c in columns])
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, data, delimiter=",", header=",".join(["time"] + names), comments="", fmt="%.9g")
    return path


# ---------------------------------------------------------------------------------------- replay
def replay(model, recording: Recording, step: float | None = None) -> dict[str, np.ndarray]:
    """Step a library model through a recording; its outputs after every step.

    Parameters
    ----------
    model : Model
        E.g. an estimator; its ``input_names`` are taken from the recording.
    recording : Recording
        Used as it is when ``step`` is None (its own, uniform, step), else resampled.
    step : float, optional
        Step [s] (default: the recording's).

    Returns
    -------
    dict
        ``"time"`` and every output of the model, one row per step (the model's state after the
        step that ends there; the first row is the state before any step).
    """
    rec = recording.on_grid(step) if step is not None else recording
    h = float(rec.time[1] - rec.time[0]) if step is None else step
    u = rec.inputs(model.input_names).tolist()          # Python floats: the models compute on them
    out = np.empty((len(rec.time), len(model.output_names)))
    out[0] = model.outputs()
    step_fn, outputs = model.step, model.outputs
    for k in range(1, len(rec.time)):
        step_fn(h, *u[k])
        out[k] = outputs()
    res = {name: out[:, i] for i, name in enumerate(model.output_names)}
    res["time"] = rec.time
    return res
