"""Numeric configuration: every String that matters has numeric stand-ins (hosts such as OMSimulator
apply only Real, Integer and Boolean start values), with a documented precedence."""
from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
import zipfile

import pytest

from sideslip.estimators.nguyen2012 import Nguyen2012Config
from sideslip.fmi.catalogue import CATALOGUE
from sideslip.fmi.variables import fmi_value
from sideslip.params import ChoiceIndices, ParameterError, declared_fields
from sideslip.plant.driver import MANEUVER_KINDS, Driver, DriverConfig
from sideslip.plant.maneuvers import parse_maneuver
from sideslip.plant.vehicle import PlantConfig
from sideslip.vehicles import VehicleConfig, VehicleParams, load_vehicle

NUMERIC_VEHICLE_FIELDS = [f.name for f, info in declared_fields(VehicleParams)
                          if info.fmu and (not isinstance(f.default, str) or info.choices)]


# ---------------------------------------------------------------- library: precedence
def test_vehicle_group_starts_at_the_default_vehicle_and_only_changed_values_apply():
    group, = PlantConfig.parameter_groups()
    starts = {name: start for name, start, _ in group.parameters()}
    suv = load_vehicle("pi2011_suv")
    assert starts["vehicle.m"] == suv.m and starts["vehicle.motor_axle"] == 1 + ("front", "rear").index(suv.motor_axle)
    assert sorted(n.split(".", 1)[1] for n in starts) == sorted(NUMERIC_VEHICLE_FIELDS)
    cfg = PlantConfig()
    assert cfg.with_parameter_groups(starts) == cfg                 # a host writing every start value back
    other = PlantConfig(vehicle="nguyen2012_coms")
    assert other.with_parameter_groups(starts).vehicle_params() == load_vehicle("nguyen2012_coms")


def test_vehicle_precedence_file_then_numeric_then_overrides():
    values = {"vehicle.I_zz": 3000.0, "vehicle.steering_ratio": 17.0, "vehicle.motor_axle": 2}
    cfg = PlantConfig(vehicle="pi2011_suv", vehicle_overrides="steering_ratio=19").with_parameter_groups(values)
    v = cfg.vehicle_params()
    assert (v.I_zz, v.steering_ratio, v.motor_axle) == (3000.0, 19.0, "rear")
    assert v.m == load_vehicle("pi2011_suv").m                     # the rest from the file
    assert PlantConfig(vehicle="kim2016_asm").with_parameter_groups({"vehicle.I_zz": 3000.0}).vehicle_params() == \
        load_vehicle("kim2016_asm", "I_zz=3000")                    # numeric over any file
    with pytest.raises(ParameterError, match=r"'vehicle.I_zz' = -1.0 .*\(0, 1e\+06\] kg.m2"):
        PlantConfig().with_parameter_groups({"vehicle.I_zz": -1.0})
    with pytest.raises(ParameterError, match=r"'vehicle.motor_axle' = 3 .*\[1, 2\]"):
        PlantConfig().with_parameter_groups({"vehicle.motor_axle": 3})


def test_driver_maneuver_kind_and_constants():
    values = {"sine_steer.frequency": 0.8, "sine_steer.amplitude": 1.0, "constant.road_mu": 0.4,
              "constant.road_bank": 0.05}
    cfg = DriverConfig(maneuver_kind=MANEUVER_KINDS.index("sine_steer") + 1).with_parameter_groups(values)
    m = parse_maneuver(cfg.maneuver)
    assert (type(m).__name__, m.frequency, m.amplitude, m.cycles) == ("SineSteer", 0.8, 1.0, 3.0)
    assert float(cfg.road_mu) == 0.4 and float(cfg.road_bank) == 0.05
    # kind 0 keeps the String maneuver; a String table set away from its default wins over the constant
    kept = DriverConfig(maneuver="circle:radius=40", road_mu="0:1, 5:0.3").with_parameter_groups(values)
    assert kept.maneuver == "circle:radius=40" and kept.road_mu == "0:1, 5:0.3" and float(kept.road_bank) == 0.05
    # every maneuver is reachable and its numeric form equals its default spec
    for kind, name in enumerate(MANEUVER_KINDS, 1):
        built = DriverConfig(maneuver_kind=kind).with_parameter_groups({})
        assert parse_maneuver(built.maneuver) == parse_maneuver(name)
    with pytest.raises(ParameterError, match="'slalom.cones' = 0"):
        DriverConfig().with_parameter_groups({"slalom.cones": 0})         # checked even when not selected
    with pytest.raises(ParameterError, match="maneuver_kind"):
        DriverConfig(maneuver_kind=len(MANEUVER_KINDS) + 1)


def test_numeric_driver_runs_like_its_string_twin():
    numeric = DriverConfig(maneuver_kind=MANEUVER_KINDS.index("step_steer") + 1).with_parameter_groups(
        {"step_steer.amplitude": -1.2, "constant.road_mu": 0.5, "vehicle.steering_ratio": 18.0})
    text = DriverConfig(maneuver="step_steer:amplitude=-1.2", road_mu="0.5", vehicle_overrides="steering_ratio=18")
    a, b = Driver(numeric), Driver(text)
    for k in range(3000):
        a.step(1e-3, 20.0, 20.0 * k * 1e-3, 0.0, 0.0)
        b.step(1e-3, 20.0, 20.0 * k * 1e-3, 0.0, 0.0)
        assert a.outputs() == b.outputs()


def test_choice_indices():
    choices = ChoiceIndices(Nguyen2012Config)
    assert [n for n, _, _ in choices.parameters()] == ["mode_index", "discretization_index"]
    cfg = Nguyen2012Config(mode="mrkf")
    assert choices.apply(cfg, {"mode_index": 0}) == cfg
    assert choices.apply(cfg, {"mode_index": 1, "discretization_index": 2}) == dataclasses.replace(
        cfg, mode="srkf", discretization="euler")
    with pytest.raises(ParameterError, match="mode_index"):
        choices.apply(cfg, {"mode_index": 4})


# ---------------------------------------------------------------- FMUs
def _model_description(fmu_dir, name):
    with zipfile.ZipFile(fmu_dir / f"{name}.fmu") as z:
        return ET.fromstring(z.read("modelDescription.xml"))


@pytest.mark.parametrize("name", sorted(n for n, s in CATALOGUE.items() if issubclass(s.config_class, VehicleConfig)))
def test_every_fmu_with_a_vehicle_declares_its_numeric_values_exactly(fmu_dir, name):
    root = _model_description(fmu_dir, name)
    default = load_vehicle(CATALOGUE[name].config_class.__dataclass_fields__["vehicle"].default)
    variables = {sv.get("name"): sv for sv in root.iter("ScalarVariable")}
    infos = dict((f.name, info) for f, info in declared_fields(VehicleParams))
    for field in NUMERIC_VEHICLE_FIELDS:
        sv = variables[f"vehicle.{field}"]
        assert sv.get("causality") == "parameter" and sv.get("variability") == "fixed", field
        assert sv.get("description"), field
        value = getattr(default, field)
        if isinstance(value, str):
            node = sv.find("Integer")
            assert int(node.get("start")) == 1 + infos[field].choices.index(value)
            continue
        node = sv.find("Real")
        assert float(node.get("start")) == value, field                      # exact: hosts write it back
        assert node.get("unit") == infos[field].unit and node.get("declaredType") == infos[field].quantity
        if infos[field].ge is not None:
            assert float(node.get("min")) == infos[field].ge


def test_plant_fmu_numeric_vehicle_equals_the_string_route_and_start_values_change_nothing(harness):
    def run(**params):
        fmu = harness("VehiclePlant")
        fmu.init(vx0=15.0, **params)
        out = []
        for k in range(400):
            fmu.step(delta_f=0.05 * math.sin(3 * k * 1e-3), T_drive=300.0)
            out.append(fmu.outputs())
        return out, fmu

    reference, _ = run(vehicle_overrides="I_zz=2900, steering_ratio=16, C_alpha_f=70000")
    numeric, fmu = run(**{"vehicle.I_zz": 2900.0, "vehicle.steering_ratio": 16.0, "vehicle.C_alpha_f": 70000.0})
    assert numeric == reference
    starts = {v.name: fmi_value(v.type, v.start) for v in fmu.md.modelVariables if v.name.startswith("vehicle.")}
    other, _ = run(vehicle="nguyen2012_coms")
    rewritten, _ = run(vehicle="nguyen2012_coms", **starts)
    assert rewritten == other and other != reference


def test_a_bad_numeric_value_fails_initialisation_naming_it(harness):
    from fmpy.fmi1 import FMICallException

    fmu = harness("Park2018Observer", logging=True)
    fmu.fmu.setupExperiment(startTime=0.0)
    fmu.fmu.enterInitializationMode()
    fmu.set(**{"vehicle.l_f": -1.0})
    with pytest.raises(FMICallException):
        fmu.fmu.exitInitializationMode()
    assert any("'vehicle.l_f' = -1.0" in m and "(0, 10] m" in m for _, m in fmu.messages), fmu.messages
