"""``vehicle check``, ``identify`` and ``calibrate``: a vehicle file resolved and checked, or made from a calibration
drive (:mod:`sideslip.studies.identify`)."""
from __future__ import annotations

import argparse
from pathlib import Path

from .common import EXAMPLES_FORMAT, window

__all__ = ["register", "vehicle_report"]


def vehicle_report(name_or_path: str) -> str:
    """What a vehicle name or file resolves to: every parameter with its unit and origin, then what follows from them.

    Raises
    ------
    ParameterError
        The message every path gives for that file (:func:`sideslip.vehicles.load_vehicle`).
    """
    from ..bicycle import BicycleModel
    from ..constants import GRAVITY
    from ..params import declared_fields
    from ..vehicles import VehicleParams, resolve_vehicle

    vehicle, origins = resolve_vehicle(name_or_path)
    lines = [f"vehicle {name_or_path}: valid", "", f"{'parameter':16s} {'value':>12s} {'unit':10s} origin"]
    for f, info in declared_fields(VehicleParams):
        if info.fmu:
            value = getattr(vehicle, f.name)
            text = f"{value:12.6g}" if isinstance(value, float) else f"{value!s:>12s}"
            lines.append(f"{f.name:16s} {text} {info.unit:10s} {origins.get(f.name, '?')}")
    model = BicycleModel.from_vehicle(vehicle)
    nominal = BicycleModel.from_vehicle(vehicle, nominal=True)
    lines += ["", "what follows from them:",
              f"  wheelbase {vehicle.l:.3f} m, sprung-mass CG {vehicle.h_scg:.3f} m high, roll axis {vehicle.h_roll_axis:.3f} m",
              f"  static wheel load front {vehicle.static_wheel_load('front'):.0f} N, rear "
              f"{vehicle.static_wheel_load('rear'):.0f} N",
              f"  roll gradient {vehicle.m_s * vehicle.h_s / (vehicle.K_phi_f + vehicle.K_phi_r - vehicle.m_s * GRAVITY * vehicle.h_s) * GRAVITY * 57.2958:.2f} deg/g",
              f"  understeer gradient, tires {model.understeer_gradient * GRAVITY * 57.2958:.2f} deg/g, the estimators' "
              f"nominal axles {nominal.understeer_gradient * GRAVITY * 57.2958:.2f} deg/g; characteristic speed "
              f"{nominal.characteristic_speed:.1f} m/s"]
    return "\n".join(lines)


def _cmd_vehicle_check(args) -> int:
    print(vehicle_report(args.file))
    return 0


def _cmd_identify(args) -> int:
    from ..recording import read_log
    from ..studies.identify import identify, vehicle_toml
    from ..vehicles import load_vehicle

    base = load_vehicle(args.vehicle)
    logs = [read_log(p, args.map) for p in args.log]
    lows = [read_log(p, args.map) for p in args.low_friction_log or []]
    result = identify(logs, base, fix=args.fix or (), low_friction=list(args.low_friction or []),
                      low_friction_logs=lows)
    print(result.table())
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(vehicle_toml(result, args.vehicle, args.log + (args.low_friction_log or [])))
    print(f"\nwrote {out} (check it with: python -m sideslip replay --vehicle {out} ...)")
    return 0


def _cmd_calibrate(args) -> int:
    from ..recording import write_log
    from ..studies.calibration import calibrate, commonroad_vehicle_file
    from ..studies.identify import vehicle_toml

    cal = calibrate(args.plant, args.vehicle, args.seed)
    print(f"calibration drive on {args.plant}" + (f" ({args.vehicle})" if args.plant == "own" else "")
          + f", sensors of seed {args.seed}:\n" + cal.table())
    if args.logs:
        for leg, rec in cal.legs.items():
            print("wrote", write_log(rec.on_grid(0.01), Path(args.logs) / f"{leg}.csv"))
    if args.out:
        text = (vehicle_toml(cal.result, args.vehicle, ["the calibration drive on the own plant"])
                if args.plant == "own" else commonroad_vehicle_file(cal))
        Path(args.out).write_text(text)
        print("wrote", args.out)
    return 0


def register(sub) -> None:
    veh = sub.add_parser("vehicle", help="check a vehicle file: what it resolves to, and why it is refused",
                         description="Resolve a vehicle file (its base, derived values) and validate it as every "
                         "model does; print each parameter with its unit and origin. The format: docs/vehicle-files.md.",
                         epilog="example:\n  python -m sideslip vehicle check my_car.toml",
                         formatter_class=argparse.RawDescriptionHelpFormatter)
    vsub = veh.add_subparsers(dest="action", required=True)
    chk = vsub.add_parser("check", help="resolve and validate a vehicle file")
    chk.add_argument("file", help="a vehicle TOML file or a bundled vehicle name")
    chk.set_defaults(func=_cmd_vehicle_check)
    ide = sub.add_parser("identify", help="a vehicle file from a calibration drive: cornering stiffnesses, yaw "
                         "inertia, steering gain and the sensors' offsets, each with its standard deviation",
                         description="Fit the single-track model to a calibration drive (a slow circle both ways and "
                         "a steering sweep; see the 'Your car' page) and write a vehicle file inheriting --vehicle.",
                         formatter_class=EXAMPLES_FORMAT, epilog="example:\n  sideslip identify --log circle.csv --log "
                         "sweep.csv --map map.toml --vehicle park2018_sonata --out my_car.toml")
    ide.add_argument("--log", action="append", required=True, help="a CSV log of the drive (repeatable: one per leg)")
    ide.add_argument("--map", help="TOML map of the logs' columns to signals, units, scale and offset")
    ide.add_argument("--vehicle", required=True, help="the car as known (bundled name or TOML file): mass, geometry, "
                     "rolling radius and track are used as they are")
    ide.add_argument("--out", required=True, help="the vehicle file to write")
    ide.add_argument("--fix", action="append", metavar="NAME", help="hold a parameter at the base's value instead of "
                     "fitting it (repeatable)")
    ide.add_argument("--low-friction", action="append", metavar="START:END", type=window, help="time window [s] driven on a "
                     "low-friction surface (repeatable)")
    ide.add_argument("--low-friction-log", action="append", metavar="LOG", help="a log driven on a low-friction "
                     "surface throughout (repeatable)")
    ide.set_defaults(func=_cmd_identify)
    cal = sub.add_parser("calibrate", help="drive the calibration procedure on a simulated plant and identify the "
                         "car, each value beside the plant's truth", formatter_class=EXAMPLES_FORMAT,
                         epilog="example:\n  sideslip calibrate --plant commonroad2 --logs out/cal --out bmw.toml")
    cal.add_argument("--plant", default="commonroad2", help="own, commonroad1, commonroad2 or commonroad3 "
                     "(default %(default)s)")
    cal.add_argument("--vehicle", default="pi2011_suv", help="the own plant's vehicle (default %(default)s)")
    cal.add_argument("--seed", type=int, default=0, help="the sensors' draw (default %(default)s)")
    cal.add_argument("--logs", help="also write the drive's legs as CSV logs into this folder")
    cal.add_argument("--out", help="write the identified vehicle file here")
    cal.set_defaults(func=_cmd_calibrate)
