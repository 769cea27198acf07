"""The library without FMI: plant, driver, sensors and an estimator as plain Python objects in a loop."""
import math

import numpy as np

from sideslip.estimators import Park2018Config, Park2018Observer
from sideslip.plant.driver import Driver, DriverConfig
from sideslip.plant.loop import run_loop
from sideslip.plant.sensors import SensorConfig, SensorSuite
from sideslip.plant.vehicle import PlantConfig, VehiclePlant


def run(show_plot=True, duration=24.0):
    """Park 2018 Sonata: 11 s straight (the offset compensator learns the sensor offsets), then a 25 m circle at
    9 m/s; Park's observer estimates the sideslip."""
    driver = Driver(DriverConfig(vehicle="park2018_sonata",
                                 maneuver="circle:v0=7,v=9,t_go=4,accel=1,radius=25,lead_in=90"))
    plant = VehiclePlant(PlantConfig(vehicle="park2018_sonata", vx0=7.0))
    sensors = SensorSuite(SensorConfig(seed=2, ay_sigma=0.05, ay_bias=0.1, yaw_rate_bias=0.005, gps_rate=20.0))
    park = Park2018Observer(Park2018Config(vehicle="park2018_sonata"))
    res = run_loop(plant, driver, duration, sensors=sensors, observers={"park": park})
    bias = np.mean(res["ay_m"][-2000:] - res["ay"][-2000:])
    err = np.degrees(res["park.beta_hat"] - res["beta"])[res["time"] > 6.0]
    print(f"final ay {res['ay'][-1]:.2f} m/s2 (v^2/R = {res['vx'][-1] ** 2 / 25:.2f}), measured ay bias {bias:.3f}, "
          f"compensated offset {-res['park.offset_ay'][-1]:.3f}; max beta {math.degrees(np.abs(res['beta']).max()):.2f} "
          f"deg, Park 2018 error RMS {np.sqrt(np.mean(err ** 2)):.3f} deg")
    if show_plot:
        import matplotlib.pyplot as plt

        plt.plot(res["time"], np.degrees(res["beta"]), label="truth")
        plt.plot(res["time"], np.degrees(res["park.beta_hat"]), label="Park 2018")
        plt.xlabel("time [s]")
        plt.ylabel("sideslip [deg]")
        plt.legend()
        plt.show()
    return res


if __name__ == "__main__":
    run()
