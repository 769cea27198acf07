"""FMU wrapper of the 8-DOF vehicle plant (library: :mod:`sideslip.plant.vehicle`)."""
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive
from sideslip.plant.vehicle import PlantConfig
from sideslip.plant.vehicle import VehiclePlant as _VehiclePlantModel


keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive

class VehiclePlant(SideslipSlave):
    """8-DOF vehicle (Pi 2011 section 2) with Dugoff tires, load transfer and in-wheel motors."""

    role = "plant"
    description = ("8-DOF vehicle plant (longitudinal, lateral, yaw, roll, four wheel spins) with Dugoff "
                   "combined-slip tires, quasi-static load transfer, bank gravity, drive/brake split and "
                   "in-wheel motors realising Mz_dyc; RK4 with adaptive internal sub-steps")
    model_class = _VehiclePlantModel
    config_class = PlantConfig
