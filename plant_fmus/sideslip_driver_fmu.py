"""FMU wrapper of the maneuver driver (library: :mod:`sideslip.plant.driver`)."""
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive
from sideslip.plant.driver import Driver, DriverConfig


keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive

class ManeuverDriver(SideslipSlave):
    """Speed controller, path follower / open-loop steering, and the scenario's road and wind."""

    role = "driver"
    description = ("Maneuver driver: speed controller on drive/brake torque, pure-pursuit path follower or "
                   "open-loop handwheel profile (sine, step, J-turn, sine with dwell, ISO 3888-1 DLC, lane "
                   "change, slalom, circle, brake in turn, 3 km track); emits road friction, bank and wind")
    model_class = Driver
    config_class = DriverConfig
