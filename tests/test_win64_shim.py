"""The win64 binary: the shim cross-compiled with mingw-w64 (where the build machine has it).

Checked here: every FMU carries it with pythonfmu's DLL beside it; it exports every FMI 2.0 function
pythonfmu's DLL exports and imports nothing but Windows system DLLs (Python is found at run time, not
linked); it carries its FMU's GUID; and, where Wine is installed, a Windows host without Python gets a
clear log message and a NULL instance from ``fmi2Instantiate`` (pythonfmu's stock DLL cannot even be
loaded there).
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

import pythonfmu
from sideslip.fmi.build import _find_cc
from sideslip.fmi.catalogue import fmu_names

FMUS = fmu_names()
STOCK_DLL = Path(pythonfmu.__file__).parent / "resources" / "binaries" / "win64" / "pythonfmu-export.dll"
NATIVE = Path(__file__).parent / "native"
SYSTEM_DLLS = {"kernel32.dll", "advapi32.dll", "msvcrt.dll"}

pytestmark = pytest.mark.skipif(_find_cc("win64") is None,
                                reason="no mingw-w64 cross compiler (x86_64-w64-mingw32-gcc): FMUs keep the stock "
                                       "win64 binary")


def _objdump() -> str:
    tool = shutil.which("x86_64-w64-mingw32-objdump")
    if tool is None:
        pytest.skip("x86_64-w64-mingw32-objdump not found")
    return tool


def _pe(path: Path) -> tuple[set[str], set[str]]:
    """(exported names, imported DLL names in lower case) of a PE file."""
    text = subprocess.run([_objdump(), "-p", str(path)], capture_output=True, text=True, check=True).stdout
    imports = {m.lower() for m in re.findall(r"DLL Name: (\S+)", text)}
    table = text.split("[Ordinal/Name Pointer] Table", 1)[1] if "[Ordinal/Name Pointer] Table" in text else ""
    exports = set(re.findall(r"^\s*\[\s*\d+\]\s+(\S+)", table, flags=re.M))
    return exports, imports


def _binaries(fmu_dir: Path, name: str, tmp: Path) -> tuple[Path, Path]:
    with zipfile.ZipFile(fmu_dir / f"{name}.fmu") as z:
        z.extractall(tmp / name)
    return tmp / name / "binaries" / "win64" / f"{name}.dll", tmp / name / "binaries" / "win64" / "pythonfmu_export.dll"


@pytest.mark.parametrize("name", FMUS)
def test_each_fmu_carries_the_win64_shim_beside_pythonfmus_dll(fmu_dir, tmp_path, name):
    shim, inner = _binaries(fmu_dir, name, tmp_path)
    assert inner.read_bytes() == STOCK_DLL.read_bytes()
    assert shim.read_bytes() != STOCK_DLL.read_bytes()
    exports, imports = _pe(shim)
    stock_exports, stock_imports = _pe(STOCK_DLL)
    fmi = {e for e in stock_exports if e.startswith("fmi2")}
    assert len(fmi) >= 30 and {e for e in exports if e.startswith("fmi2")} == fmi
    assert imports <= SYSTEM_DLLS, imports            # no python3.dll, no compiler runtime DLL
    assert "python3.dll" in stock_imports              # what the stock binary needs at load time
    guid = read_model_description(str(fmu_dir / f"{name}.fmu")).guid
    assert guid.encode() in shim.read_bytes()          # instantiation checks the FMU's own GUID


@pytest.fixture(scope="module")
def wine(tmp_path_factory):
    """Wine with a fresh prefix, and the probe host (``tests/native/win_probe.c``) built for Windows."""
    program = shutil.which("wine") or shutil.which("wine64")
    if program is None:
        pytest.skip("Wine is not installed")
    import fmpy

    work = tmp_path_factory.mktemp("wine")
    probe = work / "win_probe.exe"
    subprocess.run([_find_cc("win64"), "-O2", f"-I{Path(fmpy.__file__).parent / 'c-code'}",
                    str(NATIVE / "win_probe.c"), "-o", str(probe)], check=True, capture_output=True)
    env = dict(os.environ, WINEPREFIX=str(work / "prefix"), WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
    for key in ("PYTHONHOME", "SIDESLIP_FMU_LIBPYTHON"):
        env.pop(key, None)
    return program, probe, env


def _probe(wine, dll: Path, guid: str, **extra) -> subprocess.CompletedProcess:
    program, probe, env = wine
    return subprocess.run([program, str(probe), "Z:" + str(dll).replace("/", "\\"), guid,
                           dll.parents[2].joinpath("resources").as_uri()],
                          capture_output=True, text=True, timeout=600, env=dict(env, **extra))


def test_without_python_a_windows_host_gets_a_message_not_a_crash(wine, fmu_dir, tmp_path):
    name = "Park2018Observer"
    shim, inner = _binaries(fmu_dir, name, tmp_path)
    guid = read_model_description(str(fmu_dir / f"{name}.fmu")).guid
    proc = _probe(wine, shim, guid)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "VERSION 2.0" in proc.stdout and "INSTANCE NULL" in proc.stdout
    (log,) = [line for line in proc.stdout.splitlines() if line.startswith("LOG ")]
    assert log.startswith("LOG 3 logStatusError: no Python 3.") and "python3" in log and "SIDESLIP_FMU_LIBPYTHON" in log

    proc = _probe(wine, shim, guid, SIDESLIP_FMU_LIBPYTHON="C:\\nowhere\\python311.dll")
    assert "SIDESLIP_FMU_LIBPYTHON (C:\\nowhere\\python311.dll) cannot be loaded" in proc.stdout, proc.stdout
    assert "INSTANCE NULL" in proc.stdout

    # pythonfmu's own DLL links python3.dll: without Python the host cannot even load it
    proc = _probe(wine, inner, guid)
    assert proc.returncode == 3 and "cannot load" in proc.stderr
