"""FMU Nguyen2012DACMRKF: the wrapper of its entry in :mod:`sideslip.fmi.catalogue`."""
from sideslip.fmi.slave import fmu_class, keep_module_dict_alive

keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive
Nguyen2012DACMRKF = fmu_class("Nguyen2012DACMRKF", __name__)  # see sideslip.fmi.slave.fmu_class
