"""The protocol every library model follows (plant, sensors, driver, estimators, controller).

A model declares ``input_names`` and ``output_names`` (signal-catalogue names), advances with
``step(h, *inputs)`` (inputs in ``input_names`` order, held over the step) and exposes
``outputs()`` in ``output_names`` order as floats (Booleans as 0.0/1.0).  The FMU toolkit and
the library loop rely only on this protocol.
"""
from __future__ import annotations

from .plant.clock import StepClock

__all__ = ["Model"]


class Model:
    """Base of the library models: exact step clock, output access, step-size check.

    Subclasses set ``input_names``/``output_names``, keep their current outputs in
    ``self._out`` and start :meth:`step` with ``t = self._tick(h)``.
    """

    input_names: tuple = ()
    output_names: tuple = ()
    _out: tuple | list = ()

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
