"""FMU wrapper of the estimator + LQR stability controller (library: :mod:`sideslip.control.stability`)."""
from sideslip.control.stability import StabilityController as _Controller
from sideslip.control.stability import StabilityControllerConfig
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class StabilityController(SideslipSlave):
    """A sideslip estimator (any of the project's, chosen by parameter) in front of the LQR yaw-moment controller."""

    role = "controller"
    description = ("Vehicle stability controller in one block: sensor signals in, direct-yaw-moment command out. "
                   "Embeds the sideslip estimator named by the parameter 'estimator' and the LQR controller of "
                   "Nguyen et al. 2012 section IV")
    model_class = _Controller
    config_class = StabilityControllerConfig
