"""SideslipFusion: GNSS, IMU, wheel speeds, steering and magnetometer fused with a self-calibrating tire model.

The papers' methods each trust one thing a user's car does not give them - an offset-free gyro, a
calibrated magnetometer, the vehicle file's cornering stiffness and linear tires.
:class:`SideslipFusion` trusts none of them alone.  One extended Kalman filter (or an IMM of two,
``formulation``) on the state :class:`Fs`:

* **Time update** (:func:`~.models.kinematic_step`): the body-frame velocity driven by the
  accelerometers (the lateral one roll-compensated with the vehicle's roll model), the heading by the
  gyro, each sensor's offset a state; the road bank's gravity term ``g_y`` a state of its own, because
  it moves the lateral accelerometer but is not a tire force.  Exact for any tire and friction.
* **GNSS velocity** (:func:`~.models.gnss_measurement`), compared at the fix's own time: the filter's
  samples of the last ``max_delay`` seconds are kept and the fix's correction is carried to now through
  the filter's steps since (Larsen et al. 1998, :class:`~sideslip.estimators.kalman.DelayedMeasurements`;
  or the filter re-run from the fix's sample, ``fix_extrapolation`` false).  The delay is a state
  (``delay_state``), linearised by the acceleration across the track; or it is identified apart from the
  filter from the course's changes (:class:`~sideslip.estimators.delay.GpsLatency`).  GNSS makes the
  heading, the offsets, the rolling radius and the tire parameters observable whenever the car
  accelerates or turns.
* **Magnetometer** (:mod:`~.magnetometer`): the heading of the tilt-compensated field, with gates that
  keep a disturbed or uncalibrated magnetometer out; GNSS calibrates its offset.
* **Wheel speeds** (:func:`~.models.wheel_measurement`): the undriven axle's speed ``(1 + e_w) v_x``, the
  rolling-radius error a state.
* **Tire pseudo-measurements** (:func:`~.models.axle_pseudo`), one per axle and sample: the axle's lateral
  force from the force and moment balances gives its slip angle through a brush tire
  (:mod:`~.tire_model`) whose stiffness scales and friction are states; the slip angles tie the lateral
  velocity to the yaw rate and the steering.  With GNSS they calibrate the tire model; without it they
  hold the lateral velocity.  A sliding axle measures the friction instead (``sliding_friction``), and a
  likelihood-ratio test finds a slipperier road before an axle slides (:mod:`~.friction_test`).  How the
  tire model's error is weighed is in :mod:`~.mode`.

The IMM (``formulation = 1``, :class:`~sideslip.estimators.imm.InteractingMultipleModel`) runs a
filter that trusts the tire model (``grip``) and one whose pseudo-measurements are ``slide_factor``
times less certain with more process noise on the lateral velocity (``slide``).

Without GNSS (``use_gnss`` false, or while ``gps_valid`` is false) the same filter runs on the
in-vehicle sensors: the heading and the GNSS-only observable states random-walk with their process
noise, so the reported std grows; when GNSS returns after the heading has become uncertain
(``heading_reset``) the heading is re-initialised from the fix's course.

``beta_hat_std`` is the first-order std of ``atan2(v_y, v_x)`` from the covariance, inflated by the GNSS
innovations' consistency (:class:`~sideslip.estimators.kalman.InnovationMonitor`); ``valid`` is false
below ``v_min`` (the estimate's speed, and the wheels' unless a consistent GNSS velocity observes the speed while
they lock: ``locked_wheels_valid``), before the heading is initialised in GNSS mode, while the GNSS innovations are
inconsistent and above ``valid_std_max``, and waits ``valid_hold`` after any break
(:class:`~sideslip.estimators.base.ValidityGate`).  Results and limits: ``docs/estimator.md``.
"""
from .config import EKF, IMM, SideslipFusionConfig
from .filter import SideslipFusion
from .models import (AxlePseudo, Geometry, SampleInputs, axle_pseudo, gnss_delayed_model, gnss_measurement,
                     gnss_model, kinematic_step, magnetometer_model, sliding_friction_measurement,
                     track_acceleration, wheel_measurement, wheel_model)
from .state import Fs
from .tire_model import CAPACITY_MIN, axle_slip, axle_stiffness, fiala_slip, lateral_capacity

__all__ = ["SideslipFusion", "SideslipFusionConfig", "Fs", "EKF", "IMM", "Geometry", "SampleInputs", "AxlePseudo",
           "kinematic_step", "gnss_model", "gnss_delayed_model", "gnss_measurement", "track_acceleration",
           "magnetometer_model", "wheel_model", "wheel_measurement", "axle_pseudo", "sliding_friction_measurement",
           "axle_slip", "axle_stiffness", "fiala_slip", "lateral_capacity", "CAPACITY_MIN"]
