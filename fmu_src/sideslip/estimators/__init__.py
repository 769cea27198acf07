"""Sideslip estimators: one module per paper, the shared Kalman core and the baselines.

Every estimator is a :class:`~sideslip.estimators.base.Estimator`: construct it with its
config (or the defaults), call ``step(h, *inputs)`` with the inputs named by ``input_names``
and read ``outputs()`` / ``output_dict()``.
"""
from .base import Estimator, EstimatorConfig
from .baselines import BicycleObserverConfig, LinearBicycleObserver, OpenLoopConfig, OpenLoopKinematic
from .kalman import KalmanFilter
from .kim2016 import Kim2016Config, Kim2016SteeringEKF
from .park2018 import Park2018Config, Park2018Observer

ESTIMATORS = {cls.__name__: cls for cls in (Park2018Observer, Kim2016SteeringEKF, OpenLoopKinematic,
                                            LinearBicycleObserver)}
"""Estimator classes by name (each FMU of role ``estimator`` carries the same name)."""

__all__ = ["ESTIMATORS", "Estimator", "EstimatorConfig", "KalmanFilter", "OpenLoopKinematic", "OpenLoopConfig",
           "LinearBicycleObserver", "BicycleObserverConfig", "Park2018Observer", "Park2018Config",
           "Kim2016SteeringEKF", "Kim2016Config"]
