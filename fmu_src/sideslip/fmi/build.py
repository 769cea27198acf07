"""Build the project's FMUs: pythonfmu packaging plus the fmi2 shim (linux64 and win64).

``build_fmus()`` packs each wrapper of the catalogue (:mod:`sideslip.fmi.catalogue`) with the
modules of :mod:`sideslip` that run inside it (:mod:`sideslip.fmi.bundle`) and a
``requirements.txt`` (for ``pythonfmu deploy``) in ``resources/``, state handling and
serialisation on, ``needsExecutionTool="false"``; then, when a C compiler is available,
replaces ``binaries/linux64/<id>.so`` by the shim and ships pythonfmu's library next to it as
``pythonfmu_export.so``.  The shim is compiled with this Python's libpython path, prefix and
site-packages (``shim_config.h``), so that a C host without Python gets this interpreter and
these packages.  Without a compiler the plain pythonfmu binary is kept and the build says so
(FMUs still run in Python hosts; bad parameters are then reported by a logged error and a
refused doStep instead of ``fmi2Error``; C hosts must preload libpython).  Likewise, when the
mingw-w64 cross compiler (``x86_64-w64-mingw32-gcc``, or ``$SIDESLIP_MINGW_CC``) is available,
``binaries/win64/<id>.dll`` becomes the same shim built for Windows (it finds the user's Python 3.X
itself, see the shim's comment) with pythonfmu's DLL beside it as ``pythonfmu_export.dll``;
without it pythonfmu's stock win64 binary is kept.

Every FMU whose models have compiled parts (the plant's, the driver's and the LQR's steps, SideslipFusion's scalar
models: :mod:`sideslip.plant.kernel`) carries them for the platforms whose compiler is there, in its package's
``plant/native/<platform>/``.

Builds are cached: an FMU is rebuilt when the hash of the files it carries changes.

Each FMU carries the package under a name of its own build, ``sideslip_<hash>`` (the first 12
digits of that hash), and its wrapper as ``<module>_<hash>``: hosts load every FMU into one
Python interpreter and one ``sys.modules``, so FMUs of two builds (or of two versions of the
project) in one process would otherwise share the code of whichever was loaded first, and one
FMU would import from another FMU's unpacked folder, which some hosts delete.
"""
from __future__ import annotations

import compileall
import hashlib
import os
import py_compile
import re
import shutil
import site
import sysconfig
import subprocess
import sys
import tempfile
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from .bundle import PACKAGE_DIR, bundled_files, fmu_requirements, wrapper_script
from .catalogue import CATALOGUE, fmu_spec

__all__ = ["build_fmus", "ensure_fmus", "DEFAULT_OUT", "compile_shim", "compile_kernel", "python_config", "BuildError"]

DEFAULT_OUT = Path(os.environ.get("SIDESLIP_FMU_DIR") or Path("build") / "fmus")
"""Where the FMUs are built and found by default: ``$SIDESLIP_FMU_DIR``, else ``build/fmus`` under the working
folder (a notebook or a script in another folder can share one build through the variable)."""
SHIM_SOURCE = PACKAGE_DIR / "fmi" / "native" / "fmi2_status_shim.c"
KERNEL_SOURCES = (*(PACKAGE_DIR / "plant" / "native" / f"{model}_kernel.c" for model in ("plant", "driver")),
                  PACKAGE_DIR / "control" / "native" / "lqr_kernel.c",
                  PACKAGE_DIR / "estimators" / "fusion" / "native" / "fusion_kernel.c")
"""The plant's, the driver's and the LQR's compiled steps and SideslipFusion's scalar models
(:mod:`sideslip.plant.kernel`, one binary), built for each platform into the FMUs."""
KERNEL_HEADERS = (PACKAGE_DIR / "plant" / "native" / "python_math.h",)
"""What the kernel's C files include (Python's float semantics)."""
KERNEL_MODULE = PACKAGE_DIR / "plant" / "kernel.py"
FP_FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math"]
"""The kernel computes the same doubles as its Python reference: IEEE arithmetic, no fused multiply-adds."""
PLATFORMS = {"linux64": ".so", "win64": ".dll"}
"""The binaries the shim replaces: platform folder -> file extension."""
INNER_NAME = "pythonfmu_export"
"""pythonfmu's library in the FMU, beside the shim (plus the platform's extension)."""


class BuildError(RuntimeError):
    """An FMU could not be built."""


def _fmpy_headers() -> Path:
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


def _find_cc(platform: str = "linux64") -> str | None:
    """The C compiler for a platform's shim, or ``None``."""
    names = (os.environ.get("CC"), "cc", "gcc") if platform == "linux64" else \
        (os.environ.get("SIDESLIP_MINGW_CC"), "x86_64-w64-mingw32-gcc")
    return next((shutil.which(c) for c in names if c and shutil.which(c)), None)


def python_config() -> dict[str, str]:
    """What the shim needs to start this Python in a host that has none.

    Returns
    -------
    dict
        ``libpython`` (path of this interpreter's shared library, ``""`` for a static build),
        ``home`` (``sys.base_prefix``), ``site`` (this environment's site-packages,
        ``os.pathsep``-separated) and ``sonames`` (fallback library names of this version).
    """
    libdir = sysconfig.get_config_var("LIBDIR") or ""
    names = [sysconfig.get_config_var(k) for k in ("INSTSONAME", "LDLIBRARY")]
    libs = [os.path.join(libdir, n) for n in names if n and ".so" in n]     # not a static libpython.a
    libpython = next((lib for lib in libs if os.path.isfile(lib)), "")
    dirs = [p for p in site.getsitepackages() + [site.getusersitepackages()] if p in sys.path and os.path.isdir(p)]
    ver = f"{sys.version_info.major}.{sys.version_info.minor}"
    abi = getattr(sys, "abiflags", "")
    sonames = [f"libpython{ver}{abi}.so.1.0", f"libpython{ver}{abi}.so"]
    return {"libpython": libpython, "home": sys.base_prefix, "site": os.pathsep.join(dirs),
            "sonames": os.pathsep.join(sonames)}


def _c_string(text: str) -> str:
    """C string literal of ``text`` (UTF-8, octal escapes for anything unusual)."""
    out = []
    for b in text.encode():
        ch = chr(b)
        out.append(ch if 32 <= b < 127 and ch not in '"\\?' else f"\\{b:03o}")
    return '"' + "".join(out) + '"'


def _write_config_header(path: Path, platform: str, guid: str) -> None:
    """The shim's build-time facts: on Linux the Python the FMUs were built with (paths), on Windows
    only its version (the user's own Python 3.X is found at run time); the FMU's GUID."""
    cfg = python_config() if platform == "linux64" else {"libpython": "", "home": "", "site": "", "sonames": ""}
    lines = ["/* generated by sideslip/fmi/build.py: the Python the FMUs were built with, the FMU's GUID */"]
    for key, macro in (("libpython", "SIDESLIP_BUILD_LIBPYTHON"), ("home", "SIDESLIP_BUILD_HOME"),
                       ("site", "SIDESLIP_BUILD_SITE"), ("sonames", "SIDESLIP_PY_SONAMES")):
        lines.append(f"#define {macro} {_c_string(cfg[key])}")
    major, minor = sys.version_info[:2]
    lines.append(f'#define SIDESLIP_PY_VERSION "{major}.{minor}"')
    lines.append(f'#define SIDESLIP_PY_DLL "python{major}{minor}.dll"')
    lines.append(f"#define SIDESLIP_FMU_GUID {_c_string(guid)}")
    path.write_text("\n".join(lines) + "\n")


_NO_COMPILER = {
    "linux64": ("no C compiler found (set CC or install gcc): keeping pythonfmu's plain linux64 binary; bad "
                "parameters are then reported by a logged error and a refused doStep, not fmi2Error, and C hosts "
                "must preload libpython"),
    "win64": ("no mingw-w64 cross compiler found (install gcc-mingw-w64-x86-64 or set SIDESLIP_MINGW_CC): keeping "
              "pythonfmu's stock win64 binary (no status mapping, and Python must be on PATH)"),
}


def compile_shim(work: Path, guid: str = "", platform: str = "linux64") -> tuple[Path | None, str]:
    """Compile the shim of a platform (``linux64`` or ``win64``) for an FMU's GUID (checked at
    instantiation; empty: not checked); returns ``(path or None, message)``."""
    cc = _find_cc(platform)
    if not cc:
        return None, _NO_COMPILER[platform]
    _write_config_header(work / "shim_config.h", platform, guid)
    out = work / f"fmi2_status_shim{PLATFORMS[platform]}"
    flags = ["-fPIC", "-pthread", "-fvisibility=hidden"] if platform == "linux64" else \
        ["-s", "-static-libgcc", "-D__USE_MINGW_ANSI_STDIO=1"]          # no DLL of the compiler's own
    libs = ["-ldl"] if platform == "linux64" else ["-ladvapi32"]
    _compile([cc, "-shared", "-O2", *flags, f"-I{work}", f"-I{_fmpy_headers()}", str(SHIM_SOURCE), "-o", str(out),
              *libs], f"the fmi2 status shim ({platform})")
    return out, f"{platform} status shim compiled with {cc}"


def compile_kernel(work: Path, platform: str = "linux64") -> Path | None:
    """Compile the plant's, the driver's and the LQR's steps and SideslipFusion's scalar models
    (:data:`KERNEL_SOURCES`, one binary) for a platform into ``work``; None without its compiler (they then run their
    Python reference there)."""
    from ..plant.kernel import LIBRARY_NAME

    cc = _find_cc(platform)
    if not cc:
        return None
    out = work / f"{LIBRARY_NAME}{PLATFORMS[platform]}"
    flags = ["-fPIC", "-fvisibility=hidden"] if platform == "linux64" else ["-s", "-static-libgcc"]
    _compile([cc, "-shared", *FP_FLAGS, *flags, *map(str, KERNEL_SOURCES), "-o", str(out), "-lm"],
             f"the plant, driver, LQR and fusion kernel ({platform})")
    return out


def _compile(cmd: list[str], what: str) -> None:
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise BuildError(f"compiling {what} failed:\n{' '.join(cmd)}\n{res.stderr}")


def _source_hash(name: str, shims: tuple[str, ...]) -> str:
    import pythonfmu

    spec = fmu_spec(name)
    h = hashlib.sha256()
    bundled = bundled_files(spec)
    files = [wrapper_script(spec), SHIM_SOURCE, *bundled,
             *((*KERNEL_SOURCES, *KERNEL_HEADERS) if KERNEL_MODULE in bundled else ())]
    for p in files:
        h.update(str(p.relative_to(PACKAGE_DIR.parent) if p.is_relative_to(PACKAGE_DIR.parent) else p.name)
                 .encode())
        h.update(p.read_bytes())
    h.update(f"pythonfmu {pythonfmu.__version__} shims {shims} py{sys.version_info[:2]} {python_config()}".encode())
    return h.hexdigest()


def _install_shim(fmu: Path, model_id: str, shim: Path, platform: str) -> None:
    """Rewrite the FMU zip with the shim as the platform's ``<id>.so`` / ``<id>.dll`` and pythonfmu's
    library beside it."""
    ext = PLATFORMS[platform]
    target = f"binaries/{platform}/{model_id}{ext}"
    tmp = fmu.with_suffix(".tmp")
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        names = src.namelist()
        if target not in names:
            raise BuildError(f"{fmu.name}: {target} missing from the pythonfmu build")
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == target:
                inner = zipfile.ZipInfo(f"binaries/{platform}/{INNER_NAME}{ext}", item.date_time)
                inner.external_attr = 0o755 << 16
                inner.compress_type = zipfile.ZIP_DEFLATED
                dst.writestr(inner, data)
                dst.write(shim, target)
            else:
                dst.writestr(item, data)
    tmp.replace(fmu)


def _add_kernels(fmu: Path, package: str, kernels: dict[str, Path]) -> None:
    """Add the plant's compiled step of each platform where :mod:`sideslip.plant.kernel` looks for it."""
    with zipfile.ZipFile(fmu, "a", zipfile.ZIP_DEFLATED) as z:
        for platform, lib in kernels.items():
            z.write(lib, f"resources/{package}/plant/native/{platform}/{lib.name}")


def _add_bytecode(fmu: Path, pkg: Path) -> None:
    """Add the bundled package's bytecode to the FMU's ``resources/``, validated by the sources' hashes (a host
    that unpacks an FMU gives its files new times): a host on this Python version loads it instead of compiling
    the modules at each instantiation (compiling them all takes about as long as running them); others ignore
    it."""
    compileall.compile_dir(pkg, quiet=1, invalidation_mode=py_compile.PycInvalidationMode.CHECKED_HASH)
    with zipfile.ZipFile(fmu, "a", zipfile.ZIP_DEFLATED) as z:
        for pyc in sorted(pkg.rglob("__pycache__/*.pyc")):
            z.write(pyc, f"resources/{pyc.relative_to(pkg.parent).as_posix()}")


def _guid(fmu: Path) -> str:
    """The GUID in an FMU's modelDescription.xml."""
    import xml.etree.ElementTree as ET

    with zipfile.ZipFile(fmu) as z:
        return ET.fromstring(z.read("modelDescription.xml")).get("guid", "")


def _forget_staging(path: list, package: str, script: str) -> None:
    """Undo what pythonfmu's builder leaves in this process: it imports the wrapper ``script`` (and with it the
    bundled ``package``) from the staging folder to write the model description, and puts that folder on
    ``sys.path``.  An FMU of this build loaded later in this process (fmpy loads FMUs in-process) would otherwise
    run those modules from a deleted folder, which had no compiled kernel yet, instead of its own."""
    sys.path[:] = path
    for module in [m for m in sys.modules if m in (package, script) or m.startswith(package + ".")]:
        del sys.modules[module]


def _build_one(name: str, out_dir: Path, shims: tuple[str, ...], tag: str, kernels: dict[str, Path]) -> Path:
    """Build into a private folder, then move into ``out_dir`` atomically (a concurrent reader
    never sees a half-written FMU)."""
    from pythonfmu.builder import FmuBuilder

    spec = fmu_spec(name)
    source = wrapper_script(spec)
    with tempfile.TemporaryDirectory(prefix="sideslip_build_") as tmp:
        # pythonfmu copies the project files into resources/: the modules the FMU runs, nothing else,
        # as a package named for this build (see module docstring)
        package = f"sideslip_{tag}"
        pkg = Path(tmp) / package
        for f in bundled_files(spec):
            dest = pkg / f.relative_to(PACKAGE_DIR)
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(f, dest)
        script = Path(tmp) / f"{spec.module}_{tag}.py"
        script.write_text(re.sub(r"^(from|import) sideslip\b", rf"\1 {package}", source.read_text(), flags=re.M))
        reqs = Path(tmp) / "requirements.txt"          # for `pythonfmu deploy`
        reqs.write_text(f"# Python packages the {name} FMU imports (pip install -r requirements.txt)\n"
                        + "\n".join(fmu_requirements(spec)) + "\n")
        staging = Path(tmp) / "out"
        staging.mkdir()
        path = list(sys.path)
        try:
            fmu = Path(FmuBuilder.build_FMU(script, dest=staging, project_files=[pkg, reqs],
                                            needsExecutionTool=False, canGetAndSetFMUstate=True,
                                            canSerializeFMUstate=True))
        finally:
            _forget_staging(path, package, script.stem)
        _add_bytecode(fmu, pkg)
        if KERNEL_MODULE in bundled_files(spec):
            _add_kernels(fmu, package, kernels)
        # compiled per FMU (it checks the FMU's own GUID), the platforms' compilers side by side: they are
        # most of a build's time
        guid = _guid(fmu)
        works = [Path(tmp) / f"shim_{platform}" for platform in shims]
        for work in works:
            work.mkdir()
        with ThreadPoolExecutor(max(len(shims), 1)) as pool:
            compiled = list(pool.map(lambda args: compile_shim(args[0], guid, args[1])[0], zip(works, shims)))
        for platform, shim in zip(shims, compiled):
            _install_shim(fmu, name, shim, platform)
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
    """Build FMUs (every one of the catalogue by default) into ``out_dir``.

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
    names = sorted(CATALOGUE) if not names else list(names)
    for name in names:
        fmu_spec(name)
    shims = tuple(p for p in PLATFORMS if _find_cc(p))
    with _BuildLock(out_dir):
        digests = {name: _source_hash(name, shims) for name in names}
        todo = []
        for name in names:
            fmu, stamp = out_dir / f"{name}.fmu", out_dir / f"{name}.fmu.sha256"
            if not force and fmu.is_file() and stamp.is_file() and stamp.read_text().strip() == digests[name]:
                log(f"{name}: up to date")
            else:
                todo.append(name)
        if todo:
            for platform in PLATFORMS:
                log(f"{platform} status shim compiled with {_find_cc(platform)} for each FMU" if platform in shims
                    else _NO_COMPILER[platform])
            from ..progress import progress_bar

            kernel_dir = Path(tempfile.mkdtemp(prefix="sideslip_kernel_"))
            kernels = {p: lib for p in shims if (lib := compile_kernel(kernel_dir, p)) is not None}
            with progress_bar(len(todo), "build", "FMUs", enabled=None if log is print else False) as bar:
                for name in todo:
                    bar.set_postfix_str(name)
                    try:
                        fmu = _build_one(name, out_dir, shims, digests[name][:12], kernels)
                    except BuildError:
                        raise
                    except Exception as exc:
                        raise BuildError(f"building {name} failed: {exc!r}") from exc
                    (out_dir / f"{name}.fmu.sha256").write_text(digests[name] + "\n")
                    if log is print and not bar.disable:
                        bar.write(f"{name}: built {fmu}")          # above the bar, not through it
                    else:
                        log(f"{name}: built {fmu}")
                    bar.update()
            shutil.rmtree(kernel_dir, ignore_errors=True)
    return [out_dir / f"{name}.fmu" for name in names]


def ensure_fmus(names, out_dir: Path | str = DEFAULT_OUT, log=lambda msg: None) -> dict[str, Path]:
    """Paths of the FMUs ``names``, building or rebuilding them when out of date."""
    paths = build_fmus(names, out_dir, log=log)
    return {p.stem: p for p in paths}
