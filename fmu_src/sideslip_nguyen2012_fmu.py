"""FMU wrapper of the Nguyen 2012 multi-rate Kalman filters (library: :mod:`sideslip.estimators.nguyen2012`)."""
from sideslip.estimators.nguyen2012 import Nguyen2012Config, Nguyen2012DACMRKF as _Filter
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class Nguyen2012DACMRKF(SideslipSlave):
    """Nguyen 2012: SRKF / MRKF / disturbance-accommodating multi-rate KF on yaw rate (1 ms) and GPS course."""

    role = "estimator"
    description = ("Nguyen, Wang, Fujimoto, Hori 2012 sideslip estimation: linear Kalman filter on the bicycle "
                   "model with the in-wheel motors' yaw moment as input, yaw rate every sample and GPS course at "
                   "each fix; mode srkf [beta, r], mrkf [beta, r, psi] or dacmrkf [beta, r, psi, d1, d2]")
    model_class = _Filter
    config_class = Nguyen2012Config
