"""The two profiles of every paper's estimator: the method as published and hardened.

Each paper's estimator has a ``profile`` parameter: ``0`` the method as published (the papers' tables are
computed with it) and ``1`` hardened for sensors and vehicles other than the paper's (the default).

One style for all five: an estimator's ``_sample`` is the paper's sample, stage by stage, each stage
citing its equations.  Where the hardened profile departs from the paper, the stage calls a *hook*, a
method whose name starts with ``_hardened_`` and that only the hardened profile calls
(``if self.hardened:``); what a hook adds is documented in the method's module docstring, with the
failure it answers.  So the published method reads as the paper, and each addition lives in one
place.  What the hooks of several methods share: the validity gate of :class:`ProfiledEstimator`
(:class:`~sideslip.estimators.base.ValidityGate`), the innovation monitor
(:class:`~sideslip.estimators.kalman.InnovationMonitor`), the linear-tire checks
(:mod:`~sideslip.estimators.model_trust`) and the GPS delay (:mod:`~sideslip.estimators.delay`).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..params import param
from .base import Estimator, EstimatorConfig, ValidityGate, nis_limit_param, valid_hold_param, valid_std_max_param

__all__ = ["PUBLISHED", "HARDENED", "HARDENED_PREFIX", "ProfiledConfig", "ProfiledEstimator"]

PUBLISHED, HARDENED = 0, 1
"""Values of the ``profile`` parameter."""

HARDENED_PREFIX = "Hardened: "
"""Starts the description of a parameter only the hardened profile uses."""


@dataclass(frozen=True)
class ProfiledConfig(EstimatorConfig):
    """:class:`~sideslip.estimators.base.EstimatorConfig` plus the choice of profile."""

    profile: int = param(1, "Dimensionless", "0: the method as published (the papers' tables); 1: hardened for "
                         "sensors and vehicles other than the paper's (each addition documented with the method)",
                         choices=(PUBLISHED, HARDENED))
    valid_std_max: float = valid_std_max_param(prefix=HARDENED_PREFIX)
    valid_hold: float = valid_hold_param(prefix=HARDENED_PREFIX)
    nis_limit: float = nis_limit_param(prefix=HARDENED_PREFIX)



class ProfiledEstimator(Estimator):
    """An estimator with a published and a hardened profile (``self.hardened``; a method may turn it
    off for a variant it does not harden)."""

    config_class = ProfiledConfig

    def reset(self) -> None:
        self.hardened = self.config.profile == HARDENED
        self._gate = ValidityGate(self.config.valid_std_max, self.config.valid_hold)
        super().reset()

    def _pack(self) -> tuple:
        out = super()._pack()
        return self._gate(self, out) if self.hardened else out
