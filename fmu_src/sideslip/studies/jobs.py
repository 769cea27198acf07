"""The one job runner: many closed loops in parallel on a process pool or a Dask cluster.

Paper tables, the control evaluation and the tuning studies all run through
:func:`parallel_map`: a picklable function over a list of items on a local process pool or,
given a scheduler address, on a Dask distributed cluster, yielding ``(item, result)`` in
completion order with an optional progress bar on stderr; :func:`map_ordered` returns the
results in the items' order.  Local workers are spawned, not forked: a forked child would
inherit the parent's loaded FMUs and pythonfmu's interpreter state, which is not fork-safe.
:class:`CsvLog` appends each result to a CSV as it arrives and tells which items a previous,
interrupted study already finished, so a study resumes where it stopped.
"""
from __future__ import annotations

import csv
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path
from typing import Callable, Iterable, Iterator

__all__ = ["parallel_map", "map_ordered", "CsvLog", "ProgressBar"]


class ProgressBar:
    """A one-line text progress bar on a stream (stderr by default), with rate and remaining time."""

    def __init__(self, total: int, label: str = "", stream=None, width: int = 30):
        self.total, self.label, self.width = max(total, 1), label, width
        self.stream = stream or sys.stderr
        self.done, self.t0 = 0, time.perf_counter()

    def update(self, n: int = 1) -> None:
        self.done += n
        elapsed = time.perf_counter() - self.t0
        frac = self.done / self.total
        eta = elapsed / frac - elapsed if frac > 0 else float("nan")
        bar = "#" * int(frac * self.width)
        self.stream.write(f"\r{self.label} [{bar:<{self.width}}] {self.done}/{self.total} "
                          f"{elapsed:6.1f} s elapsed, {eta:6.1f} s left")
        if self.done >= self.total:
            self.stream.write("\n")
        self.stream.flush()


def parallel_map(fn: Callable, items: Iterable, workers: int = 2, scheduler: str | None = None,
                 progress: bool = True, label: str = "runs") -> Iterator[tuple]:
    """Yield ``(item, fn(item))`` in completion order.

    Parameters
    ----------
    fn : callable
        A module-level (picklable) function of one item.
    items : iterable
        Picklable work items.
    workers : int
        Local worker processes (ignored with ``scheduler``); 1 runs in this process.
    scheduler : str, optional
        Address of a Dask distributed scheduler (``tcp://host:8786``), or a ``distributed.Client``.
    progress : bool
        Show a progress bar on stderr.
    """
    items = list(items)
    bar = ProgressBar(len(items), label) if progress and items else None
    if scheduler is not None:
        yield from _dask_map(fn, items, scheduler, bar)
        return
    if workers <= 1 or len(items) == 1:
        for item in items:
            result = fn(item)
            if bar:
                bar.update()
            yield item, result
        return
    with ProcessPoolExecutor(max_workers=min(workers, len(items)), mp_context=get_context("spawn")) as pool:
        futures = {pool.submit(fn, item): item for item in items}
        for fut in as_completed(futures):
            result = fut.result()
            if bar:
                bar.update()
            yield futures[fut], result


class _Indexed:
    """``fn`` applied to the item of an ``(index, item)`` pair, keeping the index (picklable)."""

    def __init__(self, fn: Callable):
        self.fn = fn

    def __call__(self, pair):
        return self.fn(pair[1])


def map_ordered(fn: Callable, items: Iterable, workers: int = 2, scheduler: str | None = None,
                progress: bool = False, label: str = "runs") -> list:
    """``[fn(item) for item in items]`` computed by :func:`parallel_map` (results in the items' order)."""
    pairs = list(enumerate(items))
    results = [None] * len(pairs)
    for (i, _), result in parallel_map(_Indexed(fn), pairs, workers, scheduler, progress, label):
        results[i] = result
    return results


def _dask_map(fn, items, scheduler, bar):
    from distributed import Client, as_completed as dask_completed

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    try:
        futures = client.map(fn, items, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        for fut, result in dask_completed(futures, with_results=True):
            if bar:
                bar.update()
            yield items[index[fut.key]], result
    finally:
        if client is not scheduler:
            client.close()


class CsvLog:
    """Append-only CSV of results keyed by some columns; knows what is already done.

    Parameters
    ----------
    path : path
        The CSV file (created with a header on the first :meth:`append`).
    fields : list of str
        Column names; the first ``n_key`` identify a work item.
    n_key : int
        Number of key columns.
    """

    def __init__(self, path: str | Path, fields: list, n_key: int):
        self.path, self.fields, self.n_key = Path(path), list(fields), n_key

    def _key(self, row) -> tuple:
        return tuple(f"{float(row[f]):.9g}" if _is_number(row[f]) else str(row[f]) for f in self.fields[:self.n_key])

    def rows(self) -> list[dict]:
        """Rows written so far (values as strings)."""
        if not self.path.is_file():
            return []
        with self.path.open(newline="") as fh:
            return [r for r in csv.DictReader(fh) if all(r.get(f) not in (None, "") for f in self.fields)]

    def done(self) -> set:
        """Keys of the rows already written."""
        return {self._key(r) for r in self.rows()}

    def is_done(self, item: dict, done: set | None = None) -> bool:
        return self._key(item) in (self.done() if done is None else done)

    def append(self, row: dict) -> None:
        """Write one row (and the header if the file is new) and flush it to disk."""
        new = not self.path.is_file() or self.path.stat().st_size == 0
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self.path.open("a", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=self.fields, extrasaction="ignore")
            if new:
                w.writeheader()
            w.writerow(row)


def _is_number(value) -> bool:
    try:
        float(value)
        return True
    except (TypeError, ValueError):
        return False
