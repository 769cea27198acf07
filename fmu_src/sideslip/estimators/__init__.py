"""Sideslip estimators: one module per paper, the shared Kalman core and the baselines.

Every estimator is a :class:`~sideslip.estimators.base.Estimator`: construct it with its
config (or the defaults), call ``step(h, *inputs)`` with the inputs named by ``input_names``
and read ``outputs()`` / ``output_dict()``.  Each paper's method has a ``profile`` parameter:
hardened (the default) or as published (:mod:`~sideslip.estimators.profiles`); the shared parts are
the Kalman core and innovation monitor (:mod:`~sideslip.estimators.kalman`), the IMM
(:mod:`~sideslip.estimators.imm`), the linear-tire checks (:mod:`~sideslip.estimators.model_trust`)
and the GPS delay (:mod:`~sideslip.estimators.delay`).  The project's own estimator is the package
:mod:`~sideslip.estimators.fusion`.
"""
from .base import Estimator, EstimatorConfig
from .fusion import SideslipFusion, SideslipFusionConfig
from .baselines import BicycleObserverConfig, LinearBicycleObserver, OpenLoopConfig, OpenLoopKinematic
from .kalman import KalmanFilter
from .kim2016 import Kim2016Config, Kim2016SteeringEKF
from .nguyen2012 import Nguyen2012Config, Nguyen2012DACMRKF
from .park2018 import Park2018Config, Park2018Observer
from .pi2011 import Pi2011Config, Pi2011FuzzyEKF
from .yoon2014 import Yoon2014Config, Yoon2014DualKF

ESTIMATORS = {cls.__name__: cls for cls in (Kim2016SteeringEKF, LinearBicycleObserver, Nguyen2012DACMRKF,
                                            OpenLoopKinematic, Park2018Observer, Pi2011FuzzyEKF, Yoon2014DualKF,
                                            SideslipFusion)}
"""Estimator classes by name (each FMU of role ``estimator`` carries the same name), in the order of the
StabilityController's ``estimator_index`` (new estimators are appended so that the numbers stay)."""

__all__ = ["ESTIMATORS", "Estimator", "EstimatorConfig", "KalmanFilter", "OpenLoopKinematic", "OpenLoopConfig",
           "LinearBicycleObserver", "BicycleObserverConfig", "Park2018Observer", "Park2018Config",
           "Kim2016SteeringEKF", "Kim2016Config", "Nguyen2012DACMRKF", "Nguyen2012Config",
           "Pi2011FuzzyEKF", "Pi2011Config", "Yoon2014DualKF", "Yoon2014Config", "SideslipFusion",
           "SideslipFusionConfig"]
