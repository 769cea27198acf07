"""Calibration drives on the simulated plants: what :mod:`~sideslip.studies.identify` recovers of a car whose truth
is known, and the vehicle files of the CommonRoad cars (:data:`~sideslip.studies.drives.COMMONROAD_VEHICLES`).

A calibration (:func:`calibrate`) drives the procedure of :func:`~sideslip.studies.drives.calibration_maneuvers`
on a plant with the ``sensors`` condition's errors drawn for its seed (a user's production sensors), identifies
the car from the sensors alone and sets each value beside its reference:

* on the own plant, the plant's truth: its tires' axle stiffness (Dugoff: ``2 C_alpha``, at ``mu_lo`` the
  ``*_lo`` values), its yaw inertia, and the offsets the seed drew;
* on a CommonRoad set, the PAC2002 tires' axle stiffness at the static loads
  (:func:`~sideslip.studies.drives.pac2002_axle_stiffness`; its friction scaling leaves the slip stiffness as it
  is, so the low-friction reference is the same), the set's sprung-mass yaw inertia ``I_z`` plus its unsprung
  masses at the axles, and the drawn offsets.

The single-track model is not the plant: the identified stiffnesses are the car's effective ones (load transfer,
roll steer and compliance included), so they differ from the tires' by a few per cent, which the standard
deviations (statistical, given the model) do not cover.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..constants import GRAVITY
from ..scenarios import _BENCH_SENSORS
from ..units import DEG
from ..vehicles import load_vehicle
from .accuracy import Case, sensor_errors
from .drives import (CALIBRATION_LOW_MU, COMMONROAD_TEMPLATE, calibration_drive, commonroad_base,
                     pac2002_axle_stiffness, vehicle_set)
from .identify import Identification, identify, vehicle_toml

__all__ = ["Calibration", "calibrate", "commonroad_vehicle_file"]

_OFFSETS = ("yaw_rate_bias", "ay_bias", "ax_bias", "steer_bias")


@dataclass
class Calibration:
    """A calibration on a simulated plant: the identification, the reference of each value, the legs driven."""

    plant: str
    result: Identification
    reference: dict
    legs: dict
    seed: int = 0                    #: the sensors' draw

    def table(self) -> str:
        """Each identified value, its standard deviation and its reference, display units."""
        from .identify import _display

        rows = [f"{'parameter':<16} {'identified':>12} {'std':>10} {'reference':>12} {'error':>8}  unit"]
        for name, e in self.result.estimates.items():
            scale, unit = _display(name)
            ref = self.reference.get(name)
            std = "held" if e.fixed else f"{e.std * scale:.3g}"
            if ref is None:
                rows.append(f"{name:<16} {e.value * scale:12.5g} {std:>10} {'-':>12} {'':>8}  {unit}")
                continue
            err = (f"{100 * (e.value / ref - 1):+.1f} %" if name.startswith(("C_", "I_")) and ref
                   else f"{(e.value - ref) * scale:+.3g}")
            rows.append(f"{name:<16} {e.value * scale:12.5g} {std:>10} {ref * scale:12.5g} {err:>8}  {unit}")
        r = self.result.residual
        rows.append(f"residual RMS: yaw rate {r['yaw_rate'] * DEG:.3g} deg/s, lateral acceleration {r['ay']:.3g} "
                    f"m/s2; the fitted model's sideslip against the truth {self.result.beta_rms * DEG:.3g} deg RMS")
        return "\n".join(rows)


def calibrate(plant: str, vehicle: str = "pi2011_suv", seed: int = 0) -> Calibration:
    """Drive the calibration procedure on a plant (``own`` with the bundled ``vehicle``, or ``commonroadN``) with the
    sensors of ``seed`` and identify the car (module docstring)."""
    n = vehicle_set(plant)
    errors = sensor_errors(Case("calibration", "sensors", seed))
    sensors = {**_BENCH_SENSORS, **errors, "seed": 2000 + seed}
    if n is None:
        name, overrides = vehicle, {}
    else:
        name, overrides = COMMONROAD_TEMPLATE, commonroad_base(n)
    base = load_vehicle(name, overrides)
    legs = calibration_drive(plant, name, overrides, base, sensors)
    low = [rec for leg, rec in legs.items() if leg.endswith("low_friction")]
    result = identify([rec for leg, rec in legs.items() if not leg.endswith("low_friction")], base,
                      low_friction_logs=low)
    reference = {k: errors[k] for k in _OFFSETS}
    reference["steer_gain"] = 1.0
    if n is None:
        lo = base.mu_lo == CALIBRATION_LOW_MU
        # the roll model's steady gradient, g m_s h_s / (K_phi - m_s g h_s) (the plant's roll equation)
        mgh = base.m_s * GRAVITY * base.h_s
        reference.update(C_f_nominal=2 * base.C_alpha_f, C_r_nominal=2 * base.C_alpha_r, I_zz=base.I_zz,
                         ay_roll_gain=mgh / (base.K_phi_f + base.K_phi_r - mgh),
                         **({"C_f_nominal_lo": 2 * base.C_alpha_f_lo, "C_r_nominal_lo": 2 * base.C_alpha_r_lo}
                            if lo else {}))
    else:
        from ..plant.commonroad import vehicle_parameters

        p = vehicle_parameters(n)
        c_f, c_r = pac2002_axle_stiffness(n)
        reference.update(C_f_nominal=c_f, C_r_nominal=c_r, C_f_nominal_lo=c_f, C_r_nominal_lo=c_r,
                         I_zz=p.I_z + p.m_uf * overrides["l_f"] ** 2 + p.m_ur * overrides["l_r"] ** 2)
    return Calibration(plant, result, reference, legs, seed)


def commonroad_vehicle_file(calibration: Calibration) -> str:
    """The bundled vehicle file of a CommonRoad set: :data:`~sideslip.studies.drives.COMMONROAD_TEMPLATE` as its
    base, the set's geometry and mass, the identified values, every estimate in ``[identified]``."""
    from ..plant.commonroad import VEHICLE_SETS

    n = vehicle_set(calibration.plant)
    known = commonroad_base(n)
    result = calibration.result
    text = vehicle_toml(result, COMMONROAD_TEMPLATE, [f"the calibration drive on {calibration.plant}"])
    head, _, rest = text.partition("[params]\n")
    given = "\n".join(f"{k} = {v!r}" for k, v in known.items() if k != "I_zz")
    source = (f"[source]\npaper = \"CommonRoad vehicle models, parameter set {n} ({VEHICLE_SETS[n]}), as a user "
              "knows the car\"\n"
              "table = \"masses, CG position and height, tracks, rolling radius and drive/brake split from the set; "
              f"the cornering stiffnesses, the yaw inertia and the roll stiffness identified (python -m sideslip calibrate --plant "
              f"{calibration.plant} --seed {calibration.seed}); the rest from the base car\"\n"
              f"[source.assumed]\n\"*\" = \"the base car's ({COMMONROAD_TEMPLATE})\"\n\n")
    return head + source + "[params]\n" + given + "\n" + rest
