"""``list``, ``build`` and ``docs``: what the project has, its FMUs and their reference pages."""
from __future__ import annotations

__all__ = ["register"]


def _cmd_list(args) -> int:
    from ..fmi.catalogue import CATALOGUE
    from ..plant.maneuvers import maneuver_names
    from ..vehicles import vehicle_names
    from ..scenarios import SCENARIOS, get_scenario, scenario_names

    print("scenarios:")
    for name in scenario_names():
        if name.startswith("fmvss126") and name not in SCENARIOS:
            print(f"  {name:34s} (FMVSS 126 family; A computed on first use)")
            continue
        sc = get_scenario(name)
        print(f"  {name:34s} {sc.vehicle:16s} {sc.duration:6.0f} s  {sc.description}  [{sc.source}]")
    print("\nFMUs:")
    for name, e in sorted(CATALOGUE.items(), key=lambda kv: (kv[1].role, kv[0])):
        print(f"  {name:24s} {e.role:11s} {len(e.inputs):3d} inputs {len(e.outputs):3d} outputs")
    print("\nvehicles:  " + ", ".join(vehicle_names()))
    print("maneuvers: " + ", ".join(maneuver_names()))
    return 0


def _cmd_build(args) -> int:
    from ..fmi.build import build_fmus

    build_fmus(args.names or None, args.fmu_dir, force=args.force)
    return 0


def _cmd_docs(args) -> int:
    from ..fmi.docs import write_fmu_pages

    for path in write_fmu_pages(args.out):
        print(f"wrote {path}")
    return 0


def register(sub) -> None:
    sub.add_parser("list", help="scenarios, FMUs, vehicles, maneuvers").set_defaults(func=_cmd_list)
    build = sub.add_parser("build", help="build the FMUs")
    build.add_argument("names", nargs="*")
    build.add_argument("--force", action="store_true")
    build.set_defaults(func=_cmd_build)
    docs = sub.add_parser("docs", help="write the per-FMU reference pages of the documentation (docs/fmus)")
    docs.add_argument("--out", default="docs/fmus", help="folder of the pages (default %(default)s)")
    docs.set_defaults(func=_cmd_docs)
