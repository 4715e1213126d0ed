"""The copy of flexure an FMU carries: which sources, under which name (standard library only).

An FMU's resources hold the flexure packages its slave uses (`core`, the run-time part of
`fmu`, and on request `controllers`) as one package named `_flexure_<hash>`, the hash taken
over those sources, with their `flexure` imports rewritten to that name (`write_bundle`).
Its __init__ is `bundle_init.py`: in a host whose own flexure has the same sources it stands
in for that flexure, so that the two share their modules and their compiled code. This module
imports only the standard library, because that __init__ imports it to compare the hashes
before the FMU's requirements are checked.
"""

import hashlib
import importlib.util
import re
from collections.abc import Iterable
from pathlib import Path

# The modules of flexure.fmu a slave needs at run time (the builder, CLI and env stay out).
FMU_RUNTIME_MODULES = ("slave.py", "slave_states.py", "slave_values.py", "slave_variables.py",
                       "pythonfmu_workarounds.py", "scene_slave.py", "state_format.py",
                       "requirements.py", "compiled_engine.py")
# Lazy (PEP 562), as flexure.fmu's own: the launcher imports `requirements` (the standard
# library only) before anything may import numpy.
FMU_RUNTIME_INIT = '''"""flexure.fmu run-time part, bundled in an FMU."""

import importlib

__all__ = ["SafeSlave", "UnitReal", "escape_log"]


def __getattr__(name):
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(".slave", __name__), name)
'''
# The bundle package's __init__ (its PARTS line filled in by `_bundle_sources`).
BUNDLE_INIT = Path(__file__).with_name("bundle_init.py")


def _package_dir(name):
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        raise ImportError(f"cannot find the package {name!r} to bundle")
    return Path(next(iter(spec.submodule_search_locations)))


def _bundle_sources(parts):
    """{relative path: source text} of the flexure packages in `parts` (before renaming)."""
    init = BUNDLE_INIT.read_text().replace("\nPARTS = ()", f"\nPARTS = {tuple(parts)!r}", 1)
    sources = {"__init__.py": init}
    for part in parts:
        if part == "fmu":
            folder = Path(__file__).parent
            sources["fmu/__init__.py"] = FMU_RUNTIME_INIT
            for name in FMU_RUNTIME_MODULES:
                sources[f"fmu/{name}"] = (folder / name).read_text()
            continue
        folder = _package_dir(f"flexure.{part}")
        for path in sorted(folder.rglob("*.py")):
            if "__pycache__" not in path.parts:
                sources[f"{part}/{path.relative_to(folder).as_posix()}"] = path.read_text()
    return sources


def rewrite_imports(text, package):
    """Point `import flexure...` / `from flexure... import` at the bundled package."""
    return re.sub(r"^(\s*)(from|import)(\s+)flexure\b", rf"\1\2\3{package}", text,
                  flags=re.MULTILINE)


def bundle_name(parts: Iterable[str] = ("core", "fmu")) -> str:
    """The package name a bundle of flexure's packages gets.

    Parameters
    ----------
    parts : iterable of str
        Any of "core", "fmu", "controllers".

    Returns
    -------
    str
        "_flexure_<12 hex digits>", of the SHA-256 of the bundled sources.
    """
    digest = hashlib.sha256()
    for path, text in sorted(_bundle_sources(parts).items()):
        digest.update(path.encode() + b"\0" + text.encode() + b"\0")
    return f"_flexure_{digest.hexdigest()[:12]}"


def write_bundle(folder, parts=("core", "fmu")):
    """Write the bundled flexure package into `folder`; returns its directory."""
    package = bundle_name(parts)
    root = Path(folder) / package
    for path, text in _bundle_sources(parts).items():
        target = root / path
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(rewrite_imports(text, package))
    return root


