"""FMU wrapper of the sensor suite (library: :mod:`sideslip.plant.sensors`)."""
from sideslip.fmi.slave import SideslipSlave, keep_module_dict_alive
from sideslip.plant.sensors import SensorConfig, SensorSuite


keep_module_dict_alive(globals())  # see sideslip.fmi.slave.keep_module_dict_alive

class VehicleSensors(SideslipSlave):
    """IMU, wheel speeds, steering angle, single-antenna GPS and magnetometer."""

    role = "sensors"
    description = ("Vehicle sensors: IMU, wheel speeds with rolling-radius error, steering-angle sensor with "
                   "fault injection, single-antenna GPS (rate, delay, outages) and 3-axis magnetometer with "
                   "disturbance episodes; per-sensor rate, noise and bias; seeded")
    model_class = SensorSuite
    config_class = SensorConfig
