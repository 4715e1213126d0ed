"""A package's public names imported on first use (PEP 562), for flexure.core,
flexure.fmu and flexure.controllers: importing the package loads none of its heavy
submodules, while `from package import X`, `package.X` and `dir(package)` work for every
name of its `__all__`.

    # submodule -> the public names it defines
    _LAZY = {"analysis.modal": ("Modes", "natural_frequencies"), ...}
    __all__, __getattr__, __dir__ = lazy_exports(__name__, _LAZY)

A package that also imports names at once lists them in `__all__` beside the lazy ones:

    _lazy, __getattr__, __dir__ = lazy_exports(__name__, _LAZY)
    __all__ = ["SceneError", *_lazy]
"""

import importlib
import sys


def lazy_exports(package: str, submodules: dict[str, tuple[str, ...]]):
    """The lazy public names, `__getattr__` and `__dir__` of a package whose public names are
    imported from their submodules on first use.

    Parameters
    ----------
    package : str
        The package's `__name__`.
    submodules : dict of str to tuple of str
        Submodule, relative to the package ("analysis.modal") -> the public names it defines.

    Returns
    -------
    (list of str, callable, callable)
        The names of `submodules`, in its order (the package's `__all__`, or part of it);
        `__getattr__(name)`, which imports the name's submodule and keeps the name in the
        package (so the import happens once), raising AttributeError for any other name; and
        `__dir__()`, which lists the lazy names beside those the package holds.

    Raises
    ------
    ValueError
        A name listed under two submodules.
    """
    module_of = {}
    for module, names in submodules.items():
        for name in names:
            if name in module_of:  # the last would win, silently
                raise ValueError(f"{package}: {name!r} is listed under both "
                                 f"{module_of[name]!r} and {module!r}")
            module_of[name] = module
    public = list(module_of)

    def __getattr__(name):
        module = module_of.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{module}", package), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(public))

    return public, __getattr__, __dir__
