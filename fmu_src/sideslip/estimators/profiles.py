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
    valid_std_max: float = valid_std_max_param()
    valid_hold: float = valid_hold_param()
    nis_limit: float = nis_limit_param(prefix=HARDENED_PREFIX)


class ProfiledEstimator(Estimator):
    """An estimator with a published and a hardened profile (``self.hardened``; a method may turn it
    off for a variant it does not harden).

    ``valid`` passes the validity gate in the hardened profile, and in the published one unless
    ``consistency_check`` is false: as published a method's own flag says little (Nguyen 2012 drifts 10 deg off
    and Yoon 2014 saws by 4 deg with it true throughout), and the consistency check of every estimator
    (:class:`~sideslip.estimators.base.Estimator`) clears it where the estimate disagrees with the single-track
    model.  ``consistency_check = false`` gives the published method's own flag, ungated: the papers' tables
    score the samples a method calls valid, as the papers do."""

    config_class = ProfiledConfig

    def reset(self) -> None:
        cfg = self.config
        self.hardened = cfg.profile == HARDENED
        self._gate = ValidityGate(cfg.valid_std_max, cfg.valid_hold) if self.hardened or cfg.consistency_check \
            else None
        super().reset()
