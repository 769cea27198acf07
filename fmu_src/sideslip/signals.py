"""The signal catalogue: every signal that crosses an FMU boundary, defined once.

Names are the binding I/O contract of ``docs/design.md`` (never renamed; extras may be added).
Frames: ISO 8855 vehicle axes (x forward, y left, z up); global ENU (X east, Y north);
yaw counter-clockwise from east; ``beta = atan2(vy, vx)``; steering positive to the left.
FMU wrappers declare their ports by name from here, so unit, declared type, range and
description are written identically into every modelDescription.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .units import QUANTITIES

__all__ = ["Signal", "SIGNALS", "signal", "WHEELS", "WHEEL_SPEEDS", "WHEEL_SPEEDS_M", "PLANT_INPUTS",
           "PLANT_OUTPUTS", "SENSOR_INPUTS", "SENSOR_OUTPUTS", "DRIVER_INPUTS", "DRIVER_OUTPUTS",
           "ESTIMATOR_COMMON_OUTPUTS", "CONTROLLER_INPUTS", "CONTROLLER_EXTRA_INPUTS", "CONTROLLER_OUTPUTS",
           "LQR_OUTPUTS",
           "ESC_OUTPUTS"]

_INF = math.inf


@dataclass(frozen=True)
class Signal:
    """One catalogue entry.

    Parameters
    ----------
    name : str
        Port name (contract name).
    quantity : str
        Physical quantity, used as FMI ``declaredType``; determines the unit.
    description : str
        One-line description with sign convention.
    kind : {"Real", "Boolean"}
        FMI variable type.
    min, max : float
        Physical range (written as ``min``/``max``; inputs outside are clamped by the toolkit).
    start : float
        Start value of the port.
    """

    name: str
    quantity: str
    description: str
    kind: str = "Real"
    min: float = -_INF
    max: float = _INF
    start: float = 0.0

    @property
    def unit(self) -> str:
        """SI unit string of the signal."""
        return QUANTITIES[self.quantity]


def _real(name, quantity, description, lo=-_INF, hi=_INF, start=0.0):
    return Signal(name, quantity, description, "Real", lo, hi, start)


def _bool(name, description, start=False):
    return Signal(name, "Dimensionless", description, "Boolean", start=float(start))


WHEELS = ("fl", "fr", "rl", "rr")
"""The four wheels, in the order of every per-wheel signal and state: front-left, front-right,
rear-left, rear-right."""
_WHEELS = tuple(zip(WHEELS, ("front-left", "front-right", "rear-left", "rear-right")))
_PI = math.pi

_ENTRIES = [
    # --- plant inputs -----------------------------------------------------------------
    _real("delta_f", "Angle", "Front road-wheel steering angle, positive to the left", -1.0, 1.0),
    _real("T_drive", "Torque", "Total drive torque at the wheels (split by the vehicle's drive split)",
          -2.0e4, 2.0e4),
    _real("T_brake", "Torque", "Total brake torque at the wheels (>= 0, split by the brake balance)",
          0.0, 5.0e4),
    _real("Mz_dyc", "Torque", "Yaw-moment request realised by the in-wheel motors (positive turns left)",
          -2.0e4, 2.0e4),
    _real("mu", "FrictionCoefficient", "Tire-road friction coefficient", 0.05, 1.5, 1.0),
    _real("bank_angle", "Angle", "Road bank angle about the vehicle x axis, positive = left side up",
          -0.5, 0.5),
    _real("F_wind_y", "Force", "External lateral force at the CG (e.g. wind gust), positive to the left",
          -2.0e4, 2.0e4),
    _real("M_wind_z", "Torque", "External yaw moment about the CG (e.g. wind gust), positive turns left",
          -2.0e4, 2.0e4),
    # --- plant truth outputs ----------------------------------------------------------
    _real("vx", "Velocity", "Longitudinal velocity of the CG in vehicle axes (truth)", -100.0, 100.0),
    _real("vy", "Velocity", "Lateral velocity of the CG in vehicle axes, positive left (truth)",
          -100.0, 100.0),
    _real("yaw_rate", "AngularVelocity", "Yaw rate, positive counter-clockwise (truth)", -10.0, 10.0),
    _real("beta", "Angle", "Sideslip angle atan2(vy, vx) (truth)", -_PI, _PI),
    _real("yaw", "Angle", "Yaw angle counter-clockwise from east, wrapped to (-pi, pi] (truth)", -_PI, _PI),
    _real("roll", "Angle", "Roll angle of the body w.r.t. the horizontal (bank + suspension roll), "
          "positive = right side down (truth)", -1.0, 1.0),
    _real("roll_rate", "AngularVelocity", "Body roll rate (truth)", -10.0, 10.0),
    _real("ax", "Acceleration", "Longitudinal specific force at the CG as a perfect body-fixed "
          "accelerometer reads it (truth)", -100.0, 100.0),
    _real("ay", "Acceleration", "Lateral specific force at the CG as a perfect body-fixed accelerometer "
          "reads it, incl. gravity through bank and roll (truth)", -100.0, 100.0),
    _real("X", "Position", "Global east position of the CG (truth)", -1.0e7, 1.0e7),
    _real("Y", "Position", "Global north position of the CG (truth)", -1.0e7, 1.0e7),
    *[_real(f"omega_{w}", "AngularVelocity", f"Spin rate of the {d} wheel (truth)", -500.0, 500.0)
      for w, d in _WHEELS],
    _real("Fy_f", "Force", "Front-axle lateral force in vehicle axes (truth)", -1.0e5, 1.0e5),
    _real("Fy_r", "Force", "Rear-axle lateral force in vehicle axes (truth)", -1.0e5, 1.0e5),
    *[_real(f"Fz_{w}", "Force", f"Vertical load on the {d} tire (truth)", 0.0, 1.0e5)
      for w, d in _WHEELS],
    _real("alpha_f", "Angle", "Front-axle slip angle (mean of the two wheels), velocity angle minus "
          "wheel heading; lateral force is opposite in sign (truth)", -_PI, _PI),
    _real("alpha_r", "Angle", "Rear-axle slip angle (mean of the two wheels) (truth)", -_PI, _PI),
    _real("Mz_act", "Torque", "Yaw moment actually produced by the in-wheel motor torque difference "
          "(truth)", -2.0e4, 2.0e4),
    # --- sensor outputs ---------------------------------------------------------------
    _real("ax_m", "Acceleration", "Measured longitudinal acceleration (IMU)", -100.0, 100.0),
    _real("ay_m", "Acceleration", "Measured lateral acceleration (IMU)", -100.0, 100.0),
    _real("yaw_rate_m", "AngularVelocity", "Measured yaw rate (gyro)", -10.0, 10.0),
    _real("roll_rate_m", "AngularVelocity", "Measured roll rate (gyro)", -10.0, 10.0),
    _real("delta_m", "Angle", "Measured front road-wheel angle (steering-angle sensor / steering ratio)",
          -1.0, 1.0),
    *[_real(f"omega_{w}_m", "AngularVelocity", f"Measured spin rate of the {d} wheel", -500.0, 500.0)
      for w, d in _WHEELS],
    _real("gps_ve", "Velocity", "GPS velocity east (held between fixes)", -100.0, 100.0),
    _real("gps_vn", "Velocity", "GPS velocity north (held between fixes)", -100.0, 100.0),
    _real("gps_speed", "Velocity", "GPS horizontal speed (held between fixes)", 0.0, 100.0),
    _real("gps_course", "Angle", "GPS course atan2(gps_vn, gps_ve), counter-clockwise from east",
          -_PI, _PI),
    _bool("gps_fresh", "True in the communication step in which a new GPS fix arrives"),
    _bool("gps_valid", "True while a GPS fix is available (false during outages)"),
    _real("mag_x", "MagneticFluxRatio", "Magnetometer x, field normalised to the undisturbed norm, "
          "sensor (vehicle) axes", -10.0, 10.0),
    _real("mag_y", "MagneticFluxRatio", "Magnetometer y, normalised, sensor axes", -10.0, 10.0),
    _real("mag_z", "MagneticFluxRatio", "Magnetometer z, normalised, sensor axes", -10.0, 10.0),
    _bool("delta_fault_active", "True while the injected steering-sensor fault is active (truth)"),
    _bool("mag_disturbance_active", "True while an injected magnetic disturbance is active (truth)"),
    # --- driver / scenario outputs (plus delta_f, T_drive, T_brake, mu, bank_angle, wind) -------
    _real("delta_sw", "Angle", "Handwheel angle commanded by the driver (delta_f times steering ratio)",
          -20.0, 20.0),
    _real("v_ref", "Velocity", "Target speed of the driver's speed controller", -100.0, 100.0),
    # --- every estimator ----------------------------------------------------------------
    _real("beta_hat", "Angle", "Estimated sideslip angle", -_PI, _PI),
    _real("beta_hat_std", "Angle", "1-sigma of the sideslip estimate from the filter covariance",
          0.0, 10.0),
    _real("vx_hat", "Velocity", "Estimated longitudinal velocity", -100.0, 100.0),
    _real("vy_hat", "Velocity", "Estimated lateral velocity", -100.0, 100.0),
    _real("yaw_rate_hat", "AngularVelocity", "Estimated yaw rate", -10.0, 10.0),
    _bool("valid", "True when the estimate is usable (initialised, inputs finite, vx above threshold)"),
    _real("inputs_held", "Dimensionless", "Number of inputs held (not finite) or clamped (outside their range) in the "
          "last step; every FMU outputs it", 0.0, 1000.0),
    # --- estimator extras ------------------------------------------------------------
    _real("yaw_hat", "Angle", "Estimated yaw (heading) angle, counter-clockwise from east", -_PI, _PI),
    _real("Cf_hat", "CorneringStiffness", "Estimated front-axle cornering stiffness", 0.0, 1.0e7),
    _real("Cr_hat", "CorneringStiffness", "Estimated rear-axle cornering stiffness", 0.0, 1.0e7),
    _real("weight_K", "Dimensionless", "Weighting factor K of the integrated observer (0: bicycle model, "
          "1: kinematic model)", 0.0, 1.0),
    _real("offset_ax", "Acceleration", "Estimated correction added to ax_m (negative of its offset)", -10.0, 10.0),
    _real("offset_ay", "Acceleration", "Estimated correction added to ay_m (negative of its offset)", -10.0, 10.0),
    _real("offset_yaw_rate", "AngularVelocity", "Estimated correction added to yaw_rate_m (negative of its offset)",
          -1.0, 1.0),
    _real("offset_radius", "Length", "Estimated correction of the nominal rolling radius", -0.2, 0.2),
    _real("beta_hat_bicycle", "Angle", "Sideslip of the bicycle-model sub-filter", -_PI, _PI),
    _real("beta_hat_kinematic", "Angle", "Sideslip of the kinematic-model sub-filter", -_PI, _PI),
    _real("beta_hat_openloop", "Angle", "Sideslip of the open-loop (no GPS) kinematic integration", -_PI, _PI),
    _real("delta_hat", "Angle", "Estimated front road-wheel steering angle", -1.0, 1.0),
    _real("delta_residual", "Angle", "Low-pass filtered steering residual delta_m - delta_hat", -2.0, 2.0),
    _bool("delta_fault", "True while the steering-sensor residual test detects a fault"),
    _real("roll_hat", "Angle", "Estimated roll angle of the body (positive: right side down)", -1.0, 1.0),
    _real("bias_ax_hat", "Acceleration", "Estimated bias of ax_m", -20.0, 20.0),
    _real("bias_yaw_rate_hat", "AngularVelocity", "Estimated bias (offset) of yaw_rate_m", -1.0, 1.0),
    _real("bias_ay_hat", "Acceleration", "Estimated bias of ay_m", -20.0, 20.0),
    _real("gps_delay_hat", "Time", "Estimated (or configured) delay of the GPS velocity", 0.0, 5.0),
    _bool("mag_disturbed", "True while the magnetometer is judged disturbed (field norm off unity)"),
    _real("steer_offset_hat", "Angle", "Estimated offset of delta_m (road-wheel angle)", -0.5, 0.5),
    _real("mu_hat", "FrictionCoefficient", "Estimated tire-road friction coefficient", 0.0, 3.0),
    _real("friction_utilisation", "Dimensionless", "Estimated friction utilisation of the more utilised axle "
          "(lateral force over friction times load)", 0.0, 1.0),
    _real("slide_probability", "Dimensionless", "Probability of the IMM's slide filter (0 for a single EKF)",
          0.0, 1.0),
    _real("roll_gain_error_hat", "Dimensionless", "Estimated roll gravity in the lateral accelerometer beyond the "
          "vehicle file's roll model, per unit of lateral acceleration", -1.0, 1.0),
    _real("nonlinear_factor", "Dimensionless", "Fuzzy nonlinear factor (0: linear tires, 1: at the limit)",
          0.0, 1.0),
    _real("Fyf_hat", "Force", "Estimated front-axle lateral force", -1.0e5, 1.0e5),
    _real("Fyr_hat", "Force", "Estimated rear-axle lateral force", -1.0e5, 1.0e5),
    _real("d1_hat", "AngularVelocity", "Estimated lumped disturbance of the sideslip equation (d1)", -100.0, 100.0),
    _real("d2_hat", "AngularAcceleration", "Estimated lumped disturbance of the yaw equation (d2)", -1000.0,
          1000.0),
    # --- controller -----------------------------------------------------------------------
    _real("Mz_cmd", "Torque", "Direct-yaw-moment command for the in-wheel motors", -2.0e4, 2.0e4),
    _real("beta_ref", "Angle", "Reference sideslip angle of the reference model", -_PI, _PI),
    _real("yaw_rate_ref", "AngularVelocity", "Reference yaw rate of the reference model", -10.0, 10.0),
    _real("Mz_ff", "Torque", "Feed-forward part of the yaw-moment command (before saturation)", -1.0e7, 1.0e7),
    _real("Mz_fb", "Torque", "Feedback part of the yaw-moment command (before saturation)", -1.0e7, 1.0e7),
    _real("Mz_yaw", "Torque", "Yaw-rate PI part of the baseline ESC's command (before saturation)", -1.0e7, 1.0e7),
    _real("Mz_beta", "Torque", "Sideslip-limiter part of the baseline ESC's command (before saturation)", -1.0e7,
          1.0e7),
    _bool("beta_valid", "True when beta_hat may be used (the estimator's valid); false fades the sideslip "
          "feedback out", start=True),
    _bool("dyc_enable", "True to apply the yaw moment; false fades the command to zero", start=True),
    _real("beta_std", "Angle", "1-sigma of beta_hat (the estimator's beta_hat_std); with beta_std_ref it weights "
          "the sideslip feedback (0: full weight)", 0.0, 10.0),
]

SIGNALS: dict[str, Signal] = {}
for _s in _ENTRIES:
    if _s.name in SIGNALS:  # pragma: no cover - guards the table itself
        raise RuntimeError(f"duplicate signal {_s.name}")
    SIGNALS[_s.name] = _s


def signal(name: str) -> Signal:
    """Catalogue entry of ``name``.

    Raises
    ------
    KeyError
        With the list of known names when ``name`` is not in the catalogue.
    """
    try:
        return SIGNALS[name]
    except KeyError:
        raise KeyError(f"'{name}' is not in the signal catalogue") from None


# ---- port groups: the interfaces of the models, by catalogue name -------------------------
WHEEL_SPEEDS = tuple(f"omega_{w}" for w in WHEELS)
"""True wheel spin rates (plant outputs), in :data:`WHEELS` order."""
WHEEL_SPEEDS_M = tuple(f"omega_{w}_m" for w in WHEELS)
"""Measured wheel spin rates (sensor outputs, estimator inputs), in :data:`WHEELS` order."""
PLANT_INPUTS = ("delta_f", "T_drive", "T_brake", "Mz_dyc", "mu", "bank_angle", "F_wind_y", "M_wind_z")
PLANT_OUTPUTS = ("vx", "vy", "yaw_rate", "beta", "yaw", "roll", "roll_rate", "ax", "ay", "X", "Y",
                 *WHEEL_SPEEDS, "Fy_f", "Fy_r", *[f"Fz_{w}" for w in WHEELS], "alpha_f", "alpha_r", "Mz_act")
SENSOR_INPUTS = ("ax", "ay", "yaw_rate", "roll_rate", "delta_f", *WHEEL_SPEEDS, "vx", "vy", "yaw", "roll")
"""Plant truth the sensor models sample."""
SENSOR_OUTPUTS = ("ax_m", "ay_m", "yaw_rate_m", "roll_rate_m", "delta_m", *WHEEL_SPEEDS_M,
                  "gps_ve", "gps_vn", "gps_speed", "gps_course", "gps_fresh", "gps_valid",
                  "mag_x", "mag_y", "mag_z", "delta_fault_active", "mag_disturbance_active")
DRIVER_INPUTS = ("vx", "X", "Y", "yaw")
"""Plant truth the maneuver driver steers and controls the speed by."""
DRIVER_OUTPUTS = ("delta_f", "T_drive", "T_brake", "mu", "bank_angle", "F_wind_y", "M_wind_z",
                  "delta_sw", "v_ref")
ESTIMATOR_COMMON_OUTPUTS = ("beta_hat", "beta_hat_std", "vx_hat", "vy_hat", "yaw_rate_hat", "valid")
CONTROLLER_INPUTS = ("delta_m", "vx_hat", "beta_hat", "yaw_rate_m")
CONTROLLER_EXTRA_INPUTS = ("yaw_rate_hat", "beta_valid", "dyc_enable", "mu_hat", "beta_std")
"""Inputs the controllers take beyond the contract's, each working when left unconnected (the
estimated yaw rate is used only when the parameter ``yaw_rate_source`` asks for it, the friction
estimate only when ``friction_source`` does, and 0 there is no estimate; the sideslip's std, named
apart from the estimators' ``beta_hat_std`` like ``beta_valid`` from ``valid`` so that it is connected
from the controller's source only, when ``beta_std_ref`` is set, and 0 there is full trust)."""
CONTROLLER_OUTPUTS = ("Mz_cmd", "beta_ref", "yaw_rate_ref")
LQR_OUTPUTS = CONTROLLER_OUTPUTS + ("Mz_ff", "Mz_fb")
"""Outputs of the LQR direct-yaw-moment controller: the contract's plus the command's two parts."""
ESC_OUTPUTS = CONTROLLER_OUTPUTS + ("Mz_yaw", "Mz_beta")
"""Outputs of the baseline ESC: the contract's plus the command's two parts."""
