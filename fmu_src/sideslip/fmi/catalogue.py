"""The FMU catalogue: one table of every FMU the project builds.

Each entry names the FMU (its model identifier, the class of its wrapper), the wrapper module
(``fmu_src/<module>.py`` for the estimators and controllers, ``plant_fmus/<module>.py`` for the plant
side, :data:`PLANT_SIDE`; a name unique to this project because all FMUs of a host share one Python
interpreter), the library model and configuration it exposes, its role in a
closed loop and its description.  The co-simulation assembly, the builder, the command
line and the documentation read this table; a wrapper holds only its class statement and takes
the rest from here (:class:`sideslip.fmi.slave.SideslipSlave`).

Models and configurations are named as ``"module:attribute"`` and imported on first use, so
reading the catalogue imports no model.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from functools import cached_property

from ..params import one_of

__all__ = ["FmuSpec", "CATALOGUE", "ROLES", "PLANT_SIDE", "PLANT_PACKAGE", "HELD_OUTPUT", "fmu_spec", "fmu_names"]

HELD_OUTPUT = "inputs_held"
"""The output every FMU adds after its model's: how many inputs were held or clamped in the last step."""

ROLES = ("driver", "plant", "sensors", "estimator", "controller")
"""Roles in a closed loop, in the order the components run."""

PLANT_SIDE = ("driver", "plant", "sensors")
"""The roles whose wrappers are in ``plant_fmus/``."""
PLANT_PACKAGE = "sideslip_plant_fmus"
"""The package ``plant_fmus/`` is installed as."""


_ROOT = __name__.split(".")[0]
"""This package's top-level name: ``sideslip``, or the per-build name it has inside an FMU."""


def _resolve(ref: str):
    module, _, attr = ref.partition(":")
    if module == "sideslip" or module.startswith("sideslip."):      # the entries name the package as installed
        module = _ROOT + module[len("sideslip"):]
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class FmuSpec:
    """One FMU of the catalogue.

    Attributes
    ----------
    name : str
        FMU name: model identifier, file name ``<name>.fmu`` and wrapper class name.
    module : str
        Wrapper module's name (``fmu_src/<module>.py``, ``plant_fmus/<module>.py`` for the plant side).
    model, config : str
        Library model class and its configuration dataclass, as ``"module:attribute"``.
    role : str
        One of :data:`ROLES`.
    description : str
        The modelDescription's description.
    """

    name: str
    module: str
    model: str
    config: str
    role: str
    description: str

    def __post_init__(self):
        if self.role not in ROLES:
            raise ValueError(f"FMU {self.name}: role {self.role!r} is not one of {ROLES}")

    @cached_property
    def model_class(self) -> type:
        """The library model class (imported on first use)."""
        return _resolve(self.model)

    @cached_property
    def config_class(self) -> type:
        """The configuration dataclass (imported on first use)."""
        return _resolve(self.config)

    @property
    def inputs(self) -> tuple:
        """Input port names (signal catalogue), in value-reference order."""
        return tuple(self.model_class.input_names)

    @property
    def outputs(self) -> tuple:
        """Output port names, in value-reference order: the model's, then :data:`HELD_OUTPUT`."""
        return tuple(self.model_class.output_names) + (HELD_OUTPUT,)

    @cached_property
    def parameter_names(self) -> tuple:
        """Every parameter the FMU declares: the configuration's fields, then their numeric stand-ins."""
        from ..params import ChoiceIndices, declared_fields

        cls = self.config_class
        names = [f.name for f, info in declared_fields(cls) if info.fmu]
        for group in (ChoiceIndices(cls), *getattr(cls, "parameter_groups", tuple)()):
            names += [name for name, _, _ in group.parameters()]
        return tuple(names)

    def numeric_parameters(self, params: dict) -> dict:
        """``params`` (values by parameter name, Strings among them) as Real, Integer and Boolean
        parameters only, configuring the same model: for hosts that cannot set Strings (OMSimulator).

        Raises
        ------
        ParameterError
            For a String value without a numeric form (e.g. a friction time table), named.
        """
        from ..params import ChoiceIndices, ParameterError, build, declared_fields

        cls = self.config_class
        texts = {f.name: f.default for f, info in declared_fields(cls) if isinstance(f.default, str) and info.fmu}
        config = build(cls, {k: v for k, v in params.items() if k in texts or k in cls.__dataclass_fields__})
        out = {k: v for k, v in params.items() if k not in texts}
        stand_ins = ChoiceIndices(cls)
        covered = {name[:-len("_index")] for name, _, _ in stand_ins.parameters()} | set(
            getattr(cls, "STRING_STAND_INS", ()))
        for name, default in texts.items():
            if name not in covered and getattr(config, name) != default:
                raise ParameterError(name, getattr(config, name), "its default: it has no numeric form")
        out.update(stand_ins.numbers(config))
        if hasattr(config, "numeric_parameters"):
            out.update(config.numeric_parameters())
        return out

    @property
    def import_name(self) -> str:
        """The wrapper module's import name as installed."""
        return f"{PLANT_PACKAGE}.{self.module}" if self.role in PLANT_SIDE else self.module

    @property
    def source_folder(self) -> str:
        """The wrapper's folder in the repository."""
        return "plant_fmus" if self.role in PLANT_SIDE else "fmu_src"

    @property
    def library_module(self) -> str:
        """Module of the library model."""
        return self.model.partition(":")[0]


_ENTRIES = (
    FmuSpec("ManeuverDriver", "sideslip_driver_fmu", "sideslip.plant.driver:Driver",
            "sideslip.plant.driver:DriverConfig", "driver",
            "Maneuver driver: speed controller on drive/brake torque, pure-pursuit path follower or open-loop "
            "handwheel profile (sine, step, J-turn, sine with dwell, ISO 3888-1 DLC, lane change, slalom, circle, "
            "brake in turn, 3 km track); emits road friction, bank and wind"),
    FmuSpec("VehiclePlant", "sideslip_plant_fmu", "sideslip.plant.vehicle:VehiclePlant",
            "sideslip.plant.vehicle:PlantConfig", "plant",
            "8-DOF vehicle plant (longitudinal, lateral, yaw, roll, four wheel spins) with Dugoff combined-slip "
            "tires, quasi-static load transfer, bank gravity, drive/brake split and in-wheel motors realising "
            "Mz_dyc; RK4 with adaptive internal sub-steps"),
    FmuSpec("CommonRoadPlant", "sideslip_commonroad_fmu", "sideslip.plant.commonroad:CommonRoadPlant",
            "sideslip.plant.commonroad:CommonRoadConfig", "plant",
            "Third-party vehicle plant: the CommonRoad multi-body model (vehiclemodels.vehicle_dynamics_mb, 29 "
            "states, PAC2002 tires; published sets Ford Escort, BMW 320i, VW Vanagon) under the plant contract, "
            "with a steering actuator, the contract's wheel torques and yaw moment, road friction and bank; RK4"),
    FmuSpec("VehicleSensors", "sideslip_sensors_fmu", "sideslip.plant.sensors:SensorSuite",
            "sideslip.plant.sensors:SensorConfig", "sensors",
            "Vehicle sensors: IMU, wheel speeds with rolling-radius error, steering-angle sensor with fault "
            "injection, single-antenna GPS (rate, delay, outages) and 3-axis magnetometer with disturbance "
            "episodes; per-sensor rate, noise and bias; seeded"),
    FmuSpec("Kim2016SteeringEKF", "sideslip_kim2016_fmu", "sideslip.estimators.kim2016:Kim2016SteeringEKF",
            "sideslip.estimators.kim2016:Kim2016Config", "estimator",
            "Kim, Yoon, Kim 2016 EKF on [beta, yaw rate, road-wheel angle] with measurements [a_y, yaw rate] and "
            "the wheel speed as input; flags a stuck or offset steering sensor from the residual "
            "delta_m - delta_hat"),
    FmuSpec("LinearBicycleObserver", "sideslip_linear_bicycle_fmu",
            "sideslip.estimators.baselines:LinearBicycleObserver", "sideslip.estimators.baselines:BicycleObserverConfig",
            "estimator",
            "Baseline sideslip estimator: linear single-track model (Pi 2011 eq 20) with nominal cornering "
            "stiffness, corrected by the measured yaw rate (time-varying Kalman gain)"),
    FmuSpec("Nguyen2012DACMRKF", "sideslip_nguyen2012_fmu", "sideslip.estimators.nguyen2012:Nguyen2012DACMRKF",
            "sideslip.estimators.nguyen2012:Nguyen2012Config", "estimator",
            "Nguyen, Wang, Fujimoto, Hori 2012 sideslip estimation: linear Kalman filter on the bicycle model with "
            "the in-wheel motors' yaw moment as input, yaw rate every sample and GPS course at each fix; mode srkf "
            "[beta, r], mrkf [beta, r, psi] or dacmrkf [beta, r, psi, d1, d2]"),
    FmuSpec("OpenLoopKinematic", "sideslip_openloop_fmu", "sideslip.estimators.baselines:OpenLoopKinematic",
            "sideslip.estimators.baselines:OpenLoopConfig", "estimator",
            "Baseline sideslip estimator: direct integration of the kinematic relation "
            "d(beta)/dt = (a_y + g sin(bank)) / v_x - r (Pi 2011 eq 22); drifts with sensor bias"),
    FmuSpec("Park2018Observer", "sideslip_park2018_fmu", "sideslip.estimators.park2018:Park2018Observer",
            "sideslip.estimators.park2018:Park2018Config", "estimator",
            "Park, Choi, Hyun, Lee 2018 integrated sideslip observer: sensor offset compensator, bicycle-model EKF "
            "with normalised cornering stiffness, kinematic EKF on wheel speed and GPS velocity, weighting factor "
            "K and the integrated EKF on [vx, vy, r]; open-loop fallback during GPS outages"),
    FmuSpec("Pi2011FuzzyEKF", "sideslip_pi2011_fmu", "sideslip.estimators.pi2011:Pi2011FuzzyEKF",
            "sideslip.estimators.pi2011:Pi2011Config", "estimator",
            "Pi, Chen, Wang, Zhang 2011 sideslip observer: axle side forces from a_y and yaw acceleration blended "
            "with an adaptive linear tire model by a Mamdani fuzzy nonlinear factor, cornering-stiffness "
            "identifier, EKF on [beta, Fyf, Fyr] with tire relaxation"),
    FmuSpec("Yoon2014DualKF", "sideslip_yoon2014_fmu", "sideslip.estimators.yoon2014:Yoon2014DualKF",
            "sideslip.estimators.yoon2014:Yoon2014Config", "estimator",
            "Yoon & Peng 2014 sideslip estimation: heading EKF (yaw, roll) on gyros and a 3-axis magnetometer with "
            "magnetic-disturbance rejection, sideslip KF on [U, b_x, V, b_y] with GPS velocity, measurement "
            "shifting for the GPS delay, delay identification, bicycle model in straight driving"),
    FmuSpec("SideslipFusion", "sideslip_fusion_fmu", "sideslip.estimators.fusion:SideslipFusion",
            "sideslip.estimators.fusion:SideslipFusionConfig", "estimator",
            "Sideslip estimator fusing GNSS velocity (delay identified and compensated), IMU, wheel speeds and "
            "steering: kinematic EKF (or IMM) with online gyro, accelerometer, steering and rolling-radius offsets "
            "and a brush-tire pseudo-measurement per axle whose cornering stiffnesses and friction are estimated; "
            "in-vehicle mode without GNSS"),
    FmuSpec("LqrDycController", "sideslip_lqr_dyc_fmu", "sideslip.control.dyc:LqrDycController",
            "sideslip.control.dyc:LqrDycConfig", "controller",
            "LQR direct-yaw-moment controller for in-wheel-motor EVs (Nguyen et al. 2012 section IV): "
            "friction-limited reference model (eqs 21-22), feed-forward G_ff (eq 24), LQR feedback on the sideslip "
            "and yaw-rate errors (eqs 25-26) scheduled on speed, saturation at the motors' limit; drivable profile: "
            "feed-forward bandwidth, fade-in above a low speed, bumpless transfer, rate limit"),
    FmuSpec("BaselineEsc", "sideslip_baseline_esc_fmu", "sideslip.control.esc:BaselineEsc",
            "sideslip.control.esc:EscConfig", "controller",
            "Baseline ESC-style direct-yaw-moment controller for in-wheel-motor EVs: yaw-rate PI with a dead band "
            "around the friction-limited reference (anti-windup), plus a sideslip limiter"),
    FmuSpec("StabilityController", "sideslip_stability_fmu", "sideslip.control.stability:StabilityController",
            "sideslip.control.stability:StabilityControllerConfig", "controller",
            "Vehicle stability controller in one block: sensor signals in, direct-yaw-moment command out. Embeds "
            "the sideslip estimator named by the parameter 'estimator' and the LQR controller of Nguyen et al. "
            "2012 section IV"),
)

CATALOGUE: dict[str, FmuSpec] = {}
for _e in _ENTRIES:
    if _e.name in CATALOGUE or any(_e.module == o.module for o in CATALOGUE.values()):
        raise RuntimeError(f"duplicate FMU name or wrapper module: {_e.name}, {_e.module}")
    CATALOGUE[_e.name] = _e


def fmu_spec(name: str) -> FmuSpec:
    """Catalogue entry of FMU ``name``.

    Raises
    ------
    KeyError
        Listing the known FMU names.
    """
    try:
        return CATALOGUE[name]
    except KeyError:
        raise KeyError(one_of(name, CATALOGUE, "FMU")) from None


def fmu_names(role: str | None = None) -> list[str]:
    """Names of all FMUs, or of those with ``role``, sorted."""
    return sorted(n for n, e in CATALOGUE.items() if role is None or e.role == role)
