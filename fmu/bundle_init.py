"""A copy of flexure bundled in an FMU: this file is the bundle package's __init__.py.

The builder (`flexure.fmu.bundle`) copies the flexure packages an FMU uses into its resources
under the name `_flexure_<hash>`, the hash taken over their sources, so that the FMU runs the
code it was built and tested with whatever flexure the host has, or none.

When the host's Python has a flexure whose sources hash to this very name, that flexure *is*
this copy, and this package stands in for it: `_flexure_<hash>.core.model` is the module
`flexure.core.model`. What runs is the same code either way; sharing it saves a host that uses
flexure itself (a test suite, a closed-loop script, a sweep) a second set of module objects
and a second compilation of the engine, which costs about 50 s on an empty cache because
numba caches compiled code per package name (`core/numerics/jit.py`). Set the environment
variable FLEXURE_FMU_OWN_COPY=1 to run this copy regardless.

Standard library only: it runs before the FMU's requirements are checked.
"""

import importlib
import importlib.abc
import importlib.util
import os
import sys

PARTS = ()  # the flexure packages bundled here; the builder writes them in


def _identical_flexure_installed(package):
    """True when `flexure` is importable and its `PARTS` hash to the name `package`."""
    if os.environ.get("FLEXURE_FMU_OWN_COPY", "") not in ("", "0"):
        return False
    try:  # by name: the builder rewrites this file's `from flexure` imports to the bundle
        bundle_name = importlib.import_module("flexure.fmu.bundle").bundle_name
    except (ImportError, AttributeError):  # no flexure, or one without this: run this copy
        return False
    try:
        return bundle_name(PARTS) == package
    except OSError:  # its sources cannot be read
        return False


class _InstalledFlexure(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds `<package>.<rest>` as the module `flexure.<rest>` (imported if it is not yet)."""

    def __init__(self, package):
        self.package = package
        self.specs = {}

    def find_spec(self, name, path=None, target=None):
        if name.startswith(self.package + "."):
            return importlib.util.spec_from_loader(name, self)
        return None

    def create_module(self, spec):
        module = importlib.import_module("flexure" + spec.name[len(self.package):])
        self.specs[spec.name] = module.__spec__
        return module

    def exec_module(self, module):
        # the import system gave the installed module this alias's spec; it keeps its own
        module.__spec__ = self.specs.pop(module.__spec__.name)


STANDS_IN = _identical_flexure_installed(__name__)
# one finder per bundle name and process (this package may be imported again after a builder
# forgot it)
if STANDS_IN and not any(type(finder).__name__ == "_InstalledFlexure"
                         and getattr(finder, "package", None) == __name__
                         for finder in sys.meta_path):
    sys.meta_path.insert(0, _InstalledFlexure(__name__))
