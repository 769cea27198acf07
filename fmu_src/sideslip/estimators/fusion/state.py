"""The state of :class:`~sideslip.estimators.fusion.filter.SideslipFusion` and its per-state values.

The state's initial variances, process noise and caps are written as maps ``{Fs.X: value}``
(:func:`per_state`), so that each value stays with its state whatever the order of :class:`Fs`.
The filter leaves out the states of what it does not use, last first: the magnetometer's heading
offset without the magnetometer, the GNSS delay without ``delay_state`` (they would only cost time:
nothing observes them).
"""
from __future__ import annotations

from enum import IntEnum
from typing import Mapping

import numpy as np

__all__ = ["Fs", "state_size", "per_state"]


class Fs(IntEnum):
    """State of the fusion filter.

    ``VX``, ``VY`` body-frame velocity [m/s]; ``PSI`` heading [rad]; ``B_R`` gyro offset [rad/s];
    ``B_AX``, ``B_AY`` accelerometer offsets [m/s2]; ``D_DELTA`` steering offset [rad]; ``LN_CF``,
    ``LN_CR`` log cornering-stiffness scales of the axles; ``LN_MU`` log friction; ``E_W`` rolling-radius
    error; ``G_Y`` the road bank's gravity term ``g sin(bank)`` in the lateral accelerometer [m/s2],
    which moves the car but is not a tire force (``B_AY``, the sensor's offset, is in both); ``D_GNSS``
    the GNSS delay [s]; ``B_MAG`` the magnetometer's heading offset [rad] (a declination or iron error).
    """
    VX, VY, PSI, B_R, B_AX, B_AY, D_DELTA, LN_CF, LN_CR, LN_MU, E_W, G_Y, D_GNSS, B_MAG = range(14)


def state_size(delay_state: bool, use_magnetometer: bool) -> int:
    """Number of states the filter keeps: all of :class:`Fs` with the magnetometer, up to ``D_GNSS`` with the delay
    state only, up to ``G_Y`` with neither."""
    return len(Fs) if use_magnetometer else Fs.B_MAG if delay_state else Fs.D_GNSS


def per_state(values: Mapping[Fs, float], n: int) -> np.ndarray:
    """The vector of the first ``n`` states' values from ``{Fs.X: value}``.

    Raises
    ------
    ValueError
        When a kept state has no value.
    """
    missing = [s.name for s in Fs if s < n and s not in values]
    if missing:
        raise ValueError(f"no value for the state(s) {', '.join(missing)}")
    return np.array([float(values[s]) for s in Fs if s < n])
