"""The compiled engine an FMU carries, installed into the host's cache before the slave loads
any compiled code; what happened is logged at the first instantiation.

`flexure fmu build` puts the compiled code of the bundled flexure, built for a portable CPU
target, into the FMU's resources/flexure-engine/ (`flexure.fmu.portable_engine`). The slave
script's launcher calls `install` once its requirements are met and before the slave script
imports the bundled flexure: the code is copied into the user's cache folder when it fits this
Python (`flexure.core.numerics.portable_cache.install_compiled`: same Python, numpy, numba and
llvmlite versions, same machine), so the engine loads in about a second instead of compiling
for a minute. Where it does not fit, nothing is installed and the engine compiles as it would
without it. Nothing here raises: a failure is a note, and the engine compiles.

The notes (`take_notes`) are logged by the first instance (`SafeSlave.__init__`): pythonfmu's
binary imports the slave script before it hands the instance the host's logger.
"""

import os
import sys

FOLDER = "flexure-engine"  # in the FMU's resources/
OK, WARNING = 0, 1  # fmi2Status of a note

_NOTES = []  # (fmi2Status, message), to log at the next instantiation
_INSTALLED = []  # the engine installed in this process (this module is its package's own)


def install(script_file: str, package: str) -> None:
    """Install the compiled engine of the FMU whose launcher is `script_file`, once per
    process.

    Parameters
    ----------
    script_file : str
        The launcher's path (in the unpacked FMU's resources folder).
    package : str
        The bundled flexure's package name ("_flexure_<hash>").
    """
    source = os.path.join(os.path.dirname(os.path.abspath(script_file)), FOLDER)
    if _INSTALLED or not os.path.isdir(source):  # done, or built with --no-engine
        return
    _INSTALLED.append(source)
    if getattr(sys.modules.get(package), "STANDS_IN", False):
        _NOTES.append((OK, "this Python's flexure has the FMU's sources and runs in place of "
                           "its copy, with its own compiled-code cache; the compiled engine "
                           "the FMU carries is not used (FLEXURE_FMU_OWN_COPY=1 uses it)"))
        return
    try:
        from flexure.core.numerics.portable_cache import install_compiled

        installed, message = install_compiled(source)
    except Exception as error:  # noqa: BLE001 -- an FMU never takes its host down
        installed, message = False, f"{type(error).__name__}: {error}"
    if installed:
        _NOTES.append((OK, f"the compiled engine the FMU carries: {message}"))
    else:
        _NOTES.append((WARNING, f"the compiled engine the FMU carries is not used: {message}; "
                                "the engine compiles for this machine instead"))


def take_notes() -> list[tuple[int, str]]:
    """The notes not logged yet, (fmi2Status, message) each; the list is emptied."""
    notes = list(_NOTES)
    _NOTES.clear()
    return notes
