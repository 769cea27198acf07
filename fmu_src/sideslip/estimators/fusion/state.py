"""The state of :class:`~sideslip.estimators.fusion.filter.SideslipFusion` and its per-state values.

The state's initial variances, process noise and caps are written as maps ``{Fs.X: value}``
(:func:`per_state`), so that each value stays with its state whatever the order of :class:`Fs`.
The filter leaves out the states of what it does not use, last first: the magnetometer's heading
offset without the magnetometer, the GNSS delay without ``delay_state`` (they would only cost time:
nothing observes them).
"""
from __future__ import annotations

import math
from enum import IntEnum
from typing import Mapping, NamedTuple

import numpy as np

__all__ = ["Fs", "state_size", "per_state", "InitialState", "initial_state", "ROLL_GAIN_MAX"]

ROLL_GAIN_MAX = 0.5
"""Bound of ``K_AY``: the roll's gravity is a fraction of the lateral acceleration (0.05-0.2 for a car)."""
ROLL_GAIN_OFF = 1e-6
"""The std of ``K_AY`` with ``roll_gain_std0 = 0`` (and no process noise): held at zero, yet the covariance stays
positive definite (a fix is applied only to a positive-definite covariance)."""


class Fs(IntEnum):
    """State of the fusion filter.

    ``VX``, ``VY`` body-frame velocity [m/s]; ``PSI`` heading [rad]; ``B_R`` gyro offset [rad/s];
    ``B_AX``, ``B_AY`` accelerometer offsets [m/s2]; ``D_DELTA`` steering offset [rad]; ``LN_CF``,
    ``LN_CR`` log cornering-stiffness scales of the axles; ``LN_MU`` log friction; ``E_W`` rolling-radius
    error; ``G_Y`` the road bank's gravity term ``g sin(bank)`` in the lateral accelerometer [m/s2],
    which moves the car but is not a tire force (``B_AY``, the sensor's offset, is in both); ``K_AY`` the roll's
    gravity in the lateral accelerometer that the vehicle file's roll model misses, per unit of lateral
    acceleration (a roll gradient off, a log in a level frame: in both, like the offset); ``D_GNSS`` the GNSS delay
    [s]; ``B_MAG`` the magnetometer's heading offset [rad] (a declination or iron error).
    """
    VX, VY, PSI, B_R, B_AX, B_AY, D_DELTA, LN_CF, LN_CR, LN_MU, E_W, G_Y, K_AY, D_GNSS, B_MAG = range(15)


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


class InitialState(NamedTuple):
    """The filter's start and its per-state noise (:func:`initial_state`)."""

    x0: np.ndarray              #: initial state
    p0: np.ndarray              #: initial variances
    q: np.ndarray               #: process noise per sample (variances)
    p_cap: np.ndarray           #: variance beyond which a state gets no process noise (its prior's; none for
    #                              the velocity and the heading)
    bounds: tuple               #: ``(state, low, high)`` of the bounded states


def initial_state(cfg) -> InitialState:
    """The fusion filter's initial state, variances, process noise, caps and bounds from its configuration
    (:class:`~sideslip.estimators.fusion.config.SideslipFusionConfig`)."""
    ts, n = cfg.Ts, state_size(cfg.delay_state, cfg.use_magnetometer)
    x0 = np.zeros(n)
    if cfg.delay_state:
        x0[Fs.D_GNSS] = cfg.gps_latency
    x0[Fs.LN_MU] = math.log(cfg.mu0)
    p0 = per_state({Fs.VX: 1.0, Fs.VY: 1.0, Fs.PSI: 10.0, Fs.B_R: cfg.gyro_offset_std0,
                    Fs.B_AX: cfg.accel_offset_std0, Fs.B_AY: cfg.accel_offset_std0, Fs.D_DELTA: cfg.steer_offset_std0,
                    Fs.LN_CF: cfg.stiffness_std0, Fs.LN_CR: cfg.stiffness_std0, Fs.LN_MU: cfg.mu_std0,
                    Fs.E_W: cfg.radius_error_std0, Fs.G_Y: cfg.bank_std0, Fs.K_AY: max(cfg.roll_gain_std0, ROLL_GAIN_OFF),
                    Fs.D_GNSS: cfg.gps_latency_std,
                    Fs.B_MAG: cfg.mag_offset_std0}, n) ** 2
    p_cap = p0.copy()
    p_cap[[Fs.VX, Fs.VY, Fs.PSI]] = np.inf
    walk = math.sqrt(ts)
    q = per_state({Fs.VX: cfg.sigma_accel * ts, Fs.VY: cfg.sigma_accel * ts, Fs.PSI: cfg.sigma_gyro * ts,
                   Fs.B_R: cfg.gyro_offset_walk * walk, Fs.B_AX: cfg.accel_offset_walk * walk,
                   Fs.B_AY: cfg.accel_offset_walk * walk, Fs.D_DELTA: 1e-6 * walk,
                   Fs.LN_CF: cfg.stiffness_walk * walk, Fs.LN_CR: cfg.stiffness_walk * walk,
                   Fs.LN_MU: cfg.mu_walk * walk, Fs.E_W: 1e-5 * walk, Fs.G_Y: cfg.bank_walk * walk,
                   Fs.K_AY: cfg.roll_gain_walk * walk if cfg.roll_gain_std0 > 0.0 else 0.0,
                   Fs.D_GNSS: cfg.delay_walk * walk if cfg.delay_state else 0.0,
                   Fs.B_MAG: cfg.mag_offset_walk * walk}, n) ** 2
    bounds = ((int(Fs.LN_CF), math.log(cfg.stiffness_min), math.log(cfg.stiffness_max)),
              (int(Fs.LN_CR), math.log(cfg.stiffness_min), math.log(cfg.stiffness_max)),
              (int(Fs.LN_MU), math.log(cfg.mu_min), math.log(cfg.mu_max)),
              (int(Fs.K_AY), -ROLL_GAIN_MAX, ROLL_GAIN_MAX))
    if cfg.delay_state:          # bounded by the history kept for the delayed fixes
        bounds += ((int(Fs.D_GNSS), 0.0, int(math.ceil(cfg.max_delay / ts)) * ts),)
    return InitialState(x0, p0, q, p_cap, bounds)
