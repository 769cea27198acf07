"""The parameters of :class:`~sideslip.estimators.fusion.filter.SideslipFusion`."""
from __future__ import annotations

import math
from dataclasses import dataclass

from ... import geomagnetic
from ...params import param
from ..base import EstimatorConfig, nis_limit_param, valid_hold_param, valid_std_max_param
from ..delay import GpsLatencyConfig

__all__ = ["EKF", "IMM", "SideslipFusionConfig"]

EKF, IMM = 0, 1
"""Values of the ``formulation`` parameter."""


@dataclass(frozen=True)
class SideslipFusionConfig(EstimatorConfig, GpsLatencyConfig):
    """Parameters of :class:`~sideslip.estimators.fusion.filter.SideslipFusion`."""

    formulation: int = param(0, "Dimensionless", "0: one EKF; 1: IMM of a grip and a slide filter (the slide "
                             "filter's tire model slide_factor times less certain)", choices=(EKF, IMM))
    use_gnss: bool = param(True, "Dimensionless", "Use the GNSS velocity while gps_valid (false: in-vehicle sensors "
                           "only)")
    # kinematic model and offsets
    sigma_accel: float = param(0.1, "Acceleration", "Process noise of the kinematic model per filter sample as an "
                               "acceleration: the accelerometers' white noise at the sample and what the roll "
                               "compensation leaves (0.1: twice a 0.05 m/s2 automotive IMU's noise; slow errors are "
                               "the offset and bank states')", gt=0, le=10)
    sigma_gyro: float = param(0.002, "AngularVelocity", "Gyro noise for the heading's process noise", gt=0, le=1)
    gyro_offset_std0: float = param(0.015, "AngularVelocity", "Initial uncertainty of the gyro offset", gt=0, le=1)
    gyro_offset_walk: float = param(1.7e-4, "AngularVelocity", "Random walk of the gyro offset per sqrt(s) (1.7e-4: "
                                    "0.1 deg/s per 100 s, an automotive-grade gyro's drift)", gt=0, le=1)
    accel_offset_std0: float = param(0.2, "Acceleration", "Initial uncertainty of the accelerometer offsets",
                                     gt=0, le=10)
    accel_offset_walk: float = param(0.02, "Acceleration", "Random walk of the accelerometer offsets per sqrt(s): "
                                     "the sensor's drift and what a real road's changing grade and crossfall add "
                                     "(0.02: chosen on the training set's real drive and plants)", gt=0, le=10)
    bank_std0: float = param(0.3, "Acceleration", "Initial uncertainty of the road bank's gravity term g sin(bank) in "
                             "the lateral accelerometer (0.3: about 1.8 degrees)", gt=0, le=10)
    bank_walk: float = param(0.003, "Acceleration", "Random walk of the road bank's gravity term per sqrt(s)",
                             gt=0, le=10)
    roll_gain_std0: float = param(0.05, "Dimensionless", "Initial uncertainty of the roll's gravity in the lateral "
                                  "accelerometer that the vehicle file's roll model misses, per unit of lateral "
                                  "acceleration (0.05: a roll gradient off by 3 deg/g; 0: the roll model taken as "
                                  "exact)", ge=0, le=0.5)
    roll_gain_walk: float = param(1e-3, "Dimensionless", "Random walk of that roll gain per sqrt(s) (the load "
                                  "changes)", gt=0, le=1)
    steer_offset_std0: float = param(0.005, "Angle", "Initial uncertainty of the steering offset", gt=0, le=0.5)
    radius_error_std0: float = param(0.02, "Dimensionless", "Initial uncertainty of the rolling-radius error",
                                     gt=0, le=0.5)
    # tire model
    stiffness_std0: float = param(0.35, "Dimensionless", "Initial uncertainty of the log cornering-stiffness scales "
                                  "(0.35: about 30 percent)", gt=0, le=3)
    stiffness_walk: float = param(0.003, "Dimensionless", "Random walk of the log stiffness scales per sqrt(s)",
                                  gt=0, le=1)
    stiffness_min: float = param(0.4, "Dimensionless", "Smallest stiffness scale", gt=0, le=1)
    stiffness_max: float = param(2.5, "Dimensionless", "Largest stiffness scale", ge=1, le=10)
    mu0: float = param(1.0, "FrictionCoefficient", "Friction assumed until it shows", ge=0.05, le=1.5)
    mu_std0: float = param(0.15, "Dimensionless", "Uncertainty of the log friction", gt=0, le=3)
    mu_walk: float = param(0.02, "Dimensionless", "Random walk of the log friction per sqrt(s) (the road changes)",
                           gt=0, le=10)
    mu_min: float = param(0.1, "FrictionCoefficient", "Smallest friction", gt=0, le=1)
    mu_max: float = param(1.3, "FrictionCoefficient", "Largest friction", ge=0.5, le=3)
    combined_slip: bool = param(True, "Dimensionless", "Derate each axle's lateral friction by its longitudinal "
                                "force, m a_x by the vehicle's drive or brake split (friction ellipse, "
                                "lateral_capacity); false: the pure-slip brush tire")
    sliding_friction: bool = param(True, "Dimensionless", "Where the state's slip angle of an axle is beyond the "
                                   "brush tire's at utilisation_max, take the axle's force as its friction (the "
                                   "sliding branch) instead of a slip angle from it; false: the slip from the force "
                                   "always")
    sliding_friction_std: float = param(0.2, "Dimensionless", "Uncertainty of the log friction a sliding axle's "
                                        "force gives", gt=0, le=10)
    utilisation_max: float = param(0.95, "Dimensionless", "Friction utilisation beyond which the tire model gives "
                                   "no slip angle", gt=0, lt=1)
    friction_doubt: float = param(0.0, "Dimensionless", "The tire model's error is taken at the utilisation of a "
                                  "friction this many of its std below the estimate (0: at the estimate)", ge=0, le=5)
    sigma_slip: float = param(0.004, "Angle", "Slip-angle noise of the tire pseudo-measurements (sensor noise, "
                              "unmodelled dynamics)", gt=0, le=1)
    stiffness_doubt: float = param(1.5, "Dimensionless", "Relative error of the brush model's slip angle per prior "
                                   "std (stiffness_std0) by which an axle's stiffness scale lies below the vehicle "
                                   "file's beyond one std and beyond the friction's fall from mu0 in its own std "
                                   "(mu_std0): a tire explained as softer than the file allows, a slide the "
                                   "stiffness absorbs (0: off)", ge=0, le=100)
    friction_test: float = param(1.0, "Dimensionless", "Threshold of the CUSUM of the tire pseudo-measurements' "
                                 "log-likelihood ratio, the best-fitting of a few lower frictions against the "
                                 "estimate, beyond which the friction is re-initialised at that one: a slipperier "
                                 "road found before an axle slides (0: off)", ge=0, le=1000)
    slip_model_error: float = param(1.0, "Dimensionless", "Relative error of the brush model's slip angle at full "
                                    "utilisation (grows with utilisation squared)", ge=0, le=10)
    relaxation_length: float = param(0.5, "Length", "Tire relaxation length: the transient slip error is the slip "
                                     "rate times relaxation_length / v_x", ge=0, le=10)
    slip_correlation_time: float = param(0.1, "Time", "Correlation time of the tire model's error: each sample's "
                                         "pseudo-measurement variance is multiplied by it over Ts (an error that "
                                         "lasts is not new information every sample)", ge=0, le=10)
    adapt_window: float = param(0.5, "Time", "Window over which the tire pseudo-measurements' noise is matched to "
                                "their innovations (covariance matching: a model that stops explaining the car is "
                                "trusted less)", gt=0, le=60)
    pseudo_gate: float = param(3.0, "Dimensionless", "Normalised residual beyond which a tire pseudo-measurement "
                               "or the wheel speed is down-weighted (Huber) so that a transient the model cannot "
                               "follow, or a locking wheel, does not drag the state", gt=0, le=100)
    yaw_acc_cutoff: float = param(3.0, "Frequency", "Low-pass cut-off of the yaw acceleration in the axle forces",
                                  gt=0, le=50)
    # GNSS
    sigma_gnss: float = param(0.1, "Velocity", "GNSS velocity noise per axis", gt=0, le=10)
    max_delay: float = param(0.5, "Time", "Largest GNSS delay handled (length of the history)", gt=0, le=2)
    fix_extrapolation: bool = param(True, "Dimensionless", "Apply a delayed GNSS fix by carrying its correction "
                                    "from its sample to now through the filter's steps (Larsen 1998, two thirds "
                                    "of the cost); false: re-run the filter from the fix's sample (measurement "
                                    "shifting)")
    delay_state: bool = param(True, "Dimensionless", "Estimate the GNSS delay as a state of the filter from the "
                              "fixes' course while it turns (gps_latency +- gps_latency_std its prior); false: "
                              "identify it apart from the filter from the course's changes (identify_delay)")
    delay_walk: float = param(1e-4, "Time", "Random walk of the GNSS delay state per sqrt(s)", gt=0, le=1)
    # magnetometer
    use_magnetometer: bool = param(True, "Dimensionless", "Update the heading with the magnetometer's (mag_x, "
                                   "mag_y, mag_z, calibrated: hard and soft iron removed, normalised to the "
                                   "undisturbed field) whenever the GNSS has initialised it; false: ignore the "
                                   "magnetometer")
    sigma_mag: float = param(0.02, "MagneticFluxRatio", "Magnetometer noise per axis (normalised field)", gt=0, le=1)
    mag_declination: float = param(geomagnetic.DECLINATION, "Angle", "Declination: magnetic north east of true "
                                   "north", ge=-math.pi, le=math.pi)
    mag_offset_std0: float = param(0.05, "Angle", "Initial uncertainty of the magnetometer's heading offset (a "
                                   "declination or iron error), calibrated with GNSS", gt=0, le=3.2)
    mag_offset_walk: float = param(1e-4, "Angle", "Random walk of the magnetometer's heading offset per sqrt(s) "
                                   "(iron that changes with the load)", gt=0, le=1)
    mag_norm_gate: float = param(0.1, "MagneticFluxRatio", "Field-norm deviation from unity beyond which a reading "
                                 "is taken as disturbed and not used", gt=0, le=10)
    mag_tilt_std: float = param(0.003, "Angle", "Tilt error of the magnetometer's tilt compensation besides the "
                                "roll model's (pitch, the bank estimate)", ge=0, le=0.5)
    mag_roll_error: float = param(0.2, "Dimensionless", "Relative error of the roll model's roll in the tilt "
                                  "compensation", ge=0, le=10)
    mag_tilt_correlation_time: float = param(1.0, "Time", "Correlation time of the tilt error: its heading "
                                             "variance is multiplied by it over the readings' interval", ge=0,
                                             le=100)
    mag_gate: float = param(3.0, "Dimensionless", "Heading innovation, in its std, beyond which a magnetometer "
                            "reading is not used: a disturbance whose field norm is near unity (0: every reading "
                            "within mag_norm_gate is used)", ge=0, le=100)
    mag_nis_limit: float = param(2.0, "Dimensionless", "Mean normalised heading innovation of the magnetometer's "
                                 "last 1 / Ts readings (1 s at a reading per filter sample; each reading's error "
                                 "counted once) above which none is used until it falls below half of it: a "
                                 "heading error that lasts, as of a hard iron not removed (0: no check)",
                                 ge=0, le=1e6)
    heading_reset: float = param(0.2, "Angle", "Heading std above which the heading is re-initialised from the "
                                 "course at the next fix", gt=0, le=3.2)
    course_speed: float = param(3.0, "Velocity", "Speed below which a fix does not initialise the heading",
                                gt=0, le=50)
    # IMM
    slide_factor: float = param(10.0, "Dimensionless", "IMM: how much less certain the slide filter's tire "
                                "pseudo-measurements are", ge=1, le=1e4)
    slide_accel: float = param(1.0, "Acceleration", "IMM: extra process noise of the slide filter's lateral "
                               "velocity, as an acceleration", ge=0, le=20)
    mode_switch: float = param(0.01, "Dimensionless", "IMM: probability per sample of switching filter", gt=0, lt=0.5)
    # validity
    locked_wheels_valid: bool = param(True, "Dimensionless", "Keep the estimate valid while the wheels lock (their "
                                      "speed within +-v_min, the estimate's above v_min) as long as a consistent "
                                      "GNSS velocity observes the speed; false: valid needs the wheels' speed above "
                                      "v_min")
    valid_std_max: float = valid_std_max_param(0.03)
    valid_hold: float = valid_hold_param(0.5)
    nis_limit: float = nis_limit_param(25.0)
    compiled: int = param(1, "Dimensionless", "Scalar models (kinematic step, wheel-speed and tire measurements, "
                          "magnetometer heading): 1 compiled C where the FMU carries it for this platform (the same "
                          "doubles, faster), 0 the pure-Python reference", choices=(0, 1))

    def __post_init__(self):
        super().__post_init__()
        if self.mu_min >= self.mu_max:
            raise ValueError(f"mu_min must be below mu_max (got {self.mu_min} >= {self.mu_max})")
