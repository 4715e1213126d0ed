"""`flexure fmu doctor FMU`: can this Python host the FMU? One check a row, a fix per problem.

    flexure fmu doctor stage.fmu            # exit 0: every check passed; 1: one failed
    flexure fmu doctor stage.fmu --native   # also what a JVM, Rust or C host needs

The checks, in the order a host meets them:

- platform: this machine's FMI platform (fmpy's, e.g. linux64) has a binary in the FMU;
- the FMU's requirements file (resources/requirements.txt, written by the builder since
  flexure 0.1.0; an FMU without one cannot be checked further);
- Python: this interpreter is at least the version the FMU needs;
- one row per requirement: importable here, at a version at or above the minimum
  (`flexure.fmu.requirements.status`, the check the FMU itself runs when it is instantiated);
- the pythonfmu binary: loadable (dlopen) by this Python, tried in a child process so that a
  binary that crashes takes only that down;
- for a non-Python host (the environment `flexure fmu env` prints): a shared libpython to
  preload, and every requirement found on its PYTHONPATH or under PYTHONHOME. Without
  `--native` these rows are warnings (WARN) and do not fail the check: a Python host (fmpy,
  libcosimpy) needs neither.

Statuses: OK; WARN (reported, not failing); MISSING, OLD, FAILED (failing: exit code 1).
"""

import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path

from flexure.core import FlexureError

from .env import fmu_environment
from .requirements import FILE_NAME, parse_requirements, python_status, status

FAILING = ("MISSING", "OLD", "FAILED")
LOAD_TIMEOUT = 60.0  # s, for the child process that loads the binary


@dataclass(frozen=True)
class Check:
    """One row of the doctor's table."""

    check: str
    status: str
    found: str
    fix: str = ""


def diagnose(path: str | Path, *, native: bool = False) -> list[Check]:
    """The checks of the FMU at `path` in this Python (see the module docstring).

    FlexureError if `path` is not an FMU (no file, not a zip, no modelDescription.xml).
    """
    from fmpy import platform as this_platform

    path = Path(path)
    if not path.is_file():
        raise FlexureError(f"{path}: {'not a file' if path.exists() else 'no such file'}")
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
            if "modelDescription.xml" not in names:
                raise FlexureError(f"{path}: not an FMU: it has no modelDescription.xml")
            text = (archive.read(f"resources/{FILE_NAME}").decode()
                    if f"resources/{FILE_NAME}" in names else None)
            binaries = {name.split("/")[1]: name for name in names
                        if name.startswith("binaries/") and name.count("/") == 2
                        and not name.endswith("/")}
            binary = archive.read(binaries[this_platform]) if this_platform in binaries \
                else None
    except (zipfile.BadZipFile, OSError) as error:
        raise FlexureError(f"{path}: not an FMU: {error}") from None
    rows = [_platform_row(this_platform, sorted(binaries))]
    if text is None:
        rows.append(Check(f"resources/{FILE_NAME}", "MISSING", "the FMU lists no requirements",
                          "rebuild the FMU with this flexure (flexure fmu build), which "
                          "writes them"))
        requirements = None
    else:
        try:
            requirements = parse_requirements(text, f"{path}: resources/{FILE_NAME}")
        except ValueError as error:
            raise FlexureError(str(error)) from None
        rows += _requirement_rows(requirements)
    if binary is not None:
        rows.append(_binary_row(binaries[this_platform], binary))
    if requirements is not None:
        rows += _native_rows(requirements, native)
    return rows


def _platform_row(platform, platforms):
    found = f"this machine is {platform}; the FMU has {', '.join(platforms) or 'no binary'}"
    if platform in platforms:
        return Check("platform", "OK", found)
    return Check("platform", "MISSING", found,
                 f"run the FMU on {' or '.join(platforms) or 'a platform it has'}, or build "
                 "it on this machine (flexure fmu build)")


def _requirement_rows(requirements):
    kind, found = python_status(requirements)
    rows = [Check(f"Python >= {requirements.python}", kind, found,
                  "" if kind == "OK" else f"run the host with Python >= "
                                          f"{requirements.python}")]
    for item in requirements.items:
        kind, found = status(item)
        if kind == "OK" and not found.endswith(f" {item.version}"):
            found += f" (the FMU was built with {item.version})"
        wanted = f"{item.pin()}" + (f", needs >= {item.minimum}" if item.minimum else "")
        rows.append(Check(wanted, kind, found, "" if kind == "OK" else
                          f"python -m pip install '{item.pin()}'"))
    return rows


def _binary_row(name, data):
    """Load the pythonfmu binary into a child Python process (dlopen, nothing called)."""
    with tempfile.TemporaryDirectory(prefix="flexure_doctor_") as folder:
        binary = Path(folder) / Path(name).name
        binary.write_bytes(data)
        try:
            child = subprocess.run(
                [sys.executable, "-c", "import ctypes, sys; ctypes.CDLL(sys.argv[1])",
                 str(binary)], capture_output=True, text=True, timeout=LOAD_TIMEOUT)
        except subprocess.TimeoutExpired:
            return Check(f"binary {name}", "FAILED", f"loading it took over {LOAD_TIMEOUT:g} s",
                         "check the binary with ldd")
    if child.returncode == 0:
        return Check(f"binary {name}", "OK", "loads in this Python")
    lines = (child.stderr or "").strip().splitlines()
    reason = lines[-1] if lines else f"exit code {child.returncode}"
    return Check(f"binary {name}", "FAILED", reason,
                 "the binary needs libpython's symbols and the C++ runtime: run it from this "
                 "Python, or preload libpython (flexure fmu env)")


def _native_rows(requirements, native):
    """What a non-Python host needs: libpython to preload, and the packages on its path."""
    failing = "MISSING" if native else "WARN"
    try:
        environment = fmu_environment()
    except FlexureError as error:
        return [Check("non-Python host: libpython", failing, str(error).split(": ", 1)[-1],
                      "needed by a JVM, Rust or C host only: use a Python built with "
                      "--enable-shared")]
    rows = [Check("non-Python host: libpython", "OK", environment["LD_PRELOAD"])]
    folders = [Path(p) for p in environment["PYTHONPATH"].split(os.pathsep) if p]
    folders.append(Path(environment["PYTHONHOME"]))
    outside = []
    for item in requirements.items:
        module = sys.modules.get(item.module)
        location = getattr(module, "__file__", None) if module is not None else None
        if location and not any(Path(location).resolve().is_relative_to(folder.resolve())
                                for folder in folders):
            outside.append(f"{item.module} ({Path(location).parent})")
    if outside:
        rows.append(Check("non-Python host: PYTHONPATH", failing,
                          "not on the path `flexure fmu env` prints: " + ", ".join(outside),
                          "install them into " + (str(folders[0]) if folders[:-1] else
                                                  "this Python's site-packages")))
    else:
        rows.append(Check("non-Python host: PYTHONPATH", "OK", environment["PYTHONPATH"]))
    return rows


def failed(rows) -> bool:
    """True if a row failed (MISSING, OLD or FAILED)."""
    return any(row.status in FAILING for row in rows)


def as_dicts(rows) -> list[dict]:
    """The rows as dictionaries (for --json)."""
    return [asdict(row) for row in rows]
