"""FMU wrapper of the open-loop kinematic baseline (library: :mod:`sideslip.estimators.baselines`)."""
from sideslip.estimators.baselines import OpenLoopConfig, OpenLoopKinematic as _Estimator
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class OpenLoopKinematic(SideslipSlave):
    """Baseline: direct integration of d(beta)/dt = a_y / v_x - r (Pi 2011 eqs 21-22)."""

    role = "estimator"
    description = ("Baseline sideslip estimator: direct integration of the kinematic relation "
                   "d(beta)/dt = (a_y + g sin(bank)) / v_x - r (Pi 2011 eq 22); drifts with sensor bias")
    model_class = _Estimator
    config_class = OpenLoopConfig
