"""FMU wrapper of the Yoon & Peng 2014 dual Kalman filters (library: :mod:`sideslip.estimators.yoon2014`)."""
from sideslip.estimators.yoon2014 import Yoon2014Config, Yoon2014DualKF as _Filter
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class Yoon2014DualKF(SideslipSlave):
    """Yoon & Peng 2014: heading EKF on gyro + magnetometer with disturbance rejection, sideslip KF on GPS velocity."""

    role = "estimator"
    description = ("Yoon & Peng 2014 sideslip estimation: heading EKF (yaw, roll) on gyros and a 3-axis "
                   "magnetometer with magnetic-disturbance rejection, sideslip KF on [U, b_x, V, b_y] with GPS "
                   "velocity, measurement shifting for the GPS delay, delay identification, bicycle model in "
                   "straight driving")
    model_class = _Filter
    config_class = Yoon2014Config
