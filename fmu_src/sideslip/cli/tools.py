"""``list``, ``build`` and ``docs``: what the project has, its FMUs and their reference pages."""
from __future__ import annotations

import argparse

__all__ = ["register"]


KINDS = ("scenarios", "fmus", "vehicles", "maneuvers")
"""What ``list`` lists."""


def _cmd_list(args) -> int:
    from ..fmi.catalogue import CATALOGUE
    from ..plant.maneuvers import maneuver_names
    from ..vehicles import vehicle_names
    from ..scenarios import SCENARIOS, get_scenario, scenario_names

    text = (args.grep or "").lower()
    kinds = [args.kind] if args.kind else list(KINDS)
    lines = {kind: [] for kind in kinds}
    for kind in kinds:
        if kind == "scenarios":
            for name in scenario_names():
                if text not in name.lower():
                    continue
                if name.startswith("fmvss126") and name not in SCENARIOS:
                    lines[kind].append(f"  {name:34s} (FMVSS 126 family; A computed on first use)")
                    continue
                sc = get_scenario(name)
                lines[kind].append(f"  {name:34s} {sc.vehicle:16s} {sc.duration:6.0f} s  {sc.description}  "
                                   f"[{sc.source}]")
        elif kind == "fmus":
            lines[kind] = [f"  {name:24s} {e.role:11s} {len(e.inputs):3d} inputs {len(e.outputs):3d} outputs"
                           for name, e in sorted(CATALOGUE.items(), key=lambda kv: (kv[1].role, kv[0]))
                           if text in name.lower() or text in e.role]
        else:
            names = vehicle_names() if kind == "vehicles" else maneuver_names()
            lines[kind] = [f"  {name}" for name in names if text in name.lower()]
    for i, kind in enumerate(kinds):
        if len(kinds) > 1:
            print(("\n" if i else "") + f"{kind} ({len(lines[kind])}):")
        print("\n".join(lines[kind]) if lines[kind] else f"  none matches {args.grep!r}")
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
    lst = sub.add_parser("list", help="scenarios, FMUs, vehicles, maneuvers",
                         epilog="examples:\n  sideslip list fmus\n  sideslip list scenarios --grep snow",
                         formatter_class=argparse.RawDescriptionHelpFormatter)
    lst.add_argument("kind", nargs="?", choices=KINDS, help="list only these (default: all four)")
    lst.add_argument("--grep", metavar="TEXT", help="only names containing TEXT (case-insensitive; FMUs also by role)")
    lst.set_defaults(func=_cmd_list)
    build = sub.add_parser("build", help="build the FMUs", epilog="examples:\n  sideslip build\n  sideslip build "
                           "SideslipFusion VehiclePlant --force", formatter_class=argparse.RawDescriptionHelpFormatter)
    build.add_argument("names", nargs="*", metavar="FMU", help="FMUs to build (default: every one of the catalogue)")
    build.add_argument("--force", action="store_true", help="rebuild even when the built FMU is up to date")
    build.set_defaults(func=_cmd_build)
    docs = sub.add_parser("docs", help="write the per-FMU reference pages of the documentation (docs/fmus)")
    docs.add_argument("--out", default="docs/fmus", help="folder of the pages (default %(default)s)")
    docs.set_defaults(func=_cmd_docs)
