"""The vehicle side of a closed loop, as library models.

* :mod:`~sideslip.plant.dynamics` - the 8-DOF dynamics as a pure function ``f(x, u, p)``;
* :mod:`~sideslip.plant.tires` - Dugoff and Magic Formula combined-slip tires, slip kinematics;
* :mod:`~sideslip.plant.vehicle` - :class:`~sideslip.plant.vehicle.VehiclePlant`, the dynamics integrated by RK4;
* :mod:`~sideslip.plant.sensors` - IMU, wheel speeds, steering, GPS and magnetometer models;
* :mod:`~sideslip.plant.driver`, :mod:`~sideslip.plant.maneuvers`, :mod:`~sideslip.plant.paths` -
  the maneuver driver, the maneuvers and their reference paths;
* :mod:`~sideslip.plant.loop` - driver, plant and sensors in closed loop without FMI;
* :mod:`~sideslip.plant.clock` - exact simulation time of stepped models.
"""
