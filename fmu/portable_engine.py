"""Put the compiled engine into a scene's FMU, compiled for a portable CPU target.

`add_compiled_engine(fmu)` runs a child Python that hosts the FMU as any host would (fmpy),
with

- numba compiling for a portable CPU target (NUMBA_CPU_NAME=generic, no CPU features: the
  code runs on every x86-64 CPU; numba files it under that name, so it is kept apart from
  this machine's own);
- the FMU's own copy of flexure (FLEXURE_FMU_OWN_COPY=1), whose package name the code is
  compiled for;
- a cache folder of its own (`staging_folder`, kept: the next FMU built from the same flexure
  sources loads what this one compiled instead of compiling again).

The child instantiates the FMU once per integrator method it takes and takes a few steps, its
inputs at their start values, so that every kernel the scene's slave needs is compiled (the
first time: about a minute of CPU) or loaded. A child that loaded everything exports the cache
files of what it loaded, with a manifest of what that code needs
(`flexure.core.numerics.portable_cache.export_compiled`); one that compiled leaves that to a
second child, which loads what the first compiled: the functions a host loads, not the callees
numba compiled on the way, whose code their callers hold (stage_planar_3dof: 9 functions,
1.4 MB, instead of 121 and 10 MB). They are added to the FMU as resources/flexure-engine/, which
the FMU installs into its host's cache at instantiation (`flexure.fmu.compiled_engine`).
"""

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import zipfile
from collections import deque
from pathlib import Path

from flexure.core import FlexureError

from .compiled_engine import FOLDER

# the environment of the child: numba's portable target (numba sets no CPU features for it)
PORTABLE_TARGET = {"NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""}
STEPS, STEP = 3, 1e-3  # doSteps per method, communication step (s)
# s of wall time a child may take: a first compilation takes about a minute of CPU, several
# on a loaded machine; a child still running after this is hung, and is killed
CHILD_TIMEOUT = 1800.0


def staging_folder() -> Path | None:
    """The cache folder the portable compilations are kept in: `portable-cpu` in flexure's
    cache folder (None when there is none: a temporary one is used then)."""
    from flexure.core.numerics.jit import cache_root

    root = cache_root()
    return None if root is None else Path(root) / "portable-cpu"


def add_compiled_engine(fmu: str | Path) -> dict:
    """Compile the engine of the FMU's bundled flexure for a portable CPU target and add it
    to the FMU (resources/flexure-engine/).

    The child's log lines (the compilation notice among them) are passed on to stderr as
    they come.

    Parameters
    ----------
    fmu : str or Path
        A scene FMU built by `flexure.fmu.build_scene_fmu` (rewritten in place).

    Returns
    -------
    dict
        The manifest of the code added (`portable_cache.export_compiled`), with "fmu_bytes":
        what the FMU grew by.

    Raises
    ------
    FMUBuildError
        The child failed, or took over CHILD_TIMEOUT s and was killed (its last lines of
        stderr are in the message).
    """
    from .builder import FMUBuildError

    fmu = Path(fmu)
    staging = staging_folder()
    with tempfile.TemporaryDirectory(prefix="flexure_engine_") as temp:
        cache = staging if staging is not None else Path(temp) / "cache"
        out = Path(temp) / "engine"
        env = {**os.environ, **PORTABLE_TARGET, "FLEXURE_CACHE_DIR": str(cache),
               "FLEXURE_FMU_OWN_COPY": "1"}
        command = [sys.executable, "-m", "flexure.fmu.portable_engine", str(fmu), str(out)]
        manifest_path = out / "manifest.json"
        # a child that compiled exports nothing (what numba compiled as callees would be
        # exported with their callers, which hold their code already): a second one loads
        # it all and exports what a host loads, the same whatever the cache held before
        for _ in range(2):
            code, tail = _run_child(command, env, CHILD_TIMEOUT)
            if code != 0 or manifest_path.is_file():
                break
        if code is None:
            raise FMUBuildError(f"{fmu}: compiling its engine for a portable CPU target took "
                                f"over {CHILD_TIMEOUT:g} s; the child was killed:\n"
                                f"{''.join(tail)}")
        if code != 0 or not manifest_path.is_file():
            raise FMUBuildError(f"{fmu}: compiling its engine for a portable CPU target "
                                f"failed (exit code {code}):\n{''.join(tail)}")
        manifest = json.loads(manifest_path.read_text())
        before = fmu.stat().st_size
        with zipfile.ZipFile(fmu, "a", compression=zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(out.rglob("*")):
                if path.is_file():
                    archive.write(path, f"resources/{FOLDER}/{path.relative_to(out).as_posix()}")
        manifest["fmu_bytes"] = fmu.stat().st_size - before
    return manifest


def _run_child(command, env, timeout):
    """(exit code, its last lines of stderr) of the child, whose stderr is passed on to this
    process's as it comes (the compilation notice); the exit code is None if the child took
    over `timeout` s and was killed."""
    with subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True, start_new_session=True) as child:
        # the lines are read as they come, so the limit is kept by a timer, which kills the
        # child's whole process group: anything it started would hold the pipe open too
        killed = threading.Event()

        def kill():
            killed.set()
            try:
                os.killpg(child.pid, signal.SIGKILL)
            except ProcessLookupError:  # it ended as the timer fired
                pass

        timer = threading.Timer(timeout, kill)
        timer.start()
        try:
            tail = deque(maxlen=30)
            for line in child.stderr:
                sys.stderr.write(line)
                sys.stderr.flush()
                tail.append(line)
        finally:
            timer.cancel()
            if child.poll() is None and not killed.is_set():  # interrupted: not left running
                os.killpg(child.pid, signal.SIGKILL)
    timed_out = killed.is_set() and child.returncode == -signal.SIGKILL
    return (None if timed_out else child.returncode), tail


def _exercise(fmu, out):
    """The child: host the FMU, step it with every integrator method, export the code."""
    import importlib

    from fmpy import calloc, extract, free, read_model_description
    from fmpy.fmi2 import (
        FMU2Slave,
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )
    from numba.core import event

    def log(environment, instance, status, category, message):
        sys.stderr.write(message.decode(errors="replace").replace("%%", "%") + "\n")
        sys.stderr.flush()

    class Compilations(event.Listener):
        count = 0

        def on_start(self, ev):
            Compilations.count += 1

        def on_end(self, ev):
            pass

    event.register("numba:compile", Compilations())
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(log)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    description = read_model_description(fmu)
    variables = {v.name: v for v in description.modelVariables}
    # unzipped into the parent's temporary folder (out's), which the parent removes: fmpy's
    # extract() would make one of its own in the system's, which nothing removes
    folder = extract(fmu, unzipdir=tempfile.mkdtemp(prefix="fmu_", dir=Path(out).parent))
    package = next(p.name for p in Path(folder, "resources").iterdir()
                   if p.name.startswith("_flexure_") and p.is_dir())
    held = [v for v in variables.values() if v.causality == "input" and v.type == "Real"]
    inputs = [v.valueReference for v in held]
    # each input at its start: a force at 0, a kinematic input where it is (0 m would be a
    # jump of the whole stroke)
    starts = [float(v.start) if v.start is not None else 0.0 for v in held]
    methods, done = None, 0
    while methods is None or done < len(methods):
        slave = FMU2Slave(guid=description.guid, unzipDirectory=folder,
                          modelIdentifier=description.coSimulation.modelIdentifier,
                          instanceName="flexure-build")
        slave.instantiate(callbacks=callbacks)
        try:
            if methods is not None:
                slave.setString([variables["integrator.method"].valueReference],
                                [methods[done]])
            slave.setupExperiment(startTime=0.0)
            slave.enterInitializationMode()
            slave.exitInitializationMode()
            for k in range(STEPS):
                slave.setReal(inputs, starts)
                slave.doStep(currentCommunicationPoint=k * STEP, communicationStepSize=STEP)
            slave.terminate()
        finally:
            slave.freeInstance()
        if methods is None:  # its default first; its slave's module is loaded now
            methods = importlib.import_module(f"{package}.fmu.scene_slave").METHODS
        done += 1
    if Compilations.count:  # exported by the next child, which loads it all
        return
    portable_cache = importlib.import_module(f"{package}.core.numerics.portable_cache")
    print(json.dumps(portable_cache.export_compiled(out)))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit("usage: python -m flexure.fmu.portable_engine FMU OUT_FOLDER")
    try:
        _exercise(sys.argv[1], sys.argv[2])
    except (FlexureError, OSError, RuntimeError) as error:
        raise SystemExit(f"{sys.argv[1]}: {type(error).__name__}: {error}") from None
