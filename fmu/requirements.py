"""The Python requirements of an FMU: what its bundled flexure imports, written into the FMU,
checked before the slave runs.

A pythonfmu FMU runs in the host's Python, so the packages the bundled flexure imports must be
installed there. Which ones is measured, not guessed: the slave of a scene FMU, instantiated
and stepped with each integrator method, imports from outside the standard library and the
FMU itself exactly numpy, numba, llvmlite (numba's code generator, whose IR builder
flexure's intrinsics use directly: `core/numerics/native.py`), threadpoolctl (flexure's BLAS
thread limits, on the first model built) and scikit-sundae (as `sksundae`, for the CVODE and
IDA methods), and scipy where the model is large (the sparse factorisation's ordering
analysis, `core/numerics/sparse_lu.py`, above a few hundred coordinates); pythonfmu's Python
part travels inside the FMU (pythonfmu copies it into resources/), and python-control,
matplotlib, fmpy are never imported by a slave.
`tests/test_fmu_requirements.py` repeats that measurement on a built FMU and compares it with
`RUNTIME_IMPORTS`.

The builder writes `resources/requirements.txt`, a pip requirements file pinned to the versions
the FMU was built with, each line also naming the module it is imported as and the lowest
version flexure declares (`format_requirements`):

    # python >= 3.11
    numpy==2.4.6  # import numpy; needs >=1.26

Before the slave script imports anything, the script the builder writes (with that file's text
in it) calls `unmet_requirements` (this module imports only the standard library): each
requirement is found as the import system would find it (not run: that is the slave's
business, when it needs it), and its installed version compared with the lowest flexure
declares (a newer or older version within that range is accepted; the pinned one is what the
FMU was tested with). If one is missing or too old, the slave class is `stand_in(message)`,
whose instantiation logs that one line through the host's logger
(`pythonfmu_workarounds.log_to_host`) and fails. `flexure fmu doctor` (`flexure.fmu.doctor`)
runs the same check as a table, importing each requirement.
"""

import importlib
import importlib.metadata
import importlib.util
import os
import re
import sys
from dataclasses import dataclass

# {bundled flexure package: ((distribution, module it is imported as), ...)}; see the docstring
RUNTIME_IMPORTS = {
    "core": (("numpy", "numpy"), ("scipy", "scipy"), ("numba", "numba"),
             ("llvmlite", "llvmlite"), ("threadpoolctl", "threadpoolctl"),
             ("scikit-sundae", "sksundae")),
    "fmu": (("numpy", "numpy"),),
    "controllers": (("numpy", "numpy"),),
}
FILE_NAME = "requirements.txt"  # in the FMU's resources/

_LINE = re.compile(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==(\S+)\s+#\s*import\s+([\w.]+)"
                   r"(?:;\s*needs\s*>=\s*(\S+))?\s*$")
_PYTHON = re.compile(r"^#\s*python\s*>=\s*(\d+(?:\.\d+)*)\s*$")
_SATISFIED = set()  # requirements found satisfied in this process (imports stay done)


class RequirementError(ImportError):
    """A Python requirement of an FMU is missing or too old in the host's Python."""


@dataclass(frozen=True)
class Requirement:
    """One distribution an FMU imports: the version it was built with, the module it is
    imported as, the lowest version flexure declares (None: any)."""

    distribution: str
    version: str
    module: str
    minimum: str | None = None

    def pin(self) -> str:
        """"numpy==2.3.4": what `pip install` is given."""
        return f"{self.distribution}=={self.version}"


@dataclass(frozen=True)
class Requirements:
    """The requirements file of an FMU: the lowest Python version and the distributions."""

    python: str | None
    items: tuple[Requirement, ...]


def release(version) -> tuple[int, ...]:
    """The release numbers a version starts with: "1.26.0rc1" -> (1, 26, 0); () if none."""
    match = re.match(r"\d+(?:\.\d+)*", str(version or ""))
    return tuple(int(part) for part in match.group(0).split(".")) if match else ()


def at_least(version, minimum) -> bool:
    """True if `version`'s release numbers are >= `minimum`'s (missing parts count as 0)."""
    have, need = release(version), release(minimum)
    width = max(len(have), len(need))
    return have + (0,) * (width - len(have)) >= need + (0,) * (width - len(need))


def format_requirements(requirements: Requirements, header: str) -> str:
    """The text of requirements.txt: `header` (comment lines), the Python line, one pin a
    line with its module and minimum after the '#' (pip reads the pins only)."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    if requirements.python:
        lines.append(f"# python >= {requirements.python}")
    for item in requirements.items:
        needs = f"; needs >={item.minimum}" if item.minimum else ""
        lines.append(f"{item.pin()}  # import {item.module}{needs}")
    return "\n".join(lines) + "\n"


def parse_requirements(text: str, source: str = FILE_NAME) -> Requirements:
    """The requirements of a requirements.txt written by `format_requirements`; ValueError
    naming the line that is not of that form."""
    python, items = None, []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        match = _PYTHON.match(line)
        if match:
            python = match.group(1)
        elif line and not line.startswith("#"):
            match = _LINE.match(line)
            if match is None:
                raise ValueError(f"{source}, line {number}: expected 'NAME==VERSION  # import "
                                 f"MODULE; needs >=MINIMUM', got {line!r}")
            items.append(Requirement(*match.groups()))
    return Requirements(python, tuple(items))


def installed_version(requirement: Requirement, module=None) -> str | None:
    """The installed version of the distribution (its metadata, else the module's
    __version__), or None if neither says."""
    try:
        return importlib.metadata.version(requirement.distribution)
    except importlib.metadata.PackageNotFoundError:
        version = getattr(module, "__version__", None)
        return version if isinstance(version, str) else None


def python_status(requirements: Requirements) -> tuple[str, str]:
    """("OK" or "OLD", "Python 3.11.7"): this Python against the FMU's lowest version."""
    found = f"Python {'.'.join(map(str, sys.version_info[:3]))}"
    if requirements.python and not at_least(found.split()[1], requirements.python):
        return "OLD", found
    return "OK", found


def status(item: Requirement, *, load: bool = True) -> tuple[str, str]:
    """("OK", "MISSING" or "OLD", what was found) of one requirement in this Python: it is
    imported (with `load` False only found, as the import system would find it, without
    running it: scikit-sundae takes 0.6 s to import, which an FMU stepped by an ESDIRK method
    never needs), and its installed version compared with its minimum."""
    module = None
    try:
        if load:
            module = importlib.import_module(item.module)
        elif importlib.util.find_spec(item.module) is None:
            raise ModuleNotFoundError(f"No module named {item.module!r}")
    except Exception as error:  # noqa: BLE001 -- any failure to import is a missing one
        reason = " ".join(f"{type(error).__name__}: {error}".split())  # one line
        return "MISSING", f"import {item.module}: {reason}"
    version = installed_version(item, module)
    if item.minimum and version and not at_least(version, item.minimum):
        return "OLD", f"{item.distribution} {version}"
    return "OK", f"{item.distribution} {version or '(version unknown)'}"


def problems(requirements: Requirements, *, load: bool = True
             ) -> list[tuple[Requirement | None, str, str]]:
    """What this Python lacks: (requirement or None for Python itself, "MISSING" or "OLD",
    what was found), for each requirement it cannot import (with `load` False: find) or has
    below its minimum."""
    found = []
    kind, python = python_status(requirements)
    if kind != "OK":
        found.append((None, kind, python))
    for item in requirements.items:
        kind, what = status(item, load=load)
        if kind != "OK":
            found.append((item, kind, what))
    return found


def problem_line(fmu_name: str, requirements: Requirements, found, path: str) -> str:
    """One line naming what is missing or too old and the pip command that installs it."""
    parts, pins = [], []
    for item, kind, detail in found:
        if item is None:
            parts.append(f"{detail} is older than the {requirements.python} it needs")
            continue
        if kind == "MISSING":
            parts.append(f"{item.distribution} is missing ({detail})")
        else:
            parts.append(f"{detail} is older than the {item.minimum} it needs")
        pins.append(f"'{item.pin()}'")
    fix = (f"; install into this Python ({sys.prefix}): python -m pip install {' '.join(pins)}"
           f" (or every requirement: python -m pip install -r {path})" if pins else "")
    return f"{fmu_name} cannot run in this Python: {'; '.join(parts)}{fix}"


def unmet_requirements(text: str, script_file: str) -> str | None:
    """None if this Python has what an FMU needs, given the text of its requirements.txt
    (embedded in its slave script, whose path is `script_file`); otherwise the one line saying
    what it lacks. Nothing is read from files: pythonfmu's binary runs the script again at
    every instantiation, in the namespace of its first import, whose folder may be gone."""
    if text in _SATISFIED:
        return None
    path = os.path.join(os.path.dirname(os.path.abspath(script_file)), FILE_NAME)
    try:
        requirements = parse_requirements(text, path)
    except ValueError as error:
        return f"the FMU's requirements cannot be read: {error}"
    found = problems(requirements, load=False)  # the slave imports what it needs, when
    if not found:
        _SATISFIED.add(text)
        return None
    return problem_line(model_identifier(os.path.dirname(path)), requirements, found, path)


def model_identifier(resources: str) -> str:
    """The model identifier of the unpacked FMU whose resources folder is `resources` (the
    name of its binary), or "this FMU"."""
    binaries = os.path.join(os.path.dirname(os.path.normpath(resources)), "binaries")
    try:
        for platform in sorted(os.listdir(binaries)):
            for name in sorted(os.listdir(os.path.join(binaries, platform))):
                return name.rsplit(".", 1)[0]
    except OSError:
        pass
    return "this FMU"


def stand_in(message: str):
    """The slave class of an FMU whose requirements are unmet: instantiating it logs `message`
    through the host's logger at status fmi2Error and fails (fmi2Instantiate returns NULL)."""
    from pythonfmu import Fmi2Slave  # pythonfmu's Python part, shipped in the FMU

    from .pythonfmu_workarounds import guard_exit, log_to_host

    class MissingRequirements(Fmi2Slave):
        """Stands in for the slave class when the FMU's requirements are unmet."""

        def __init__(self, **kwargs):
            # the binary made its interpreter guard before calling this, and releases it twice
            # at exit unless guarded (`guard_exit`), an instance made or not; this instance's
            # own folder, as the script module may be the first instance's
            resources = kwargs.get("resources") or ""
            try:
                guard_exit(resources, model_identifier(resources))
            except Exception:  # noqa: BLE001 -- naming what is missing matters more
                pass
            if not log_to_host(kwargs, message):
                print(message, file=sys.stderr)  # no way into the host's logger: at least here
            raise RequirementError(message)

        def do_step(self, current_time, step_size):  # never called: no instance exists
            return False

    return MissingRequirements


def failed_script(error: Exception, script_file: str, namespace: dict):
    """The slave class of an FMU whose slave script raised `error` as it ran: a stand-in (see
    `stand_in`) whose instantiation logs what failed and where, instead of pythonfmu's fatal
    error, after which its binary would be left unguarded at exit. The slave classes the
    script made before it failed are taken out of `namespace` (the launcher's locals), where
    pythonfmu's binary would pick one of them over the stand-in."""
    import traceback

    source = os.path.basename(script_file)[: -len(".py")] + ".slave.py"
    lines = [frame.lineno for frame in traceback.extract_tb(error.__traceback__)
             if frame.filename.endswith(source)]
    line = getattr(error, "lineno", None) if isinstance(error, SyntaxError) else (
        lines[-1] if lines else None)
    where = f"{source}, line {line}" if line else source
    message = (f"{model_identifier(os.path.dirname(os.path.abspath(script_file)))}: its slave "
               f"script failed as it ran ({where}): {type(error).__name__}: {error}")
    for key, value in list(namespace.items()):
        if isinstance(value, type) and any(c.__name__ == "Fmi2Slave" for c in value.__mro__[1:]):
            del namespace[key]
    return stand_in(message)


def runtime_requirements(bundle, extra=()) -> Requirements:
    """The requirements of an FMU that bundles the flexure packages `bundle` (() for none:
    the host's flexure) and whose script imports the distributions `extra` ("NAME" or
    "NAME:MODULE"), pinned to the versions installed here; ValueError for one that is not.

    The lowest versions are those flexure's own metadata declares (pyproject.toml); a
    distribution it does not declare gets none.
    """
    pairs = [pair for part in bundle for pair in RUNTIME_IMPORTS[part]]
    if not bundle:
        pairs.append(("flexure", "flexure"))
    for text in extra:
        distribution, _, module = str(text).partition(":")
        pairs.append((distribution.strip(), module.strip() or _module_of(distribution)))
    declared = _declared_minimums()
    items, seen = [], set()
    for distribution, module in pairs:
        if _normalized(distribution) in seen:
            continue
        seen.add(_normalized(distribution))
        try:
            version = importlib.metadata.version(distribution)
        except importlib.metadata.PackageNotFoundError:
            raise ValueError(f"requirement {distribution!r}: no such distribution is installed "
                             "here, so its version cannot be pinned") from None
        items.append(Requirement(distribution, version, module,
                                 declared.get(_normalized(distribution))))
    try:
        python = importlib.metadata.metadata("flexure")["Requires-Python"]
        python = re.fullmatch(r"\s*>=\s*(\d+(?:\.\d+)*)\s*", python or "").group(1)
    except (importlib.metadata.PackageNotFoundError, AttributeError):
        python = "{}.{}".format(*sys.version_info[:2])
    return Requirements(python, tuple(items))


def _normalized(name):
    return re.sub(r"[-_.]+", "-", name).lower()


def _declared_minimums():
    """{normalized distribution: lowest version} of flexure's declared dependencies."""
    try:
        declared = importlib.metadata.requires("flexure") or []
    except importlib.metadata.PackageNotFoundError:
        return {}
    minimums = {}
    for text in declared:
        match = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(?:\[[^\]]*\])?\s*>=\s*"
                         r"([0-9][^,;\s]*)\s*(;.*)?$", text)
        if match and not (match.group(3) or "").strip(" ;"):  # no extras' markers
            minimums[_normalized(match.group(1))] = match.group(2)
    return minimums


def _module_of(distribution):
    """The top-level module a distribution is imported as: the one of its own name, else the
    first it provides."""
    provided = sorted(module for module, owners in
                      importlib.metadata.packages_distributions().items()
                      if _normalized(distribution) in map(_normalized, owners))
    wanted = _normalized(distribution).replace("-", "_")
    return wanted if wanted in provided or not provided else provided[0]
