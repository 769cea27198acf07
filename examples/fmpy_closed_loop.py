"""A closed loop written directly against the master: driver, plant and sensors FMUs through fmpy.

Shows the three things a script needs: components with parameters, the run, and the recorded
fields ``<instance>.<variable>``.  Connections are made by equal names.
"""

import numpy as np

from sideslip.cosim.assembly import Component
from sideslip.cosim.master import CoSimulation


def run(show_plot=True, duration=8.0):
    """SUV on mu 0.5: 0.5 Hz sine steer of 60 deg at the handwheel, 80 km/h."""
    maneuver = "sine_steer:v0=22.2,v=22.2,amplitude=1.05,frequency=0.5,cycles=2,t_start=1"
    components = [
        Component("ManeuverDriver", "driver", {"vehicle": "pi2011_suv", "maneuver": maneuver, "road_mu": "0.5"}),
        Component("VehiclePlant", "plant", {"vehicle": "pi2011_suv", "vx0": 22.2}),
        Component("VehicleSensors", "sensors", {"seed": 1, "ay_sigma": 0.1, "gps_rate": 10.0}),
    ]
    with CoSimulation(components, step=1e-3) as sim:
        res = sim.run(duration)
    beta = np.degrees(res["plant.beta"])
    print(f"{res.meta['real_time_factor']:.1f}x real time; max |beta| {np.abs(beta).max():.2f} deg; "
          f"max |ay_m| {np.abs(res['sensors.ay_m']).max():.2f} m/s2; GPS fixes {res['sensors.gps_fresh'].sum()}")
    if show_plot:
        import matplotlib.pyplot as plt

        plt.plot(res["time"], beta, label="beta [deg]")
        plt.plot(res["time"], np.degrees(res["plant.yaw_rate"]) / 10, label="yaw rate / 10 [deg/s]")
        plt.xlabel("time [s]")
        plt.legend()
        plt.show()
    return res


if __name__ == "__main__":
    run()
