"""An FMU's modules kept importable after its host deletes the unpacked folder, without importing them all.

Hosts such as OMSimulator delete an FMU's unpacked folder once it is loaded, so a module of the FMU's package
imported later (an import inside a function, a model another FMU of the same build asks for) would no longer be
found.  Importing every module at instantiation avoids that, at the price of running them all: about 0.1 s of
every instantiation for modules the FMU's own model never uses.  Instead, :func:`keep_resident` reads the
package's sources while the folder exists and appends a finder to ``sys.meta_path`` that serves them from memory;
it is consulted only when the normal import system cannot find a module of the package (the folder gone), and a
module runs only when first imported.  Data files read at import (the vehicle files) are read by the modules that
the FMU's model imports at instantiation.
"""
from __future__ import annotations

import importlib.abc
import importlib.util
import sys
from pathlib import Path

__all__ = ["ResidentPackage", "keep_resident"]


class ResidentPackage(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finder and loader of one package's modules from sources held in memory.

    Parameters
    ----------
    sources : dict
        ``{module name: (file path, source text, is a package)}``.
    """

    def __init__(self, sources: dict):
        self.sources = sources

    def find_spec(self, fullname, path=None, target=None):
        entry = self.sources.get(fullname)
        if entry is None:
            return None
        origin, _, is_package = entry
        spec = importlib.util.spec_from_loader(fullname, self, origin=origin, is_package=is_package)
        if is_package:
            spec.submodule_search_locations = [str(Path(origin).parent)]
        spec.has_location = True
        return spec

    def create_module(self, spec):
        return None                                   # the default module object

    def exec_module(self, module) -> None:
        origin, text, _ = self.sources[module.__name__]
        exec(compile(text, origin, "exec"), module.__dict__)


def keep_resident(package) -> ResidentPackage:
    """Hold the sources of every module of ``package`` (a package object) in memory and serve them to later
    imports that the normal finders cannot satisfy (see module docstring)."""
    root = Path(package.__path__[0])
    sources = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root).with_suffix("").parts
        is_package = parts[-1] == "__init__"
        name = ".".join((package.__name__, *(parts[:-1] if is_package else parts)))
        sources[name] = (str(path), path.read_text(encoding="utf-8"), is_package)
    finder = ResidentPackage(sources)
    sys.meta_path.append(finder)
    return finder
