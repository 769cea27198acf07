"""FMU wrapper of the LQR direct-yaw-moment controller (library: :mod:`sideslip.control.dyc`)."""
from sideslip.control.dyc import LqrDycConfig, LqrDycController as _Controller
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class LqrDycController(SideslipSlave):
    """Nguyen 2012 section IV: reference model, feed-forward and speed-scheduled LQR yaw-moment control."""

    role = "controller"
    description = ("LQR direct-yaw-moment controller for in-wheel-motor EVs (Nguyen et al. 2012 section IV): "
                   "friction-limited reference model (eqs 21-22), feed-forward G_ff (eq 24), LQR feedback on the "
                   "sideslip and yaw-rate errors (eqs 25-26) scheduled on speed, saturation at the motors' limit")
    model_class = _Controller
    config_class = LqrDycConfig
