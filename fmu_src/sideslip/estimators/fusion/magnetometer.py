"""The heading from the magnetometer, and the guards that keep a wrong one out.

GNSS gives the course, heading plus sideslip; without a heading of its own the filter splits the two
by the tire model, and in a long slide or a steady turn the tire model's error drifts the gyro offset
and with it the heading.  Each new reading whose field norm is within ``mag_norm_gate`` of unity gives
the heading of the tilt-compensated horizontal field
(:func:`~sideslip.geomagnetic.tilt_compensated_heading`), the tilt being the roll model's roll plus the
bank ``asin(g_y / g)``.  Its noise is the reading's over the horizontal field plus the tilt's error
(``mag_tilt_std``, ``mag_roll_error`` of the roll, the bank state's std) times ``d psi / d tilt`` (up to
``tan(inclination)``: the site's inclination itself is not needed), the latter counted once per
``mag_tilt_correlation_time`` (a tilt error lasts).  The readings are calibrated (hard and soft iron
removed, ``mag_declination`` set); what heading offset remains is the filter's state ``B_MAG``.

Two guards: a reading whose heading innovation is more than ``mag_gate`` of its std off is not used (a
disturbance whose field norm happens to be near unity), and while the mean normalised innovation of
the last second's readings, each one's error counted once, is above ``mag_nis_limit`` (until back
below half of it) none is (a hard iron not removed, whose heading error turns with the heading and
passes the gate reading by reading).  A magnetometer not wired (a zero field) fails the norm gate.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from ...constants import GRAVITY
from ...geomagnetic import tilt_compensated_heading
from ..kalman import InnovationMonitor
from .models import magnetometer_model
from .state import Fs

__all__ = ["HeadingMeasurement", "MagnetometerHeading"]

_PSI, _G_Y, _B_MAG = int(Fs.PSI), int(Fs.G_Y), int(Fs.B_MAG)


class HeadingMeasurement(NamedTuple):
    """A magnetometer's heading and its variance."""

    heading: float              #: [rad]
    variance: float             #: [rad2]


class MagnetometerHeading:
    """Headings from new, undisturbed magnetometer readings (module docstring).

    Parameters
    ----------
    config : SideslipFusionConfig
        The ``mag_*`` and ``sigma_mag`` parameters.
    ts : float
        Sample period [s].
    compiled : sideslip.plant.kernel.FusionKernel, optional
        The compiled reading (the same doubles as :meth:`_reading`); None: the Python.
    """

    __slots__ = ("config", "ts", "window", "nis", "off", "_last", "_age", "_compiled")

    def __init__(self, config, ts: float, compiled=None):
        self.config, self.ts = config, ts
        self.window = max(int(round(1.0 / ts)), 1)
        self.nis = InnovationMonitor(self.window, config.mag_nis_limit)
        self.off = False                 # the window found the readings inconsistent
        self._last, self._age = None, 0
        # a bound method, not the kernel: an FMU state takes it from its template
        self._compiled = None if compiled is None else compiled.heading

    def measure(self, mag: tuple, phi: float, x, P) -> HeadingMeasurement | None:
        """The heading of the reading ``mag`` (normalised field, sensor frame) at the roll model's roll ``phi``
        [rad], against the filter's state ``x`` and covariance ``P``; None for a held, disturbed or rejected
        reading."""
        cfg = self.config
        self._age += 1
        if mag == self._last:                           # a held sample is not a new reading
            return None
        self._last = mag
        age, self._age = self._age, 0
        what, psi_m, r, nis = (self._reading(mag, phi, x, P, age) if self._compiled is None else self._compiled(
            *mag, phi, x.item(_G_Y), x.item(_PSI), x.item(_B_MAG), P.item(_G_Y, _G_Y), P.item(_PSI, _PSI),
            P.item(_B_MAG, _B_MAG), P.item(_PSI, _B_MAG), age))
        if what == 0.0:
            return None
        # the readings' consistency, each one's error counted once: a heading error that lasts (a hard iron not
        # removed, turning with the heading) shows in the window where each reading alone passes the gate
        self.nis.add(nis)
        if what == 1.0:
            return None                                 # a disturbance whose norm is near unity: not the heading
        if cfg.mag_nis_limit > 0.0:
            # found inconsistent, the magnetometer is used again only once the window is half the limit
            ratio = self.nis.ratio if self.nis.count >= self.window else 0.0
            self.off = ratio > (0.5 if self.off else 1.0) * cfg.mag_nis_limit
            if self.off:
                return None
        return HeadingMeasurement(psi_m, r)

    def _reading(self, mag: tuple, phi: float, x, P, age: int) -> tuple:
        """What a new reading ``age`` samples after the last gives: 0 nothing (its field's norm is off, or there is
        no horizontal field), 1 its NIS only (the innovation gate rejects it), 2 a heading; the heading [rad], its
        variance [rad2] and its NIS for the consistency window (the compiled version: ``sideslip_fusion_heading``)."""
        cfg = self.config
        if not abs(math.sqrt(mag[0] ** 2 + mag[1] ** 2 + mag[2] ** 2) - 1.0) <= cfg.mag_norm_gate:
            return 0.0, 0.0, 0.0, 0.0                   # disturbed (or not a number)
        # the body's tilt: the roll model's roll on the road plus the road's bank (the state's gravity term)
        bank = math.asin(max(-0.5, min(float(x[_G_Y]) / GRAVITY, 0.5)))
        psi_m, dpsi_dtilt, h2 = tilt_compensated_heading(mag, phi + bank, cfg.mag_declination)
        if h2 < 1e-4:                                   # no horizontal field to point with
            return 0.0, 0.0, 0.0, 0.0
        # the tilt's error: the roll model's, the bank estimate's (its state's std) and the rest (pitch)
        tilt_var = (cfg.mag_tilt_std + cfg.mag_roll_error * abs(phi)) ** 2 + P.item(_G_Y, _G_Y) / GRAVITY ** 2
        # it lasts (a roll model wrong in a turn, a bank): its share counts once per correlation time
        r = cfg.sigma_mag ** 2 / h2 + dpsi_dtilt ** 2 * tilt_var * max(cfg.mag_tilt_correlation_time
                                                                        / (age * self.ts), 1.0)
        prior = P.item(_PSI, _PSI) + P.item(_B_MAG, _B_MAG) + 2.0 * P.item(_PSI, _B_MAG)
        y = math.remainder(psi_m - magnetometer_model(x).h, 2.0 * math.pi)
        nis = y * y / (prior + cfg.sigma_mag ** 2 / h2 + dpsi_dtilt ** 2 * tilt_var)
        return 1.0 if cfg.mag_gate > 0.0 and y * y > cfg.mag_gate ** 2 * (prior + r) else 2.0, psi_m, r, nis
