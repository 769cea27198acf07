"""Build the project's FMUs: pythonfmu packaging plus the fmi2 status shim (linux64).

``build_fmus()`` packs each wrapper with the whole :mod:`sideslip` package in ``resources/``,
state handling and serialisation on, ``needsExecutionTool="false"``; then, when a C
compiler is available, replaces ``binaries/linux64/<id>.so`` by the status shim and ships
pythonfmu's library next to it as ``pythonfmu_export.so``.  Without a compiler the plain
pythonfmu binary is kept and the build says so (FMUs still run; bad parameters are then
reported by a logged error and a refused doStep instead of ``fmi2Error``).

Builds are cached: an FMU is rebuilt when the hash of its sources changes.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from .registry import PACKAGE_DIR, fmu_entries, fmu_entry

__all__ = ["build_fmus", "ensure_fmus", "DEFAULT_OUT", "compile_shim", "BuildError"]

DEFAULT_OUT = Path("build") / "fmus"
SHIM_SOURCE = PACKAGE_DIR / "fmi" / "native" / "fmi2_status_shim.c"
INNER_NAME = "pythonfmu_export.so"


class BuildError(RuntimeError):
    """An FMU could not be built."""


def _fmpy_headers() -> Path:
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


def _find_cc() -> str | None:
    return next((shutil.which(c) for c in (os.environ.get("CC"), "cc", "gcc") if c and shutil.which(c)), None)


def compile_shim(work: Path) -> tuple[Path | None, str]:
    """Compile the status shim; returns ``(path or None, message)``."""
    cc = _find_cc()
    if not cc:
        return None, ("no C compiler found (set CC or install gcc): keeping pythonfmu's plain linux64 binary; "
                      "bad parameters are then reported by a logged error and a refused doStep, not fmi2Error")
    out = work / "fmi2_status_shim.so"
    cmd = [cc, "-shared", "-fPIC", "-O2", "-fvisibility=hidden", f"-I{_fmpy_headers()}", str(SHIM_SOURCE),
           "-o", str(out), "-ldl"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise BuildError(f"compiling the fmi2 status shim failed:\n{' '.join(cmd)}\n{res.stderr}")
    return out, f"status shim compiled with {cc}"


def _source_hash(script: Path, shim: bool) -> str:
    import pythonfmu

    h = hashlib.sha256()
    files = sorted(p for p in PACKAGE_DIR.rglob("*") if p.suffix in (".py", ".toml", ".c")
                   and "__pycache__" not in p.parts)
    for p in [script, *files]:
        h.update(str(p.relative_to(PACKAGE_DIR.parent) if p.is_relative_to(PACKAGE_DIR.parent) else p.name)
                 .encode())
        h.update(p.read_bytes())
    h.update(f"pythonfmu {pythonfmu.__version__} shim {shim} py{sys.version_info[:2]}".encode())
    return h.hexdigest()


def _install_shim(fmu: Path, model_id: str, shim: Path) -> None:
    """Rewrite the FMU zip with the shim as ``<id>.so`` and pythonfmu's library beside it."""
    target = f"binaries/linux64/{model_id}.so"
    tmp = fmu.with_suffix(".tmp")
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        names = src.namelist()
        if target not in names:
            raise BuildError(f"{fmu.name}: {target} missing from the pythonfmu build")
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == target:
                inner = zipfile.ZipInfo(f"binaries/linux64/{INNER_NAME}", item.date_time)
                inner.external_attr = 0o755 << 16
                inner.compress_type = zipfile.ZIP_DEFLATED
                dst.writestr(inner, data)
                dst.write(shim, target)
            else:
                dst.writestr(item, data)
    tmp.replace(fmu)


def _build_one(name: str, out_dir: Path, shim: Path | None) -> Path:
    """Build into a private folder, then move into ``out_dir`` atomically (a concurrent reader
    never sees a half-written FMU)."""
    from pythonfmu.builder import FmuBuilder

    entry = fmu_entry(name)
    with tempfile.TemporaryDirectory(prefix="sideslip_build_") as tmp:
        # pythonfmu copies the project folder; give it a clean copy of the package (no caches)
        pkg = Path(tmp) / "sideslip"
        shutil.copytree(PACKAGE_DIR, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        staging = Path(tmp) / "out"
        staging.mkdir()
        fmu = Path(FmuBuilder.build_FMU(entry.script, dest=staging, project_files=[pkg],
                                        needsExecutionTool=False, canGetAndSetFMUstate=True,
                                        canSerializeFMUstate=True))
        if shim is not None:
            _install_shim(fmu, name, shim)
        final = out_dir / fmu.name
        part = out_dir / f".{fmu.name}.{os.getpid()}.part"
        shutil.copy2(fmu, part)
        os.replace(part, final)
    return final


class _BuildLock:
    """Exclusive lock on ``out_dir`` while FMUs are checked and built (parallel workers that
    all ensure the same FMUs build each one once); a no-op where ``fcntl`` is missing."""

    def __init__(self, out_dir: Path):
        self.path = out_dir / ".build.lock"

    def __enter__(self):
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows: the atomic replace still protects readers
            self.fd = None
            return self
        self.fd = os.open(self.path, os.O_CREAT | os.O_RDWR)
        fcntl.flock(self.fd, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc):
        if self.fd is not None:
            os.close(self.fd)                   # closing releases the lock


def build_fmus(names=None, out_dir: Path | str = DEFAULT_OUT, force: bool = False, log=print) -> list[Path]:
    """Build FMUs (all registered ones by default) into ``out_dir``.

    Parameters
    ----------
    names : iterable of str, optional
        FMU names; unknown names raise ``KeyError`` listing the known ones.
    out_dir : path
        Destination folder (created).
    force : bool
        Rebuild even if the cached build matches the sources.
    log : callable
        Progress messages.

    Raises
    ------
    BuildError
        On any build failure (compile error, packaging error).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = sorted(fmu_entries()) if not names else list(names)
    for name in names:
        fmu_entry(name)
    with_shim = _find_cc() is not None
    with _BuildLock(out_dir):
        digests = {name: _source_hash(fmu_entry(name).script, with_shim) for name in names}
        todo = []
        for name in names:
            fmu, stamp = out_dir / f"{name}.fmu", out_dir / f"{name}.fmu.sha256"
            if not force and fmu.is_file() and stamp.is_file() and stamp.read_text().strip() == digests[name]:
                log(f"{name}: up to date")
            else:
                todo.append(name)
        if todo:
            with tempfile.TemporaryDirectory(prefix="sideslip_shim_") as tmp:
                shim, msg = compile_shim(Path(tmp))     # only when something is built
                log(msg)
                for name in todo:
                    try:
                        fmu = _build_one(name, out_dir, shim)
                    except BuildError:
                        raise
                    except Exception as exc:
                        raise BuildError(f"building {name} failed: {exc!r}") from exc
                    (out_dir / f"{name}.fmu.sha256").write_text(digests[name] + "\n")
                    log(f"{name}: built {fmu}")
    return [out_dir / f"{name}.fmu" for name in names]


def ensure_fmus(names, out_dir: Path | str = DEFAULT_OUT, log=lambda msg: None) -> dict[str, Path]:
    """Paths of the FMUs ``names``, building or rebuilding them when out of date."""
    paths = build_fmus(names, out_dir, log=log)
    return {p.stem: p for p in paths}
