"""FMU wrapper of the Park 2018 integrated observer (library: :mod:`sideslip.estimators.park2018`)."""
from sideslip.estimators.park2018 import Park2018Config, Park2018Observer as _Observer
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class Park2018Observer(SideslipSlave):
    """Park 2018: offset compensator, bicycle and kinematic EKFs, weighting factor, integrated EKF."""

    role = "estimator"
    description = ("Park, Choi, Hyun, Lee 2018 integrated sideslip observer: sensor offset compensator, "
                   "bicycle-model EKF with normalised cornering stiffness, kinematic EKF on wheel speed and "
                   "GPS velocity, weighting factor K and the integrated EKF on [vx, vy, r]; open-loop fallback "
                   "during GPS outages")
    model_class = _Observer
    config_class = Park2018Config
