"""What goes into an FMU: the project modules it runs and the packages it needs installed.

An FMU carries only code that runs inside FMUs: the modules of :mod:`sideslip` reached from the
wrappers and the catalogue entries' models (imports are parsed, those inside functions
included, and every parent package comes along), plus the data files lying in those packages'
folders (the vehicle TOMLs).  The co-simulation masters, the studies, the command line and the
builder itself stay out.

``resources/requirements.txt`` (for ``pythonfmu deploy``) lists the third-party packages those
modules import, mapped to their distributions, each with the version range the project
declares for it (``pyproject.toml``), else ``>=`` the version installed at build time.
"""
from __future__ import annotations

import ast
import importlib.util
import sys
from functools import lru_cache
from importlib import metadata
from pathlib import Path

import sideslip

from .catalogue import FmuSpec

__all__ = ["PACKAGE_DIR", "wrapper_script", "module_imports", "module_name", "bundled_files", "imported_modules",
           "fmu_requirements"]

PACKAGE_DIR = Path(sideslip.__file__).resolve().parent
"""The installed :mod:`sideslip` package folder."""

PROJECT = "sideslip-fmu"
BUNDLED = {"pythonfmu"}
"""Packages pythonfmu's builder copies into every FMU's ``resources/`` (not requirements)."""

_DATA_SUFFIXES = (".toml",)
"""Data files an FMU needs from the folders of its packages."""


def wrapper_script(spec: FmuSpec) -> Path:
    """The wrapper module file of a catalogue entry, found through the import system (editable or
    installed alike).

    Raises
    ------
    FileNotFoundError
        When the module is not importable.
    """
    try:
        found = importlib.util.find_spec(spec.import_name)
    except ModuleNotFoundError:                     # the plant side's package itself is missing
        found = None
    if found is None or not found.origin:
        raise FileNotFoundError(f"FMU {spec.name}: wrapper module {spec.import_name!r} is not importable "
                                "(is sideslip-fmu installed?)")
    return Path(found.origin)


def _module_file(name: str) -> Path | None:
    """Source file of ``sideslip.x.y`` inside the package tree, or None."""
    base = PACKAGE_DIR.joinpath(*name.split(".")[1:])
    for cand in (base.with_suffix(".py"), base / "__init__.py"):
        if cand.is_file():
            return cand
    return None


def module_name(path: Path) -> str:
    """Dotted name of a file of the :mod:`sideslip` package."""
    rel = path.relative_to(PACKAGE_DIR.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def module_imports(path: Path) -> set[str]:
    """Absolute names a file imports (relative imports resolved; ``from m import x`` gives ``m`` and
    ``m.x``, which is a module when such a file exists)."""
    stat = path.stat()
    return set(_parsed_imports(path, stat.st_mtime_ns, stat.st_size))


@lru_cache(maxsize=1024)
def _parsed_imports(path: Path, mtime_ns: int, size: int) -> frozenset:
    """:func:`module_imports` of one version of a file (parsed once; every build asks for every file)."""
    name = module_name(path) if path.is_relative_to(PACKAGE_DIR) else path.stem
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = ".".join(base[:len(base) - node.level + 1])
                mod = f"{base}.{node.module}" if node.module else base
            else:
                mod = node.module
            found.add(mod)
            found |= {f"{mod}.{a.name}" for a in node.names}
    return frozenset(found)


def _closure(script: Path, extra_modules=()) -> tuple[set[Path], set[str]]:
    """Project files reached from ``script`` and ``extra_modules``, and the other top-level modules."""
    files: set[Path] = set()
    others: set[str] = set()
    todo = [script] + [f for f in map(_module_file, extra_modules) if f is not None]
    while todo:
        path = todo.pop()
        if path in files:
            continue
        files.add(path)
        for name in module_imports(path):
            top = name.split(".")[0]
            if top != PACKAGE_DIR.name:
                others.add(top)
                continue
            parts = name.split(".")
            for i in range(1, len(parts) + 1):           # the module and every parent package
                f = _module_file(".".join(parts[:i]))
                if f is not None and f not in files:
                    todo.append(f)
    return files - {script}, others


def _own_modules(spec: FmuSpec) -> set[Path]:
    """The modules an FMU's own code reaches (its wrapper, model and configuration)."""
    return _closure(wrapper_script(spec), (spec.library_module, spec.config.partition(":")[0]))[0]


def bundled_files(spec: FmuSpec) -> list[Path]:
    """Files of :mod:`sideslip` an FMU carries: the modules any FMU of the catalogue runs, and the
    data files of their packages.

    Every FMU carries the union rather than only its own modules because FMUs loaded into one
    interpreter share one ``sideslip`` package, the first one's: a plant FMU loaded after an
    estimator FMU must find the plant's modules there.
    """
    from .catalogue import CATALOGUE

    modules = set().union(*(_own_modules(s) for s in CATALOGUE.values()))
    data = {p for m in modules if m.name == "__init__.py" for p in m.parent.iterdir()
            if p.suffix in _DATA_SUFFIXES and p.is_file()}
    return sorted(modules | data)


def imported_modules(spec: FmuSpec) -> set[str]:
    """Top-level names of the third-party modules an FMU imports (standard library and
    :data:`BUNDLED` left out)."""
    _, others = _closure(wrapper_script(spec), (spec.library_module, spec.config.partition(":")[0]))
    return {m for m in others if m not in sys.stdlib_module_names and m not in BUNDLED and m != "__future__"}


def _declared() -> dict[str, str]:
    """Requirement strings of the project by normalised distribution name."""
    try:
        reqs = metadata.requires(PROJECT) or []
    except metadata.PackageNotFoundError:
        return {}
    out = {}
    for r in reqs:
        if "extra ==" in r:
            continue
        spec = r.split(";")[0].strip()
        name = spec.split(">")[0].split("<")[0].split("=")[0].split("~")[0].split("!")[0].split("[")[0].strip()
        out[name.lower().replace("_", "-")] = spec
    return out


def fmu_requirements(spec: FmuSpec) -> list[str]:
    """Requirement lines for an FMU (sorted, with build versions noted).

    Raises
    ------
    RuntimeError
        When an imported module belongs to no installed distribution (the FMU could not run).
    """
    dists = metadata.packages_distributions()
    declared = _declared()
    lines = []
    for module in sorted(imported_modules(spec)):
        owners = dists.get(module)
        if not owners:
            raise RuntimeError(f"FMU {spec.name}: module {module!r} belongs to no installed distribution")
        name = owners[0]
        key = name.lower().replace("_", "-")
        version = metadata.version(name)
        requirement = declared.get(key, f"{name}>={version}")
        lines.append(f"{requirement}  # built with {name} {version}")
    return sorted(set(lines), key=str.lower)
