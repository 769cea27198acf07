"""The one job runner: many closed loops in parallel on a process pool or a Dask cluster.

Paper tables, the control evaluation and the tuning studies all run through
:func:`parallel_map`: a picklable function over a list of items on a local process pool or,
given a scheduler address, on a Dask distributed cluster, yielding ``(item, result)`` in
completion order with an optional progress bar on stderr; :func:`map_ordered` returns the
results in the items' order.  A study that maps many times keeps one set of workers for all of them
(:func:`worker_pool`).  Local workers are spawned, not forked: a forked child would
inherit the parent's loaded FMUs and pythonfmu's interpreter state, which is not fork-safe.
:class:`ResultLog` (JSON lines, for :func:`map_ordered`) and :class:`CsvLog` (a table) append each result to disk
as it arrives and tell which items a previous, interrupted study already finished, so a study resumes where it
stopped.
"""
from __future__ import annotations

import csv
import json
import os
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from multiprocessing import get_context
from pathlib import Path
from typing import Callable, Iterable, Iterator

__all__ = ["parallel_map", "map_ordered", "worker_pool", "ResultLog", "CsvLog"]


def parallel_map(fn: Callable, items: Iterable, workers: int = 2, scheduler: str | None = None,
                 progress: bool = True, label: str = "runs", weight: Callable | None = None,
                 unit: str = "runs") -> Iterator[tuple]:
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
        Address of a Dask distributed scheduler (``tcp://host:8786``), ``"local"`` (a Dask cluster of ``workers``
        processes on this machine, started for the call), a ``distributed.Client``, or the pool of
        :func:`worker_pool` (kept running after the call).
    progress : bool
        Show a progress bar on stderr when it is a terminal (:func:`sideslip.progress.progress_bar`).
    weight : callable, optional
        An item's share of the bar (e.g. its simulated seconds, in ``unit``); by default each item counts one.
    """
    from ..progress import progress_bar

    items = list(items)
    weigh = weight or (lambda item: 1)
    bar = progress_bar(sum(weigh(i) for i in items), label, unit) if progress and items else None
    if isinstance(scheduler, Executor) or (scheduler is None and workers > 1 and len(items) > 1):
        with _pool_for(scheduler, min(workers, len(items))) as pool:
            futures = {pool.submit(fn, item): item for item in items}
            try:
                for fut in as_completed(futures):
                    result = fut.result()
                    if bar:
                        bar.update(weigh(futures[fut]))
                    yield futures[fut], result
            finally:
                if bar:
                    bar.close()
        return
    source = _dask_map(fn, items, scheduler, workers) if scheduler is not None else ((i, fn(i)) for i in items)
    try:
        for item, result in source:
            if bar:
                bar.update(weigh(item))
            yield item, result
    finally:
        if bar:
            bar.close()


BLAS_THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""What sets a numerical library's own threads: one per worker (as Dask's workers have), unless set.  The workers
are the parallelism; a BLAS pool per worker on top of them oversubscribes the cores (docs, "Tuning studies")."""


def _local_pool(workers: int) -> ProcessPoolExecutor:
    for name in BLAS_THREADS:           # the workers are spawned on demand and inherit this environment
        os.environ.setdefault(name, "1")
    return ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"))


@contextmanager
def _pool_for(pool, workers: int):
    """``pool`` itself (left running), or a fresh local pool of ``workers`` shut down at the end."""
    if pool is not None:
        yield pool
        return
    with _local_pool(workers) as fresh:
        yield fresh


@contextmanager
def worker_pool(workers: int = 2, scheduler=None):
    """Workers kept for many :func:`parallel_map` calls (a study's batches): pass what this yields as their
    ``scheduler``.  ``scheduler`` None gives a local pool of ``workers`` spawned processes (None for one worker:
    the calls run in this process), ``"local"`` a Dask cluster of ``workers`` processes on this machine, an
    address or a ``distributed.Client`` a client of that cluster."""
    if scheduler is None:
        if workers <= 1:
            yield None
            return
        with _local_pool(workers) as pool:
            yield pool
        return
    from distributed import Client

    if isinstance(scheduler, Client):
        yield scheduler
        return
    with _dask_client(scheduler, workers) as client:
        yield client


class _Indexed:
    """``fn`` applied to the item of an ``(index, item)`` pair, keeping the index (picklable)."""

    def __init__(self, fn: Callable):
        self.fn = fn

    def __call__(self, pair):
        return self.fn(pair[1])


def map_ordered(fn: Callable, items: Iterable, workers: int = 2, scheduler: str | None = None,
                progress: bool = True, label: str = "runs", weight: Callable | None = None, unit: str = "runs",
                log: "ResultLog | None" = None, key: Callable = repr) -> list:
    """``[fn(item) for item in items]`` computed by :func:`parallel_map` (results in the items' order).

    With ``log``, every result is appended to it as it arrives, and an item whose ``key(item)`` the log already
    holds is not run again: its logged result is returned (results must be JSON data).
    """
    pairs = list(enumerate(items))
    results = [None] * len(pairs)
    if log is not None:
        done = log.load()
        keys = [key(item) for _, item in pairs]
        for i, k in enumerate(keys):
            if k in done:
                results[i] = done[k]
        pairs = [(i, item) for i, item in pairs if keys[i] not in done]
    pair_weight = None if weight is None else (lambda pair: weight(pair[1]))
    for (i, _), result in parallel_map(_Indexed(fn), pairs, workers, scheduler, progress, label, pair_weight, unit):
        results[i] = result
        if log is not None:
            log.append(keys[i], result)
    return results


class ResultLog:
    """Append-only JSON-lines file of finished work items, ``{"key": ..., "result": ...}`` per line, each line
    flushed as its item finishes: an interrupted study loses only the items that were running.

    Parameters
    ----------
    path : path
        The file (created on the first :meth:`append`).
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)

    def load(self) -> dict:
        """``{key: result}`` of the items written so far (a line cut off by an interruption is ignored)."""
        if not self.path.is_file():
            return {}
        out = {}
        for line in self.path.read_text().splitlines():
            try:
                entry = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(entry, dict) and "key" in entry and "result" in entry:
                out[entry["key"]] = entry["result"]
        return out

    def append(self, key: str, result) -> None:
        """Write one item's result."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self.path.open("a") as fh:
            fh.write(json.dumps({"key": key, "result": result}) + "\n")
            fh.flush()


@contextmanager
def _dask_client(scheduler, workers: int):
    """A client of the Dask cluster at the address ``scheduler``, or of a local one (``"local"``), closed at the
    end."""
    from distributed import Client, LocalCluster

    if scheduler == "local":
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            with Client(cluster) as client:
                yield client
        return
    with Client(scheduler) as client:
        yield client


def _dask_map(fn, items, scheduler, workers: int):
    from distributed import Client, as_completed as dask_completed

    with (_pool_for(scheduler, workers) if isinstance(scheduler, Client) else _dask_client(scheduler, workers)) \
            as client:
        futures = client.map(fn, items, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        for fut, result in dask_completed(futures, with_results=True):
            yield items[index[fut.key]], result


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
