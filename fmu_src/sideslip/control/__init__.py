"""The LQR direct-yaw-moment controller of Nguyen 2012 section IV and the stability controller.

* :mod:`~sideslip.control.reference` - reference model (eqs 21-22), friction-limited;
* :mod:`~sideslip.control.feedforward` - feed-forward of eq 24 (python-control);
* :mod:`~sideslip.control.lqr` - LQR gains (eqs 25-26) scheduled on speed;
* :mod:`~sideslip.control.schedule` - the speed tables behind both;
* :mod:`~sideslip.control.dyc` - :class:`LqrDycController`;
* :mod:`~sideslip.control.stability` - :class:`StabilityController` (an estimator + the LQR).
"""
from .dyc import LqrDycConfig, LqrDycController, yaw_moment_limit

__all__ = ["LqrDycConfig", "LqrDycController", "yaw_moment_limit"]
