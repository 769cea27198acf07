"""FMU wrapper of the Kim 2016 steering-angle EKF (library: :mod:`sideslip.estimators.kim2016`)."""
from sideslip.estimators.kim2016 import Kim2016Config, Kim2016SteeringEKF as _Filter
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class Kim2016SteeringEKF(SideslipSlave):
    """Kim 2016: EKF on [beta, yaw rate, steering angle] from a_y and yaw rate, steering-sensor fault flag."""

    role = "estimator"
    description = ("Kim, Yoon, Kim 2016 EKF on [beta, yaw rate, road-wheel angle] with measurements [a_y, yaw "
                   "rate] and the wheel speed as input; flags a stuck or offset steering sensor from the "
                   "residual delta_m - delta_hat")
    model_class = _Filter
    config_class = Kim2016Config
