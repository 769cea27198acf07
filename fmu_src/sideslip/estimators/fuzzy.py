"""A compact Mamdani fuzzy inference system (two inputs, one output), for Pi 2011's nonlinear factor.

Written here rather than taken from a package: the maintained Python fuzzy libraries
(scikit-fuzzy, simpful) pull in networkx / sympy-sized dependencies for what is ten lines of
numpy, and their per-call overhead (~1 ms) would dominate a filter that runs every 10 ms.

Inference (Mamdani): a rule's strength is the minimum of its antecedents' memberships; the
output set is the union (maximum) of each consequent's membership function clipped at the
strengths of the rules that conclude it; the crisp output is the centroid of that set,
computed on a uniform grid of the output universe.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Trapezoid", "Mamdani"]


@dataclass(frozen=True)
class Trapezoid:
    """Membership function rising on ``[a, b]``, 1 on ``[b, c]``, falling on ``[c, d]``.

    A triangle has ``b == c``; a left (right) shoulder has ``a == b == -inf`` (``c == d ==
    inf``).
    """

    a: float
    b: float
    c: float
    d: float

    def __post_init__(self):
        if not self.a <= self.b <= self.c <= self.d:
            raise ValueError(f"trapezoid corners must be ordered, got {self.a}, {self.b}, {self.c}, {self.d}")

    def __call__(self, x) -> np.ndarray:
        """Membership of every element of ``x`` (array in, array out)."""
        x = np.asarray(x, dtype=float)
        return np.array([self.scalar(v) for v in x.ravel()]).reshape(x.shape)

    def scalar(self, x: float) -> float:
        """Membership of one float in [0, 1]."""
        if x < self.b:
            return 0.0 if x <= self.a else (x - self.a) / (self.b - self.a)
        if x > self.c:
            return 0.0 if x >= self.d else (self.d - x) / (self.d - self.c)
        return 1.0


class Mamdani:
    """Two-input, one-output Mamdani system.

    Parameters
    ----------
    in1, in2 : dict of str -> Trapezoid
        Linguistic terms of the two inputs.
    out : dict of str -> Trapezoid
        Linguistic terms of the output.
    rules : dict of (str, str) -> str
        ``(term of in1, term of in2) -> term of out`` (every rule has weight 1).
    universe : (float, float)
        Range of the output on which the centroid is taken.
    points : int
        Grid points of the output universe.
    """

    def __init__(self, in1: dict, in2: dict, out: dict, rules: dict, universe: tuple, points: int = 401):
        for (t1, t2), t_out in rules.items():
            if t1 not in in1 or t2 not in in2 or t_out not in out:
                raise ValueError(f"rule ({t1}, {t2}) -> {t_out} uses an undefined term")
        self.in1, self.in2, self.out, self.rules = dict(in1), dict(in2), dict(out), dict(rules)
        self.grid = np.linspace(universe[0], universe[1], points)
        self._out_names = list(out)
        self._out_mf = np.array([out[n](self.grid) for n in self._out_names])      # (terms, points)
        self._rule_idx = [(t1, t2, self._out_names.index(t_out)) for (t1, t2), t_out in rules.items()]

    def strengths(self, x1: float, x2: float) -> np.ndarray:
        """Firing level of each output term (max over the rules that conclude it)."""
        m1 = {n: mf.scalar(x1) for n, mf in self.in1.items()}
        m2 = {n: mf.scalar(x2) for n, mf in self.in2.items()}
        levels = [0.0] * len(self._out_names)
        for t1, t2, k in self._rule_idx:
            w = min(m1[t1], m2[t2])
            if w > levels[k]:
                levels[k] = w
        return np.array(levels)

    def evaluate(self, x1: float, x2: float) -> float:
        """Crisp output: centroid of the aggregated output set (the universe's centre if no rule fires)."""
        levels = self.strengths(x1, x2)
        agg = np.minimum(levels[:, None], self._out_mf).max(axis=0)
        total = agg.sum()
        if total <= 0.0:
            return float(0.5 * (self.grid[0] + self.grid[-1]))
        return float(agg.dot(self.grid) / total)
