"""Parameter declarations, vehicle parameter sets and the signal catalogue."""
import math
import re
from dataclasses import dataclass
from fnmatch import fnmatch
from pathlib import Path

import pytest

import sideslip.vehicles
from sideslip.params import ParameterError, build, check, param, parse_assignments
from sideslip.signals import (CONTROLLER_INPUTS, CONTROLLER_OUTPUTS, ESTIMATOR_COMMON_OUTPUTS, PLANT_INPUTS,
                              PLANT_OUTPUTS, SENSOR_OUTPUTS, SIGNALS)
from sideslip.units import QUANTITIES, UNITS
from sideslip.vehicles import VehicleParams, load_vehicle, vehicle_names, vehicle_source


@dataclass(frozen=True)
class _Cfg:
    mass: float = param(1.0, "Mass", "a mass", gt=0, le=100)
    n: int = param(3, "Dimensionless", "a count", ge=1, le=10)
    mode: str = param("a", "Dimensionless", "a mode", choices=("a", "b"))

    def __post_init__(self):
        check(self)


def test_parameter_error_names_parameter_value_and_range():
    with pytest.raises(ParameterError) as e:
        _Cfg(mass=-2.0)
    assert e.value.name == "mass" and e.value.value == -2.0
    assert "(0, 100] kg" in str(e.value)
    with pytest.raises(ParameterError, match=r"one of 'a', 'b'"):
        _Cfg(mode="c")
    with pytest.raises(ParameterError, match=r"an integer"):
        build(_Cfg, {"n": "2.5"})
    with pytest.raises(ParameterError, match=r"known name \(did you mean .mass.\?\): mass, mode, n"):
        build(_Cfg, {"mas": 2})
    assert build(_Cfg, {"mass": "2", "n": "4.0"}) == _Cfg(mass=2.0, n=4)
    for bad in (math.nan, math.inf):
        with pytest.raises(ParameterError):
            _Cfg(mass=bad)


def test_parse_assignments():
    assert parse_assignments("a=1, b = 2.5; c=x") == {"a": "1", "b": "2.5", "c": "x"}
    assert parse_assignments("") == {}
    with pytest.raises(ParameterError, match="key=value"):
        parse_assignments("a=1, oops")


# ---------------------------------------------------------------- vehicles
PAPER_VALUES = {
    # Park 2018 Table 1
    "park2018_sonata": dict(m=1819.0, l_f=1.265, l_r=1.54, I_zz=3566.0, R_w=0.33, h_cg=0.542,
                            C_f_nominal=191000.0, C_r_nominal=161000.0, C_f_nominal_lo=23500.0,
                            C_r_nominal_lo=18000.0),
    # Pi 2011 Table 3
    "pi2011_suv": dict(m=2325.0, m_s=2090.0, m_uf=138.0, m_ur=97.0, I_xx=750.0, I_zz=3500.0, I_xz=25.0,
                       I_w=2.1, t_f=1.7, t_r=1.7, l_f=1.05, l_r=1.75, l_fs=1.07, l_rs=1.73, h_cg=0.925,
                       h_s=0.6, h_uf=0.535, h_ur=0.535, R_w=0.35, K_phi_f=48000.0, K_phi_r=38000.0,
                       C_phi_f=2800.0, C_phi_r=2600.0, C_sigma=60000.0, C_alpha_f=40000.0, C_alpha_r=40000.0,
                       C_f_nominal=80000.0, C_r_nominal=80000.0),
    # Kim 2016 Table 1
    "kim2016_asm": dict(m=1418.0, l_f=1.064, l_r=1.596, I_zz=1850.0, C_f_nominal=320000.0, C_r_nominal=290000.0),
    # Nguyen 2012 Section V: true 10000, nominal 7000 N/rad per tire
    "nguyen2012_coms": dict(C_alpha_f=10000.0, C_alpha_r=10000.0, C_f_nominal=14000.0, C_r_nominal=14000.0),
}


@pytest.mark.parametrize("name", sorted(PAPER_VALUES))
def test_vehicle_values_from_the_papers(name):
    v = load_vehicle(name)
    for key, value in PAPER_VALUES[name].items():
        assert getattr(v, key) == pytest.approx(value, rel=1e-12), key


@pytest.mark.parametrize("name", sorted(PAPER_VALUES))
def test_values_not_in_the_paper_are_marked_assumed(name):
    src = vehicle_source(name)
    assert src["paper"] and src["table"]
    given = set(PAPER_VALUES[name]) | {"name"}
    undeclared = [f for f in VehicleParams.__dataclass_fields__
                  if f not in given and not any(fnmatch(f, key) for key in src["assumed"])]
    assert undeclared == [], f"{name}: values neither from the paper nor marked assumed: {undeclared}"


def test_every_bundled_vehicle_loads_and_validates():
    assert set(vehicle_names()) == {"park2018_sonata", "pi2011_suv", "kim2016_asm", "nguyen2012_coms", "stanford_track_car",
                                  "commonroad_ford_escort", "commonroad_bmw_320i", "commonroad_vw_vanagon"}
    for n in vehicle_names():
        v = load_vehicle(n)
        assert v.name == n
        assert v.m_s + v.m_uf + v.m_ur == pytest.approx(v.m, rel=0.02)


@pytest.mark.parametrize("override,param_name,allowed", [
    ("m=-5", "vehicle.m", "(0, 100000] kg"),
    ("l_r=0", "vehicle.l_r", "(0, 10] m"),
    ("steering_ratio=0.5", "vehicle.steering_ratio", "(1, 40]"),
    ("h_s=2.0", "vehicle.h_s", "<= sprung CG height"),
    ("K_phi_f=100, K_phi_r=100", "vehicle.K_phi_f", "statically stable roll"),
    ("motor_axle=middle", "vehicle.motor_axle", "one of 'front', 'rear'"),
    ("wheelbase=3", "vehicle.wheelbase", "a known name"),
])
def test_bad_vehicle_values_are_reported_with_name_and_range(override, param_name, allowed):
    with pytest.raises(ParameterError) as e:
        load_vehicle("pi2011_suv", override)
    assert e.value.name == param_name
    assert allowed in str(e.value)


def test_unknown_vehicle_lists_the_known_ones(tmp_path):
    with pytest.raises(ParameterError, match="pi2011_suv"):
        load_vehicle("no_such_car")
    custom = tmp_path / "car.toml"
    bundled = Path(sideslip.vehicles.__file__).with_name("pi2011_suv.toml")
    custom.write_text(bundled.read_text().replace("m = 2325.0", "m = 2330.0"))
    assert load_vehicle(str(custom)).m == 2330.0


def test_cornering_stiffness_depends_on_friction_as_park_table1():
    v = load_vehicle("park2018_sonata")
    assert v.nominal_cornering_stiffness(1.0) == (191000.0, 161000.0)
    assert v.nominal_cornering_stiffness(0.3) == (23500.0, 18000.0)
    assert v.nominal_cornering_stiffness(0.1) == (23500.0, 18000.0)        # held outside
    mid = v.nominal_cornering_stiffness(0.65)
    assert mid[0] == pytest.approx(0.5 * (191000 + 23500))
    assert v.cornering_stiffness(1.0) == (95500.0, 80500.0)                 # plant per tire


# ---------------------------------------------------------------- catalogue
CONTRACT = """delta_f T_drive T_brake Mz_dyc mu bank_angle vx vy yaw_rate beta yaw roll roll_rate ax ay X Y
omega_fl omega_fr omega_rl omega_rr Fy_f Fy_r Fz_fl Fz_fr Fz_rl Fz_rr alpha_f alpha_r ax_m ay_m yaw_rate_m
roll_rate_m delta_m omega_fl_m omega_fr_m omega_rl_m omega_rr_m gps_ve gps_vn gps_speed gps_course gps_fresh
gps_valid mag_x mag_y mag_z beta_hat beta_hat_std vx_hat vy_hat yaw_rate_hat valid Mz_cmd beta_ref
yaw_rate_ref""".split()


def test_catalogue_holds_every_contract_signal():
    assert not set(CONTRACT) - set(SIGNALS)
    for group in (PLANT_INPUTS, PLANT_OUTPUTS, SENSOR_OUTPUTS, ESTIMATOR_COMMON_OUTPUTS, CONTROLLER_INPUTS,
                  CONTROLLER_OUTPUTS):
        assert set(group) <= set(SIGNALS)
    assert {"gps_fresh", "gps_valid", "valid"} <= {n for n, s in SIGNALS.items() if s.kind == "Boolean"}


def test_catalogue_entries_are_complete():
    for name, s in SIGNALS.items():
        assert s.description and s.quantity in QUANTITIES and QUANTITIES[s.quantity] in UNITS, name
        if s.kind == "Real":
            assert math.isfinite(s.min) and math.isfinite(s.max), name
            assert s.min <= s.start <= s.max, name
    for name in ("delta_f", "beta", "yaw", "roll", "alpha_f", "bank_angle", "gps_course", "beta_hat"):
        assert SIGNALS[name].unit == "rad"          # angles are never degrees on a port


def test_units_have_consistent_base_units():
    for u in UNITS.values():
        assert set(u.base) <= {"kg", "m", "s", "A", "K", "mol", "cd", "rad"}
        assert re.fullmatch(r"[A-Za-z0-9./]+", u.name)


def test_a_parameter_error_crosses_a_process_boundary_with_its_message():
    import pickle
    err = ParameterError("vehicle.m", -1.0, "> 0 kg")
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is ParameterError and str(back) == str(err) and back.name == "vehicle.m"
