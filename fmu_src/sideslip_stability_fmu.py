"""FMU StabilityController: the wrapper of its entry in :mod:`sideslip.fmi.catalogue`."""
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive


class StabilityController(SideslipSlave):
    """Model, configuration, role and description come from the catalogue entry of this name."""
