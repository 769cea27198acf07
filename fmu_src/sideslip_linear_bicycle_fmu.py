"""FMU wrapper of the linear bicycle-model observer baseline (library: :mod:`sideslip.estimators.baselines`)."""
from sideslip.estimators.baselines import BicycleObserverConfig, LinearBicycleObserver as _Estimator
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class LinearBicycleObserver(SideslipSlave):
    """Baseline: linear Kalman filter on the linear bicycle model (Pi 2011 eq 20) with the yaw rate measured."""

    role = "estimator"
    description = ("Baseline sideslip estimator: linear single-track model (Pi 2011 eq 20) with nominal "
                   "cornering stiffness, corrected by the measured yaw rate (time-varying Kalman gain)")
    model_class = _Estimator
    config_class = BicycleObserverConfig
