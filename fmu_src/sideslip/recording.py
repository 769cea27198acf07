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

from .signals import SENSOR_OUTPUTS, SIGNALS, WHEEL_SPEEDS_M
from .units import si_factor

__all__ = ["Recording", "LogError", "read_log", "write_log", "replay", "plausibility", "missing_columns",
           "recorded_speed", "OPTIONAL_INPUTS", "LOGGED_INPUTS", "REFERENCES", "PLAUSIBLE", "LOG_READERS", "MAP_KEYS",
           "WHEEL_SPEED_STAND_INS"]

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

WHEEL_SPEED_STAND_INS = ("vx", *WHEEL_SPEEDS_M)
"""What may stand in for the four wheel speeds (:meth:`Recording.with_wheel_speeds`)."""

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
    wheel_speeds_from: str | None = None
    """What stands in for missing wheel speeds (:meth:`with_wheel_speeds`), as the map file asks."""

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
        return Recording(grid, out, ref, self.source, self.wheel_speeds_from)

    def window(self, t0: float = -math.inf, t1: float = math.inf) -> "Recording":
        """The samples with ``t0 <= time <= t1`` [s].

        Raises
        ------
        LogError
            When fewer than two samples are left, naming the log's span.
        """
        keep = (self.time >= t0) & (self.time <= t1)
        if keep.sum() < 2:
            raise LogError(f"{self.source}: window {t0:g}:{t1:g} s holds fewer than two samples; the log covers "
                           f"{self.time[0]:g} to {self.time[-1]:g} s")
        return Recording(self.time[keep], {k: np.asarray(v)[keep] for k, v in self.signals.items()},
                         {k: np.asarray(v)[keep] for k, v in self.reference.items()}, self.source,
                         self.wheel_speeds_from)

    def with_wheel_speeds(self, vehicle, source: str | None = None) -> "Recording":
        """The recording with its four wheel speeds made from ``source`` where it has none.

        Every estimator reads the wheels only through the mean of an axle (the undriven one:
        :meth:`sideslip.estimators.base.Estimator.speed`), so one speed stands in for four: ``"vx"`` (a logged
        speed over ground, a signal or a reference, e.g. from an optical sensor or the INS) gives every wheel
        ``vx / R_w``; one wheel's speed (``"omega_rl_m"``...) gives its axle's mean by removing the yaw rate's
        share at that wheel (``+- r t / 2``) when the log has the yaw rate.  Drive and brake slip of the wheels is
        lost: the stand-in is the free-rolling speed.

        Parameters
        ----------
        vehicle : VehicleParams
            The estimators' vehicle (rolling radius, track).
        source : str, optional
            One of :data:`WHEEL_SPEED_STAND_INS` (default: the map's ``wheel_speeds_from``).

        Raises
        ------
        LogError
            When the recording lacks ``source``.
        """
        source = source or self.wheel_speeds_from
        if source is None or all(w in self.signals for w in WHEEL_SPEEDS_M):
            return self
        if source not in WHEEL_SPEED_STAND_INS:
            raise LogError(f"wheel speeds from {source!r}: allowed {', '.join(WHEEL_SPEED_STAND_INS)}")
        series = self.signals.get(source, self.reference.get(source))
        if series is None:
            raise LogError(f"{self.source}: no column for {source}, which is to stand in for the wheel speeds")
        series = np.asarray(series, dtype=float)
        if source == "vx":
            axle = series / vehicle.R_w
        else:
            side = 1.0 if source[len("omega_") + 1] == "l" else -1.0          # the left wheel runs slower in a left turn
            track = vehicle.t_f if source[len("omega_")] == "f" else vehicle.t_r
            r = np.asarray(self.signals.get("yaw_rate_m", np.zeros_like(series)), dtype=float)
            axle = series + side * r * track / (2.0 * vehicle.R_w)
        signals = dict(self.signals)
        for w in WHEEL_SPEEDS_M:
            signals[w] = axle
        return Recording(self.time, signals, dict(self.reference), self.source, source)

    def inputs(self, names, unused=()) -> np.ndarray:
        """Rows of the signals ``names`` (a model's ``input_names``), optional ones filled in.

        ``unused`` are inputs the model's configuration never reads (e.g. the GNSS of an estimator told not to use
        it): a log may lack them, and they are zero then.

        Raises
        ------
        LogError
            Naming the inputs the recording lacks.
        """
        missing = [n for n in names if n not in self.signals and n not in OPTIONAL_INPUTS and n not in unused]
        if missing:
            raise LogError(missing_columns(self.source, missing, "the estimator"))
        cols = [np.asarray(self.signals[n], dtype=float) if n in self.signals
                else np.full(len(self.time), OPTIONAL_INPUTS.get(n, 0.0)) for n in names]
        return np.column_stack(cols)


def missing_columns(source: str, missing, needed_by: str) -> str:
    """The message of a log that lacks inputs, with what can stand in for them."""
    text = (f"{source}: no column for {', '.join(missing)} (needed by {needed_by}; name the columns by the contract "
            "or map them in a map file)")
    if set(missing) & set(WHEEL_SPEEDS_M):
        text += ("; without wheel speeds, a logged speed or one wheel's speed can stand in for them: "
                 "--wheel-speeds-from vx (or omega_rl_m, ...), or wheel_speeds_from in the map file")
    return text


# ---------------------------------------------------------------------------------------- reading
def _read_csv(path: Path, wanted=None) -> tuple[list[str], np.ndarray]:
    """A CSV log: a header row, then numbers (numpy's parser; a file it refuses is read cell by cell to name the
    column and row that is not a number)."""
    try:
        with path.open(newline="") as fh:
            header = [h.strip() for h in next(csv.reader(fh))]
    except (OSError, StopIteration, UnicodeDecodeError, csv.Error) as exc:
        raise LogError(f"{path}: cannot be read as a CSV log with a header row ({exc})") from None
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=float)
        if data.shape[1] == len(header) and len(data):
            return header, data
    except ValueError:
        pass
    return header, _read_csv_cells(path, header)


def _read_csv_cells(path: Path, header: list) -> np.ndarray:
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        next(reader)
        rows = [r for r in reader if r and any(c.strip() for c in r)]
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
    return data


def _read_parquet(path: Path, wanted=None) -> tuple[list[str], np.ndarray]:
    """A Parquet table (pyarrow): numeric and Boolean columns; others read as missing."""
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise LogError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow, or sideslip-fmu[data])") from None
    try:
        table = pq.read_table(path)
    except Exception as exc:  # noqa: BLE001 - pyarrow raises several types for a bad file
        raise LogError(f"{path}: cannot be read as a Parquet log ({exc})") from None
    header, columns = [], []
    for name, column in zip(table.column_names, table.columns):
        header.append(str(name))
        try:
            columns.append(np.asarray(column.to_numpy(zero_copy_only=False), dtype=float))
        except (TypeError, ValueError):
            columns.append(np.full(table.num_rows, np.nan))
    if not table.num_rows:
        raise LogError(f"{path}: no data rows")
    return header, np.column_stack(columns)


def _read_mdf(path: Path, wanted=None) -> tuple[list[str], np.ndarray]:
    """An ASAM MDF (3 or 4) file (asammdf): the wanted channels on the time stamps of the one sampled most often,
    each held from its last sample (zero-order hold, as :meth:`Recording.on_grid`), a column ``time`` [s] added."""
    try:
        from asammdf import MDF
    except ImportError:
        raise LogError(f"{path}: reading MDF needs asammdf (pip install asammdf, or sideslip-fmu[data])") from None
    try:
        mdf = MDF(path)
    except Exception as exc:  # noqa: BLE001 - asammdf raises several types for a bad file
        raise LogError(f"{path}: cannot be read as an MDF log ({exc})") from None
    try:
        names = [n for n in mdf.channels_db if n != "time" and (wanted is None or n in wanted)]
        signals = {}
        for name in names:
            try:
                sig = mdf.get(name)
            except Exception:  # noqa: BLE001 - a channel asammdf cannot decode is treated as absent
                continue
            if sig.samples.dtype.kind in "biuf" and sig.samples.ndim == 1 and len(sig.timestamps):
                signals[name] = (np.asarray(sig.timestamps, dtype=float), np.asarray(sig.samples, dtype=float))
    finally:
        mdf.close()
    if not signals:
        raise LogError(f"{path}: no numeric channel" + (f" among {', '.join(sorted(wanted))}" if wanted else ""))
    time = max((t for t, _ in signals.values()), key=len)
    header, columns = ["time"], [time]
    for name, (t, v) in signals.items():
        idx = np.searchsorted(t, time, side="right") - 1
        columns.append(np.where(idx >= 0, v[np.maximum(idx, 0)], np.nan))
        header.append(name)
    return header, np.column_stack(columns)


LOG_READERS = {".csv": _read_csv, ".txt": _read_csv, ".parquet": _read_parquet, ".pq": _read_parquet,
               ".mf4": _read_mdf, ".mdf": _read_mdf, ".dat": _read_mdf}
"""The log formats by file suffix: each reader returns the column names and a 2-D array of numbers (a column a
signal).  Parquet needs pyarrow and MDF asammdf (the ``data`` extra)."""


def _read_table(path: Path, wanted: set | None) -> tuple[list[str], np.ndarray]:
    reader = LOG_READERS.get(path.suffix.lower())
    if reader is None:
        raise LogError(f"{path}: unknown log format {path.suffix!r}; known: {', '.join(sorted(LOG_READERS))}")
    if not path.is_file():
        raise LogError(f"{path}: no such file")
    return reader(path, wanted)


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


MAP_KEYS = ("time", "signals", "reference", "wheel_speeds_from")
"""The top-level keys of a map file."""


def _load_map(map_path: Path | None) -> dict:
    if map_path is None:
        return {}
    try:
        data = tomllib.loads(Path(map_path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise LogError(f"map file {map_path}: {exc}") from None
    unknown = set(data) - set(MAP_KEYS)
    if unknown:
        raise LogError(f"map file {map_path}: unknown keys {', '.join(sorted(unknown))} ({', '.join(MAP_KEYS)})")
    return data


def _wanted(mapping: dict) -> set:
    """The columns a map and the contract may name (what an MDF reader loads)."""
    out = {"time"} | set(LOGGED_INPUTS) | set(REFERENCES)
    for section in ("signals", "reference"):
        for spec in mapping.get(section, {}).values():
            out.add(spec if isinstance(spec, str) else spec.get("column", "") if isinstance(spec, dict) else "")
    time = mapping.get("time", "time")
    out.add(time if isinstance(time, str) else time.get("column", "time") if isinstance(time, dict) else "time")
    return out


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
    """Read a log: CSV, Parquet or MDF (:data:`LOG_READERS`; see module docstring).

    Parameters
    ----------
    csv_path : path
        The log: a CSV file (a header row, then one row per sample), a Parquet table or an MDF file.
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
    mapping = _load_map(Path(map_path) if map_path else None)
    header, data = _read_table(path, _wanted(mapping))
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
    stand_in = mapping.get("wheel_speeds_from")
    if stand_in is not None and stand_in not in WHEEL_SPEED_STAND_INS:
        raise LogError(f"map file: wheel_speeds_from = {stand_in!r}; allowed: {', '.join(WHEEL_SPEED_STAND_INS)}")
    return Recording(time, signals, reference, str(path), stand_in)


def recorded_speed(rec: Recording, radius: float | None = None) -> np.ndarray:
    """The car's speed in a recording [m/s]: the reference velocity (a simulation's truth, a log's INS), else the
    GNSS speed, else (given a rolling ``radius`` [m]) the wheels' mean speed; without any, every sample counts as
    moving (infinite)."""
    if "vx" in rec.reference:
        return np.hypot(rec.reference["vx"], rec.reference.get("vy", 0.0))
    if "gps_speed" in rec.signals:
        return np.asarray(rec.signals["gps_speed"], dtype=float)
    wheels = [np.asarray(rec.signals[w], dtype=float) for w in WHEEL_SPEEDS_M if w in rec.signals]
    if wheels and radius is not None:
        return np.abs(np.mean(wheels, axis=0)) * radius
    return np.full(len(rec.time), np.inf)


def _correlation(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    """Pearson's correlation of ``a`` and ``b`` over ``mask`` (NaN with fewer than 20 samples or no variation)."""
    if mask.sum() < 20 or np.ptp(a[mask]) == 0 or np.ptp(b[mask]) == 0:
        return math.nan
    return float(np.corrcoef(a[mask], b[mask])[0, 1])


def plausibility(rec: Recording, vehicle=None) -> list[str]:
    """What in a log looks wrong though every value is within a car's range: signs, scales and units that the
    physics of the drive contradict.  Each finding names the signal and what to change in the map file.

    Checks, on the samples faster than 5 m/s:

    * the reference sideslip beyond 0.2 rad (11 deg) for half the drive, or beyond 0.15 rad in a tenth of the
      samples with less than 2 m/s2 of lateral acceleration: logged in degrees?
    * the lateral acceleration against yaw rate x speed (steady turning), and the steering against the yaw rate:
      opposite signs mean a flipped axis (``scale = -1``);
    * the longitudinal acceleration against the change of speed: the same;
    * the road-wheel angle beyond 0.6 rad (34 deg) at speed: the handwheel angle (divide by the steering ratio);
    * the wheels' speed (on ``vehicle``'s rolling radius, 0.31 m without one) against the GNSS speed: off by more
      than 20 % is a unit (rpm, km/h) or a radius wrong.

    Returns
    -------
    list of str
        The findings, empty for a plausible log.
    """
    radius = vehicle.R_w if vehicle is not None else 0.31
    speed = recorded_speed(rec, radius)
    moving = speed > 5.0
    out = []
    if not moving.any():
        return ["the log never moves faster than 5 m/s (by its speed signals): nothing to estimate"]
    speed = np.where(np.isfinite(speed), speed, 0.0)          # a log without any speed: the sign checks only
    sig, ref = rec.signals, rec.reference
    if "beta" in ref:
        beta = np.abs(np.asarray(ref["beta"], dtype=float))
        calm = moving & (np.abs(np.asarray(sig["ay_m"], dtype=float)) < 2.0) if "ay_m" in sig else moving
        typical = float(np.median(beta[moving]))
        calm_p90 = float(np.percentile(beta[calm], 90)) if calm.sum() > 20 else 0.0
        if typical > 0.2 or calm_p90 > 0.15:
            out.append(f"reference beta: {typical:.2f} rad typical while moving and {calm_p90:.2f} rad (90th "
                       "percentile) below 2 m/s2 of lateral acceleration, where a car holds a few hundredths of a "
                       "radian: is it logged in degrees? (unit = \"deg\" in the map file)")
    if "ay_m" in sig and "yaw_rate_m" in sig:
        ay, r = np.asarray(sig["ay_m"], dtype=float), np.asarray(sig["yaw_rate_m"], dtype=float)
        c = _correlation(ay, r * speed, moving & (np.abs(ay) > 1.0))
        if c < -0.5:
            out.append(f"ay_m and yaw_rate_m: in turns their signs disagree (correlation of a_y with r v {c:.2f}): "
                       "one axis is flipped (scale = -1 on it in the map file; ISO 8855: y left, z up)")
    if "delta_m" in sig and "yaw_rate_m" in sig:
        d, r = np.asarray(sig["delta_m"], dtype=float), np.asarray(sig["yaw_rate_m"], dtype=float)
        c = _correlation(d, r, moving & (np.abs(r) > 0.05))
        if c < -0.5:
            out.append(f"delta_m and yaw_rate_m: their signs disagree (correlation {c:.2f}): the steering or the gyro "
                       "is flipped (scale = -1; positive steering turns left)")
        big = float(np.max(np.abs(d[speed > 10.0]), initial=0.0))
        if big > 0.6:
            out.append(f"delta_m reaches {big:.2f} rad ({np.degrees(big):.0f} deg) above 10 m/s: is it the handwheel "
                       "angle? The estimators take the road-wheel angle (scale = 1 / steering ratio)")
    if "ax_m" in sig and len(rec.time) > 2:
        ax = np.asarray(sig["ax_m"], dtype=float)
        dv = np.gradient(speed, rec.time)
        c = _correlation(ax, dv, moving & (np.abs(dv) > 0.5))
        if c < -0.5:
            out.append(f"ax_m: it disagrees in sign with the change of speed (correlation {c:.2f}): flipped? "
                       "(scale = -1; ISO 8855: x forward)")
    wheels = [np.asarray(sig[w], dtype=float) for w in WHEEL_SPEEDS_M if w in sig]
    if wheels and "gps_speed" in sig:
        gps = np.asarray(sig["gps_speed"], dtype=float)
        use = moving & (gps > 5.0)
        if use.sum() > 20:
            ratio = float(np.median(np.abs(np.mean(wheels, axis=0))[use] * radius / gps[use]))
            if not 0.8 < ratio < 1.25:
                out.append(f"wheel speeds: on a {radius:.3f} m rolling radius they give {ratio:.2f} x the GNSS speed: "
                           "a unit (rpm: unit = \"rpm\"; a speed in km/h: convert to rad/s) or the radius is wrong")
    return out


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
    unused = model.unused_inputs(vars(model.config)) if hasattr(model, "unused_inputs") else ()
    u = rec.inputs(model.input_names, unused).tolist()          # Python floats: the models compute on them
    out = np.empty((len(rec.time), len(model.output_names)))
    out[0] = model.outputs()
    step_fn, outputs = model.step, model.outputs
    for k in range(1, len(rec.time)):
        step_fn(h, *u[k])
        out[k] = outputs()
    res = {name: out[:, i] for i, name in enumerate(model.output_names)}
    res["time"] = rec.time
    return res
