"""A package's public names imported on first use (PEP 562), for flexure.core,
flexure.fmu and flexure.controllers: importing the package loads none of its heavy
submodules, while `from package import X`, `package.X` and `dir(package)` work for every
name of its `__all__`.

    __getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
"""

import importlib
import sys


def lazy_exports(package: str, submodules: dict[str, str], public: list[str]):
    """The module-level `__getattr__` and `__dir__` of a package whose public names are
    imported from their submodules on first use.

    Parameters
    ----------
    package : str
        The package's `__name__`.
    submodules : dict of str to str
        Public name -> the submodule that defines it, relative to the package
        ("analysis.modal").
    public : list of str
        The package's `__all__`, which `dir(package)` lists.

    Returns
    -------
    (callable, callable)
        `__getattr__(name)`, which imports the name's submodule and keeps the name in the
        package (so the import happens once), raising AttributeError for any other name; and
        `__dir__()`.
    """

    def __getattr__(name):
        module = submodules.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{module}", package), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(public))

    return __getattr__, __dir__
