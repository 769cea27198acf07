"""Feed-forward of the direct yaw moment (Nguyen 2012 eqs 23-24), scheduled on speed.

Eq 23 splits the bicycle model's sideslip response, ``beta = G_11 delta_f + G_12 N_z``, and
eq 24 picks the yaw moment that makes it the reference response ``G_beta`` of eq 21:
``G_ff = (G_beta - G_11) / G_12``.  ``G_11`` and ``G_12`` share the model's characteristic
polynomial and ``G_12`` has a constant numerator (the yaw moment reaches the sideslip only
through the yaw rate), so ``G_ff`` is a second-order polynomial ``N(s)`` over ``1 + tau_beta s``:
improper, a double differentiator of the steering.  Its static gain is zero (eq 21 asks for the
model's own steady state), so it acts only while the steering moves.

It is realised through a low-pass ``L(s)``, ``N(s) L(s) / (1 + tau_beta s)``:

* as published (:func:`first_order_lowpass`, ``tau_ff`` = 20 ms): the least that makes it proper.
  It stays a differentiator up to 8 Hz, so steering-sensor noise reaches the motors: 0.57 mrad
  (std) of white noise gives an RMS ``N_ff`` of about 450 N m on the SUV at 18 m/s;
* with a bandwidth (:func:`second_order_lowpass`, Butterworth at ``f_ff``): the steering reaches the
  motors only in the band where the yaw dynamics respond to it.  The cars' yaw modes have their
  natural frequencies at 0.8-3 Hz from 30 down to 10 m/s, the driver's steering lies below about
  2 Hz (FMVSS 126 steers at 0.7 Hz); at ``f_ff`` = 2 Hz the same noise gives about 6 N m.
  :func:`noise_gain` computes these figures.

The filter is a state-space system with the fixed denominator ``(1 + tau_beta s) D_L(s)`` in
controllable canonical form: its states are the low-passed steering and its derivatives, which
do not depend on the speed, and only the output row (the numerator) is scheduled on speed.  A
change of speed therefore changes the output only by what the new numerator makes of the same
filtered steering - zero in a steady steer, whatever the jump - rather than through a filter
state built for another speed.

python-control does the algebra (``minreal`` cancels the shared polynomial) and SciPy the
discretisation (both imported in the functions that use them: an FMU imports every module it carries
when it is instantiated, and python-control's import, about 2 s, is needed only where a feed-forward is
designed), by the bilinear (Tustin) map rather than the zero-order hold: the filter is fast
next to its reference, and the ZOH filter's samples, held by the plant for a whole step, miss the
target.  On the SUV at 80 km/h with a 0.7 Hz steer (1 ms), the linear model's sideslip deviates
from ``G_beta delta`` by 9.4 / 2.3 / 0.46 % of its peak with Tustin for ``tau_ff`` = 20 / 5 / 1 ms,
and by 10.6 / 15 / 81 % with the ZOH (tests/test_control.py).  The bilinear map keeps the states'
coordinates (``A``, ``B`` are fixed), and its output row is linear in the continuous one, so
interpolating the discrete rows between grid speeds is interpolating the numerator.
"""
from __future__ import annotations

import math
import warnings
from functools import lru_cache

import numpy as np

from ..bicycle import BicycleModel
from .schedule import SpeedTable, speed_grid

__all__ = ["sideslip_responses", "reference_sideslip", "eq24_numerator", "first_order_lowpass",
           "second_order_lowpass", "feedforward_tf", "noise_gain", "ScheduledFeedforward"]


def sideslip_responses(model: BicycleModel, vx: float) -> tuple[control.TransferFunction, control.TransferFunction]:
    """``G_11`` (steering -> sideslip) and ``G_12`` (yaw moment -> sideslip) of eq 23 at ``vx``.

    Written from ``(sI - A)^-1 B`` by Cramer's rule rather than ``ss2tf``, whose round-off
    leaves a spurious ``1e-15 s`` in the numerator of ``G_12`` that spoils the division of eq 24.
    """
    import control

    a, b = model.matrices(vx)
    den = [1.0, -(a[0, 0] + a[1, 1]), a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]]
    g11 = control.tf([b[0, 0], a[0, 1] * b[1, 0] - a[1, 1] * b[0, 0]], den)
    g12 = control.tf([a[0, 1] * b[1, 1]], den)
    return g11, g12


def reference_sideslip(model: BicycleModel, vx: float, tau_beta: float) -> control.TransferFunction:
    """``G_beta`` of eq 21: the steady-state sideslip gain through the lag ``1 / (1 + tau_beta s)``."""
    import control

    return control.tf([model.steady_state_gains(vx)[0]], [tau_beta, 1.0])


def eq24_numerator(model: BicycleModel, vx: float, tau_beta: float) -> np.ndarray:
    """``N(s)`` with ``G_ff = N(s) / (1 + tau_beta s)`` (eq 24), coefficients highest power first [N m/rad]."""
    import control

    g11, g12 = sideslip_responses(model, vx)
    lag = control.tf([tau_beta, 1.0], [1.0])
    with warnings.catch_warnings():            # the intermediate (G_beta - G_11)/G_12 * lag is improper
        warnings.simplefilter("ignore")
        poly = control.minreal((reference_sideslip(model, vx, tau_beta) - g11) / g12 * lag, verbose=False)
    num = np.atleast_1d(np.squeeze(poly.num[0][0])) / float(np.squeeze(poly.den[0][0]))
    if np.size(np.atleast_1d(np.squeeze(poly.den[0][0]))) != 1 or num.size > 3:
        raise ArithmeticError("eq 24 did not reduce to a polynomial over the reference lag")
    return num


def first_order_lowpass(tau: float) -> control.TransferFunction:
    """``1 / (1 + tau s)``: the published realisation's proper-ing low-pass."""
    import control

    return control.tf([1.0], [tau, 1.0])


def second_order_lowpass(f: float) -> control.TransferFunction:
    """Second-order Butterworth low-pass with its -3 dB frequency at ``f`` [Hz]."""
    import control

    w = 2.0 * math.pi * f
    return control.tf([w * w], [1.0, math.sqrt(2.0) * w, w * w])


def feedforward_tf(model: BicycleModel, vx: float, tau_beta: float,
                   lowpass: control.TransferFunction | float) -> control.TransferFunction:
    """The realised feed-forward ``N(s) L(s) / (1 + tau_beta s)`` of eq 24 at ``vx`` [N m/rad].

    ``lowpass`` is ``L(s)``, or a time constant [s] for :func:`first_order_lowpass`.
    """
    import control

    if not isinstance(lowpass, control.TransferFunction):
        lowpass = first_order_lowpass(float(lowpass))
    lp_num, lp_den = (np.atleast_1d(np.squeeze(p[0][0])) for p in (lowpass.num, lowpass.den))
    return control.tf(np.polymul(eq24_numerator(model, vx, tau_beta), lp_num), np.polymul([tau_beta, 1.0], lp_den))


def noise_gain(model: BicycleModel, vx: float, tau_beta: float, lowpass, Ts: float, hold: int = 1) -> float:
    """RMS ``N_ff`` [N m] per rad (std) of white steering noise, for the filter sampled every ``Ts`` [s] and
    a sensor whose samples are held for ``hold`` filter samples (100 Hz into 1 kHz: 10).

    The output's variance, averaged over the hold phase, is the energy of the response to one held
    sample divided by ``hold``.
    """
    a, b, c, d = _discrete(feedforward_tf(model, vx, tau_beta, lowpass), Ts)
    x, total = np.zeros(a.shape[0]), 0.0
    for k in range(int(20.0 / Ts)):                  # 20 s: every pole has decayed by then
        u = 1.0 if k < hold else 0.0
        total += float(c[0] @ x + d[0, 0] * u) ** 2
        x = a @ x + b[:, 0] * u
    return math.sqrt(total / hold)


def _discrete(tf: control.TransferFunction, Ts: float):
    import scipy.signal

    num, den = (np.atleast_1d(np.squeeze(p[0][0])) for p in (tf.num, tf.den))
    a, b, c, d = scipy.signal.tf2ss(num, den)                  # controllable canonical form: A, B from den only
    return scipy.signal.cont2discrete((a, b, c, d), Ts, method="bilinear")[:4]


@lru_cache(maxsize=64)
def _discrete_schedule(model: BicycleModel, tau_beta: float, lowpass: tuple, Ts: float, v_lo: float,
                       v_hi: float, n: int) -> tuple:
    """Grid, output rows ``[C_d, D_d]`` and the fixed ``(A_d, B_d)`` of the feed-forward.

    Cached: it depends on the model and time constants only, not on the LQR weights, so a
    tuning study computes it once per worker process.  ``lowpass`` is ``(numerator, denominator)``.
    """
    import control

    lp = control.tf(*lowpass)
    grid = speed_grid(v_lo, v_hi, n)
    rows, fixed = [], None
    for v in grid:
        a, b, c, d = _discrete(feedforward_tf(model, v, tau_beta, lp), Ts)
        if fixed is None:
            fixed = a, b
        elif not (np.allclose(a, fixed[0], rtol=1e-12, atol=0) and np.allclose(b, fixed[1], rtol=1e-12, atol=0)):
            raise ArithmeticError("feed-forward states vary with speed")            # see module docstring
        rows.append((*c[0], d[0, 0]))
    return tuple(grid), tuple(rows), tuple(map(tuple, fixed[0])), tuple(fixed[1][:, 0])


class ScheduledFeedforward:
    """Discrete feed-forward filter ``delta_f -> N_z_ff`` with its output row scheduled on speed.

    Parameters
    ----------
    model : BicycleModel
        Nominal model the feed-forward inverts.
    tau_beta : float
        Reference-lag time constant [s].
    lowpass : control.TransferFunction or float
        The realisation's low-pass ``L(s)``, or a time constant [s] (first order).
    Ts : float
        Sample period [s].
    v_lo, v_hi : float
        Speed range of the grid [m/s].
    """

    def __init__(self, model: BicycleModel, tau_beta: float, lowpass, Ts: float, v_lo: float, v_hi: float,
                 n: int = 32):
        import control

        if not isinstance(lowpass, control.TransferFunction):
            lowpass = first_order_lowpass(float(lowpass))
        key = tuple(tuple(np.atleast_1d(np.squeeze(p[0][0])).tolist()) for p in (lowpass.num, lowpass.den))
        grid, rows, a, b = _discrete_schedule(model, tau_beta, key, Ts, v_lo, v_hi, n)
        self.output_row = SpeedTable(grid, rows)
        self.a, self.b = [list(r) for r in a], list(b)
        self.reset()

    def reset(self) -> None:
        """Zero filter state."""
        self._x = [0.0] * len(self.b)
        self._next = [0.0] * len(self.b)

    def step(self, delta: float, vx: float) -> float:
        """One sample: feed-forward yaw moment [N m] for steering ``delta`` [rad] at ``vx`` [m/s]."""
        row, x, nxt = self.output_row(vx), self._x, self._next
        n = len(x)
        y = row[n] * delta
        for i in range(n):
            y += row[i] * x[i]
        for i, (ai, bi) in enumerate(zip(self.a, self.b)):
            s = bi * delta
            for j in range(n):
                s += ai[j] * x[j]
            nxt[i] = s
        self._x, self._next = nxt, x
        return y
