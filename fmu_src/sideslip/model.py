"""The protocol every library model follows (plant, sensors, driver, estimators, controller).

A model declares ``input_names`` and ``output_names`` (signal-catalogue names), advances with
``step(h, *inputs)`` (inputs in ``input_names`` order, held over the step) and exposes
``outputs()`` in ``output_names`` order as floats (Booleans as 0.0/1.0).  The FMU toolkit and
the library loop rely only on this protocol.  :class:`SampledModel` adds the sample clock of
the models that run their algorithm at their own period ``Ts`` (estimators, controllers).
"""
from __future__ import annotations

from .plant.clock import StepClock

__all__ = ["Model", "SampledModel"]


class Model:
    """Base of the library models: exact step clock, output access, step-size check.

    Subclasses set ``input_names``/``output_names``, keep their current outputs in
    ``self._out`` and start :meth:`step` with ``t = self._tick(h)``.
    """

    input_names: tuple = ()
    output_names: tuple = ()
    _out: tuple | list = ()
    held_inputs: int = 0
    """How many inputs of the current step are held or clamped values (set by the FMU toolkit, which
    replaces a non-finite input by its last valid value and clamps one outside its range); a model
    that reports validity reports it false while this is not 0."""

    def _reset_clock(self) -> None:
        self._clock = StepClock()

    def _tick(self, h: float) -> float:
        """Validate the step size and advance the clock; returns the time at the end of the step.

        Raises
        ------
        ValueError
            If ``h <= 0``.
        """
        if not h > 0.0:
            raise ValueError(f"step size must be > 0, got {h}")
        return self._clock.tick(h)

    @property
    def t(self) -> float:
        """Time at the end of the last step [s]."""
        return self._clock.t

    def outputs(self) -> tuple:
        """Current outputs in ``output_names`` order."""
        return tuple(self._out)

    def output_dict(self) -> dict[str, float]:
        """Current outputs as ``{name: value}``."""
        return dict(zip(self.output_names, self._out))


class SampledModel(Model):
    """A model stepped at the master's communication step that samples every ``Ts``.

    Samples fall at ``k Ts`` (k >= 1): a step may hold none (``Ts`` longer than the step,
    inputs held in between) or several (``Ts`` shorter).  Subclasses set ``self.Ts``, call
    :meth:`_reset_samples` when they reset and, in :meth:`step`, run one sample for each of
    the :meth:`_samples_due` at the end of the step.
    """

    Ts: float = 1e-3

    def _reset_samples(self) -> None:
        self._samples = 0

    def _samples_due(self, t: float) -> int:
        """Number of samples due up to time ``t`` [s] that have not run yet (marks them as run).

        A sample at ``k Ts`` is due when ``k Ts <= t`` within ``1e-9 Ts``, so that the
        rounding of ``k Ts`` and of the step clock cannot skip or repeat one.
        """
        n = 0
        while (self._samples + 1) * self.Ts <= t + 1e-9 * self.Ts:
            self._samples += 1
            n += 1
        return n
