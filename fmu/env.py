"""The environment a host outside Python needs to run a pythonfmu FMU.

A pythonfmu FMU's binary calls into libpython but does not link it, and it runs the Python
code in whatever interpreter it finds. So a JVM, Rust or C host must:

- preload libpython, so its symbols are in the global scope (`LD_PRELOAD`);
- point the embedded interpreter at its standard library (`PYTHONHOME`, the base prefix)
  and at the packages the FMU imports, which it lists in resources/requirements.txt
  (`PYTHONPATH`, the site-packages of this Python; `flexure fmu doctor FMU --native` checks
  that they are there).

flexure itself travels inside the FMU (see `flexure.fmu.builder`). A Python host (fmpy,
libcosimpy) needs none of this: the FMU then uses the host's own interpreter.
"""

import json
import site
import sys
import sysconfig
from pathlib import Path

from flexure.core import FlexureError


def libpython_path():
    """The shared libpython of this interpreter (FlexureError if it was built static)."""
    libdir = Path(sysconfig.get_config_var("LIBDIR") or "")
    for name in (sysconfig.get_config_var("INSTSONAME"), sysconfig.get_config_var("LDLIBRARY")):
        if name and (libdir / name).is_file() and ".so" in name:
            return libdir / name
    raise FlexureError(
        f"{sys.executable}: this Python has no shared libpython in {libdir}; a host outside "
        "Python needs one (build Python with --enable-shared, e.g. PYTHON_CONFIGURE_OPTS="
        "--enable-shared pyenv install 3.11)")


def fmu_environment() -> dict[str, str]:
    """What a non-Python host needs to run flexure's FMUs on this machine.

    Returns
    -------
    dict of str to str
        {environment variable: value}: LD_PRELOAD (libpython), PYTHONHOME, PYTHONPATH, and
        in a venv PYTHONUSERBASE (the venv, so that its .pth files run).

    Raises
    ------
    FlexureError
        This Python's shared libpython cannot be found.
    """
    paths = [p for p in site.getsitepackages() if Path(p).is_dir()]
    environment = {
        "LD_PRELOAD": str(libpython_path()),
        "PYTHONHOME": sys.base_prefix,
        "PYTHONPATH": ":".join(paths),
    }
    if sys.prefix != sys.base_prefix:
        # In a venv, the venv is the embedded interpreter's user site too: a PYTHONPATH entry
        # is not a site folder, so its .pth files (an editable install's, `pip install -e`)
        # would not run, and the FMU would not find that flexure and compile its own copy.
        environment["PYTHONUSERBASE"] = sys.prefix
    return environment


def format_environment(environment, *, style="sh"):
    """The environment as `export` lines and a comment on what they are for ("sh"), JSON
    ("json") or `env` arguments ("env")."""
    if style == "json":
        return json.dumps(environment, indent=2)
    if style == "env":
        return " ".join(f"{k}={v}" for k, v in environment.items())
    return "\n".join([f"export {k}='{v}'" for k, v in environment.items()] + [
        "# What a JVM, Rust or C host of flexure's FMUs needs: libpython preloaded, and this",
        "# Python's standard library and site-packages, where each FMU's packages (its",
        "# resources/requirements.txt) must be installed: flexure fmu doctor FMU --native"])
