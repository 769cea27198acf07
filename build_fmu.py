"""Build every FMU of the project: ``python build_fmu.py [--out DIR] [--force] [NAME ...]``.

Default output folder: ``build/fmus/``.  Needs the project installed (``pip install -e .``);
exits non-zero with the reason on any failure.  Same as ``python -m sideslip build``.
"""
import argparse
import sys

from sideslip.fmi.build import DEFAULT_OUT, BuildError, build_fmus
from sideslip.fmi.catalogue import fmu_names


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"FMUs to build (default: all: {', '.join(fmu_names())})")
    parser.add_argument("--out", default=str(DEFAULT_OUT), help="output folder (default: %(default)s)")
    parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = parser.parse_args(argv)
    try:
        build_fmus(args.names or None, args.out, force=args.force)
    except (BuildError, KeyError) as exc:
        print(f"build_fmu: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
