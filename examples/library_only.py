"""The library without FMI: plant, driver and sensors as plain Python objects in a loop."""
import math

import numpy as np

from sideslip.plant.driver import Driver, DriverConfig
from sideslip.plant.loop import run_loop
from sideslip.plant.sensors import SensorConfig, SensorSuite
from sideslip.plant.vehicle import PlantConfig, VehiclePlant


def run(show_plot=True, duration=12.0):
    """Park 2018 Sonata in a 25 m circle; compares the measured lateral acceleration with truth."""
    driver = Driver(DriverConfig(vehicle="park2018_sonata",
                                 maneuver="circle:v0=5,v=9,t_go=2,accel=1,radius=25,lead_in=10"))
    plant = VehiclePlant(PlantConfig(vehicle="park2018_sonata", vx0=5.0))
    sensors = SensorSuite(SensorConfig(seed=2, ay_sigma=0.05, ay_bias=0.1))
    res = run_loop(plant, driver, duration, sensors=sensors)
    bias = np.mean(res["ay_m"][-2000:] - res["ay"][-2000:])
    print(f"final ay {res['ay'][-1]:.2f} m/s2 (v^2/R = {res['vx'][-1] ** 2 / 25:.2f}), measured bias {bias:.3f}, "
          f"max beta {math.degrees(np.abs(res['beta']).max()):.2f} deg")
    if show_plot:
        import matplotlib.pyplot as plt

        plt.plot(res["X"], res["Y"])
        plt.axis("equal")
        plt.show()
    return res


if __name__ == "__main__":
    run()
