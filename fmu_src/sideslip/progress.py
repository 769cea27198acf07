"""Progress of long commands on stderr: tqdm bars, shown from zero with a smoothed ETA, silent when stderr is not a
terminal (a log file or a test gets no bar).  tqdm rather than a hand-written bar: it handles terminal width,
rates, remaining time and non-terminals."""
from __future__ import annotations

import sys

__all__ = ["progress_bar", "fraction_callback"]

SMOOTHING = 0.05
"""tqdm's exponential moving average factor of the rate: low, so that a few slow items do not swing the ETA."""


def progress_bar(total: float, label: str, unit: str = "it", enabled: bool | None = None):
    """A tqdm bar on stderr of ``total`` units.

    Parameters
    ----------
    total : float
        What completes the bar (items, simulated seconds, ...).
    label : str
        Shown before the bar.
    unit : str
        The unit of ``total``.
    enabled : bool, optional
        Force the bar on or off; by default it shows only when stderr is a terminal.
    """
    from tqdm import tqdm

    return tqdm(total=total, desc=label, unit=unit, file=sys.stderr, smoothing=SMOOTHING, dynamic_ncols=True,
                disable=None if enabled is None else not enabled, mininterval=0.5,
                bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} {unit} [{elapsed}<{remaining}]")


def fraction_callback(bar):
    """A ``progress(fraction)`` callback (the masters' ``run(progress=...)``) that moves ``bar`` to that fraction of
    its total."""
    def update(fraction: float) -> None:
        target = fraction * bar.total
        if target > bar.n:
            bar.update(target - bar.n)
    return update
