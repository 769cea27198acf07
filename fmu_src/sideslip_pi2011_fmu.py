"""FMU wrapper of the Pi 2011 fuzzy-weighted EKF (library: :mod:`sideslip.estimators.pi2011`)."""
from sideslip.estimators.pi2011 import Pi2011Config, Pi2011FuzzyEKF as _Filter
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class Pi2011FuzzyEKF(SideslipSlave):
    """Pi 2011: side forces from sensors and an adaptive tire model blended by a fuzzy nonlinear factor, EKF."""

    role = "estimator"
    description = ("Pi, Chen, Wang, Zhang 2011 sideslip observer: axle side forces from a_y and yaw acceleration "
                   "blended with an adaptive linear tire model by a Mamdani fuzzy nonlinear factor, cornering-"
                   "stiffness identifier, EKF on [beta, Fyf, Fyr] with tire relaxation")
    model_class = _Filter
    config_class = Pi2011Config
