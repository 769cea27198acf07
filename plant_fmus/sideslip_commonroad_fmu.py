"""FMU CommonRoadPlant: the wrapper of its entry in :mod:`sideslip.fmi.catalogue`."""
from sideslip.fmi.slave import fmu_class, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive
CommonRoadPlant = fmu_class("CommonRoadPlant", __name__)  # see sideslip.fmi.slave.fmu_class
