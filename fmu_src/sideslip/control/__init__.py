"""Yaw-moment controllers: the LQR of Nguyen 2012 section IV, a baseline ESC, the stability controller.

* :mod:`~sideslip.control.reference` - reference model (eqs 21-22), friction-limited;
* :mod:`~sideslip.control.feedforward` - feed-forward of eq 24 (python-control);
* :mod:`~sideslip.control.lqr` - LQR gains (eqs 25-26) scheduled on speed;
* :mod:`~sideslip.control.schedule` - the speed tables behind both;
* :mod:`~sideslip.control.base` - what every controller shares: speed schedule, fade-in, bumpless
  transfer, friction schedule, yaw-rate dead band, sideslip limiter, rate limit, saturation;
* :mod:`~sideslip.control.dyc` - :class:`LqrDycController`;
* :mod:`~sideslip.control.esc` - :class:`BaselineEsc` (yaw-rate PI + sideslip limiter);
* :mod:`~sideslip.control.stability` - :class:`StabilityController` (an estimator + the LQR).
"""
from .base import yaw_moment_limit
from .dyc import LqrDycConfig, LqrDycController
from .esc import BaselineEsc, EscConfig

__all__ = ["LqrDycConfig", "LqrDycController", "BaselineEsc", "EscConfig", "yaw_moment_limit"]
