"""Reference paths for the path-following driver: sampled centre lines with station and curvature.

All paths start at the origin heading east unless stated.  Lateral-offset maneuvers
(ISO 3888-1 double lane change, single lane change, slalom) are written as ``Y(X)`` with
smooth (raised-cosine) transitions; circuits are chains of straights and arcs.
"""
from __future__ import annotations

import math
from bisect import bisect_right

import numpy as np

__all__ = ["Path", "offset_path", "iso3888_dlc_offsets", "lane_change_offsets", "slalom_offsets",
           "arc_chain", "closed_track"]


class Path:
    """A planar reference line sampled at (roughly) constant spacing.

    Parameters
    ----------
    x, y : array_like
        Sample points [m] in ENU (at least 2, consecutive points distinct).
    closed : bool
        Whether the last point connects back to the first (circuits).
    """

    def __init__(self, x, y, closed: bool = False):
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if x.shape != y.shape or x.size < 2:
            raise ValueError("a path needs at least two points")
        seg = np.hypot(np.diff(x), np.diff(y))
        if np.any(seg <= 0):
            raise ValueError("consecutive path points must differ")
        self.x, self.y, self.closed = x, y, closed
        self.s = np.concatenate(([0.0], np.cumsum(seg)))
        self.length = float(self.s[-1] + (math.hypot(x[0] - x[-1], y[0] - y[-1]) if closed else 0.0))
        self.psi = np.unwrap(np.arctan2(np.gradient(y), np.gradient(x)))
        dpsi = np.gradient(self.psi)
        ds = np.gradient(self.s)
        self.kappa = dpsi / ds
        self._xl, self._yl, self._sl = x.tolist(), y.tolist(), self.s.tolist()
        # each segment's direction, squared length and length (the last one closes a closed path)
        xl, yl = self._xl, self._yl
        self._ex = [xl[(a + 1) % len(xl)] - xl[a] for a in range(len(xl))]
        self._ey = [yl[(a + 1) % len(yl)] - yl[a] for a in range(len(yl))]
        self._seg2 = [ex * ex + ey * ey for ex, ey in zip(self._ex, self._ey)]
        self._seg = [math.sqrt(s2) for s2 in self._seg2]

    def project(self, px: float, py: float, hint: int = 0) -> tuple[int, float]:
        """Nearest sample index and continuous station of the foot point of ``(px, py)``.

        The nearest sample is found by hill-climbing from ``hint`` (O(1) per call while the
        vehicle advances a few samples per step, and it keeps the follower on the right
        branch where a path crosses itself); the station is then the orthogonal projection
        onto the adjacent segment, so it moves smoothly instead of in sample-sized jumps.
        """
        xl, yl, sl, n, closed = self._xl, self._yl, self._sl, len(self._xl), self.closed
        # (the distances inline: this runs every driver step, and a call costs as much as the arithmetic)
        i = hint % n if closed else (0 if hint < 0 else (n - 1 if hint > n - 1 else hint))
        dx, dy = xl[i] - px, yl[i] - py
        d = dx * dx + dy * dy
        for direction in (1, -1):
            moved = False
            while True:
                j = i + direction
                if closed:
                    j %= n
                elif not 0 <= j < n:
                    break
                dx, dy = xl[j] - px, yl[j] - py
                dj = dx * dx + dy * dy
                if dj >= d:
                    break
                i, d, moved = j, dj, True
            if moved:           # the sample it came from lies farther: no need to look back
                break
        # foot point on the segment after i, else on the one before it
        for a in (i, i - 1):
            if closed:
                a %= n
            elif a < 0 or a + 1 >= n:
                continue
            ex, ey = self._ex[a], self._ey[a]
            w = ((px - xl[a]) * ex + (py - yl[a]) * ey) / self._seg2[a]
            if 0.0 <= w <= 1.0:
                return i, sl[a] + w * self._seg[a]
        return i, sl[i]

    def point_at(self, station: float) -> tuple[float, float]:
        """Point at station ``station`` [m]: wrapped on closed paths; before the start and past
        the end of an open path, continued along the first / last heading."""
        sl, xl, yl = self._sl, self._xl, self._yl
        if self.closed:
            station %= sl[-1]
        elif station > sl[-1] or station < 0.0:
            i = len(sl) - 1 if station > 0.0 else 0
            psi = self.psi[i]
            over = station - sl[i]
            return xl[i] + over * math.cos(psi), yl[i] + over * math.sin(psi)
        i = bisect_right(sl, station) - 1
        i = 0 if i < 0 else (len(sl) - 2 if i > len(sl) - 2 else i)
        w = (station - sl[i]) / (sl[i + 1] - sl[i])
        return xl[i] + w * (xl[i + 1] - xl[i]), yl[i] + w * (yl[i + 1] - yl[i])

    def curvature_at(self, station: float) -> float:
        """Curvature [1/m] at ``station`` (nearest sample; positive turning left)."""
        if self.closed:
            station %= self.s[-1]
        i = int(np.clip(np.searchsorted(self.s, station), 0, len(self._sl) - 1))
        return float(self.kappa[i])


def _raised_cosine(u: np.ndarray) -> np.ndarray:
    """0 -> 1 smooth step on u in [0, 1] (continuous slope)."""
    u = np.clip(u, 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(math.pi * u))


def offset_path(lead_in: float, offsets, tail: float = 200.0, ds: float = 0.5) -> Path:
    """Path ``Y(X)`` along east: straight ``lead_in`` then piecewise raised-cosine offsets.

    Parameters
    ----------
    lead_in : float
        Straight length before the first transition [m].
    offsets : sequence of (length, target_offset)
        Each item moves the lateral offset to ``target_offset`` [m] over ``length`` [m]
        (``length`` of a hold segment with unchanged target gives a straight).
    tail : float
        Straight length after the last segment [m].
    """
    total = lead_in + sum(length for length, _ in offsets) + tail
    x = np.arange(0.0, total + ds, ds)
    y = np.zeros_like(x)
    start, y0 = lead_in, 0.0
    for length, target in offsets:
        inside = x >= start
        y[inside] = y0 + (target - y0) * _raised_cosine((x[inside] - start) / length)
        start += length
        y0 = target
    return Path(x, y)


def iso3888_dlc_offsets(offset: float = 3.5) -> list[tuple[float, float]]:
    """ISO 3888-1 double lane change section lengths with the centre-line offset [m].

    Sections: 15 m entry lane, 30 m change, 25 m offset lane, 25 m change back, 15 m
    exit lane (the raised cosines pass through the gates' centres).
    """
    return [(15.0, 0.0), (30.0, offset), (25.0, offset), (25.0, 0.0), (15.0, 0.0)]


def lane_change_offsets(offset: float = 3.5, length: float = 30.0) -> list[tuple[float, float]]:
    """Single lane change: one raised-cosine transition of ``length`` to ``offset``."""
    return [(length, offset), (30.0, offset)]


def slalom_offsets(spacing: float, amplitude: float, cones: int) -> list[tuple[float, float]]:
    """Slalom: alternate lateral offsets ``+/-amplitude`` at each cone, ``spacing`` apart."""
    segs = [(0.5 * spacing, amplitude)]
    sign = -1.0
    for _ in range(cones - 1):
        segs.append((spacing, sign * amplitude))
        sign = -sign
    segs.append((0.5 * spacing, 0.0))
    return segs


def arc_chain(segments, ds: float = 0.5, x0: float = 0.0, y0: float = 0.0, psi0: float = 0.0,
              closed: bool = False) -> Path:
    """Chain of straights and arcs.

    Parameters
    ----------
    segments : sequence of (length, radius)
        ``radius = inf`` for a straight; positive radius turns left, negative right.
    """
    xs, ys = [x0], [y0]
    x, y, psi = x0, y0, psi0
    for length, radius in segments:
        n = max(1, int(math.ceil(length / ds)))
        step = length / n
        for _ in range(n):
            if math.isinf(radius):
                x += step * math.cos(psi)
                y += step * math.sin(psi)
            else:
                dpsi = step / radius
                # exact chord of the arc
                chord = 2.0 * radius * math.sin(0.5 * dpsi)
                x += chord * math.cos(psi + 0.5 * dpsi)
                y += chord * math.sin(psi + 0.5 * dpsi)
                psi += dpsi
            xs.append(x)
            ys.append(y)
    if closed:
        xs, ys = xs[:-1], ys[:-1]
    return Path(xs, ys, closed=closed)


def closed_track() -> Path:
    """A closed circuit of about 3 km with curves of radius 40, 60, 80, 120 and 150 m.

    Layout (counter-clockwise): 400 m straight, R120 left 90 deg, 200 m, R60 left 90 deg,
    R40 right 90 deg, R40 left 90 deg, straight, R80 left 90 deg, straight, R150 left 90 deg,
    closing straight.  The three free straights are solved so that the loop closes.
    """
    q = 0.5 * math.pi
    inf = math.inf
    # headings: E -> N -> W -> N -> W, then free straights s7 (west), s9 (south), s11 (east)
    fixed = [(400.0, inf), (120 * q, 120.0), (200.0, inf), (60 * q, 60.0), (40 * q, -40.0), (40 * q, 40.0)]
    p = arc_chain(fixed, ds=0.5)
    xa, ya = p.x[-1], p.y[-1]                       # end heading west
    # after s7 west: R80 left (west -> south): displacement (-80, -80)
    # after s9 south: R150 left (south -> east): displacement (+150, -150)
    # after s11 east: back to the origin
    # y: ya - 80 - s9 - 150 = 0  -> s9 ;  x: xa - s7 - 80 + 150 + s11 = 0 with s11 chosen for ~3 km
    s9 = ya - 80.0 - 150.0
    total_fixed = sum(length for length, _ in fixed) + 80 * q + 150 * q + s9
    s11 = 0.5 * ((3000.0 - total_fixed) - (xa - 80.0 + 150.0))
    s7 = xa - 80.0 + 150.0 + s11
    if min(s7, s9, s11) <= 0:  # pragma: no cover - geometry constants above guarantee this
        raise RuntimeError("track does not close")
    segs = fixed + [(s7, inf), (80 * q, 80.0), (s9, inf), (150 * q, 150.0), (s11, inf)]
    return arc_chain(segs, ds=0.5, closed=True)
