"""The Python packages an FMU needs at run time, for ``resources/requirements.txt``.

``pythonfmu deploy FMU`` pip-installs that file into the current environment.  The list is
derived, not written by hand: the wrapper script and every module of :mod:`sideslip` it
reaches are parsed (imports inside functions included), the third-party top-level modules
found are mapped to their distributions, and each distribution gets the version range the
project declares for it (``pyproject.toml``), else ``>=`` the version installed at build time.
"""
from __future__ import annotations

import ast
import sys
from importlib import metadata
from pathlib import Path

from .registry import PACKAGE_DIR

__all__ = ["imported_modules", "fmu_requirements"]

PROJECT = "sideslip-fmu"
BUNDLED = {"pythonfmu"}
"""Packages pythonfmu's builder copies into every FMU's ``resources/`` (not requirements)."""


def _module_file(name: str) -> Path | None:
    """Source file of ``sideslip.x.y`` inside the package tree, or None."""
    parts = name.split(".")[1:]
    base = PACKAGE_DIR.joinpath(*parts)
    for cand in (base.with_suffix(".py"), base / "__init__.py"):
        if cand.is_file():
            return cand
    return None


def _package_of(path: Path) -> str:
    rel = path.relative_to(PACKAGE_DIR.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    else:
        parts.pop()                        # a module's package
    return ".".join(parts)


def imported_modules(script: Path) -> set[str]:
    """Top-level names of the third-party modules imported by ``script`` and the project
    modules it reaches (transitively); the standard library and :data:`BUNDLED` left out."""
    found: set[str] = set()
    todo, seen = [Path(script)], set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        inside = path.is_relative_to(PACKAGE_DIR)
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level and inside:
                    pkg = _package_of(path).split(".")
                    base = ".".join(pkg[:len(pkg) - node.level + 1])
                    mod = f"{base}.{node.module}" if node.module else base
                    names = [mod] + [f"{mod}.{a.name}" for a in node.names]
                elif node.level:
                    continue
                else:
                    names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            for name in names:
                if name.split(".")[0] == PACKAGE_DIR.name:
                    f = _module_file(name)
                    if f is not None:
                        todo.append(f)
                else:
                    found.add(name.split(".")[0])
    return {m for m in found if m not in sys.stdlib_module_names and m not in BUNDLED and m != "__future__"}


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


def fmu_requirements(script: Path) -> list[str]:
    """Requirement lines for the FMU built from ``script`` (sorted, with build versions noted).

    Raises
    ------
    RuntimeError
        When an imported module belongs to no installed distribution (the FMU could not run).
    """
    dists = metadata.packages_distributions()
    declared = _declared()
    lines = []
    for module in sorted(imported_modules(script)):
        owners = dists.get(module)
        if not owners:
            raise RuntimeError(f"{script}: module {module!r} belongs to no installed distribution")
        name = owners[0]
        key = name.lower().replace("_", "-")
        version = metadata.version(name)
        spec = declared.get(key, f"{name}>={version}")
        lines.append(f"{spec}  # built with {name} {version}")
    return sorted(set(lines), key=str.lower)
