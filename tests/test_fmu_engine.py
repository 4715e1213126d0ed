"""The compiled engine an FMU carries (flexure.fmu.portable_engine, .compiled_engine), and the
compilation notice in an FMU host's log.

- A host that must compile (an empty cache) is told so through its FMI logger at status
  warning during its first instantiate, with debug logging off: the child host prints each
  logged message as it comes and is stopped once the notice arrives (the compilation itself
  would take a minute).
- An FMU whose carried engine does not fit this Python (another numba version, a manifest that
  cannot be read) logs why and compiles as an FMU without one does; in a host whose flexure
  stands in for the FMU's copy, the carried engine is not used and a note says so.
- Slow: an FMU built here with its engine, copied into a fresh venv that has only the FMU's
  requirements (and fmpy), instantiated and stepped there with an empty cache, with each
  integrator method: not one function compiles, the cache holds what the FMU carried and
  nothing more, and the outputs are those of the same steps run in this process.
"""

import hashlib
import json
import os
import shutil
import subprocess
import sys
import textwrap
import venv
import zipfile
from pathlib import Path

import children
import numpy as np
import pytest

from flexure.core.numerics.compile_notice import DEFAULT_CPU_S, SLOW_MACHINE_CPU_S
from flexure.fmu.pythonfmu_binary import LIBRARY, NATIVE

# A child host: instantiate the FMU (debug logging off), step it, print every message its
# logger gets as a JSON line as it comes, then a summary line: the numba compilations in the
# process, the CPU seconds of instantiate + initialise + steps, the outputs.
CORRECTED_SHA256 = hashlib.sha256((NATIVE / "linux64" / LIBRARY).read_bytes()).hexdigest()
HOST = textwrap.dedent("""
    import json, sys, time
    from numba.core import event
    from fmpy import calloc, extract, free, read_model_description
    from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE,
                           fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                           fmi2CallbackLoggerTYPE)

    class Count(event.Listener):
        compiled = 0
        def on_start(self, ev):
            Count.compiled += 1
        def on_end(self, ev):
            pass

    event.register("numba:compile", Count())

    def log(environment, instance, status, category, message):
        print(json.dumps({"status": status, "category": category.decode(),
                          "message": message.decode().replace("%%", "%")}), flush=True)

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(log)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    path, force, steps = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
    methods = sys.argv[4].split(",") if len(sys.argv) > 4 else [""]  # "": the default
    description = read_model_description(path)
    vr = {v.name: v.valueReference for v in description.modelVariables}
    outputs = [v.name for v in description.modelVariables if v.causality == "output"]
    folder = extract(path)
    y, cpu = [], None
    for method in methods:
        start = time.process_time()
        fmu = FMU2Slave(guid=description.guid, unzipDirectory=folder,
                        modelIdentifier=description.coSimulation.modelIdentifier,
                        instanceName="host")
        fmu.instantiate(callbacks=callbacks, loggingOn=False)
        if method:
            fmu.setString([vr["integrator.method"]], [method])
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        for k in range(steps):
            fmu.setReal([vr["F"]], [force])
            fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
            if cpu is None:  # the first instance's outputs
                y.append(fmu.getReal([vr[name] for name in outputs]))
        cpu = time.process_time() - start if cpu is None else cpu
        fmu.terminate()
        fmu.freeInstance()
    print(json.dumps({"compiled": Count.compiled, "cpu_s": cpu, "outputs": outputs, "y": y}))
""")


def start_host(fmu, cache, python=sys.executable, own_copy=False, steps=3, force=1.0,
               methods=None):
    env = {key: value for key, value in os.environ.items()
           if key not in ("FLEXURE_FMU_OWN_COPY", "NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES")}
    env["FLEXURE_CACHE_DIR"] = str(cache)
    env["TMPDIR"] = str(Path(fmu).parent)  # where fmpy unzips it: the test's own folder
    if own_copy:
        env["FLEXURE_FMU_OWN_COPY"] = "1"
    extra = [",".join(methods)] if methods else []
    return subprocess.Popen([str(python), "-c", HOST, str(fmu), str(force), str(steps), *extra],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=Path(fmu).parent)


def messages_until(host, words):
    """The host's logged messages up to the first that contains `words`; the host is then
    stopped (it would go on compiling)."""
    try:
        lines = children.lines_until(
            host, host.stdout, lambda line: words in json.loads(line).get("message", ""))
    except AssertionError as error:
        raise AssertionError(f"the host did not log {words!r}: {error}\n"
                             f"its stderr: {host.stderr.read()[-3000:]}") from None
    finally:
        host.kill()
        host.wait()
    return [json.loads(line) for line in lines]


def with_engine_folder(fmu, folder, manifest_text):
    """A copy of `fmu` in `folder` whose resources/flexure-engine holds `manifest_text`."""
    copy = Path(folder) / Path(fmu).name
    shutil.copyfile(fmu, copy)
    with zipfile.ZipFile(copy, "a") as archive:
        archive.writestr("resources/flexure-engine/manifest.json", manifest_text)
    return copy


NOTICE = "flexure: compiling its engine for this machine, once per version of flexure: "


def test_a_host_that_must_compile_sees_the_notice_in_its_log(scene_fmus, tmp_path):
    cache = tmp_path / "cache"
    seen = messages_until(start_host(scene_fmus("stage_planar_1dof"), cache),
                          "compiling its engine")
    notice = seen[-1]
    assert (notice["status"], notice["category"]) == (1, "logStatusWarning")
    assert notice["message"] == (
        f"host: {NOTICE}about {DEFAULT_CPU_S:.0f} s of CPU (measured on flexure's 2-core "
        f"development machines, up to {SLOW_MACHINE_CPU_S:.0f} s on a slower one; none here "
        f"yet); kept in {cache}")


@pytest.mark.parametrize("manifest, says", [
    (json.dumps({"format": 1, "numba": "0.0.1", "python": "{}.{}".format(*sys.version_info),
                 "implementation": "cpython", "abiflags": ""}),
     "it was compiled for numba 0.0.1; this Python has numba "),
    pytest.param("{not json", "its manifest.json cannot be read (JSONDecodeError: ",
                 marks=pytest.mark.slow),  # 2 s: the same path as the manifest above
])
def test_a_carried_engine_that_does_not_fit_is_left_out_with_a_warning(scene_fmus, tmp_path,
                                                                      manifest, says):
    """... and the instantiation goes on to compile, as an FMU without one does."""
    fmu = with_engine_folder(scene_fmus("stage_planar_1dof"), tmp_path, manifest)
    seen = messages_until(start_host(fmu, tmp_path / "cache", own_copy=True),
                          "compiling its engine")
    assert len(seen) == 2, seen
    assert (seen[0]["status"], seen[0]["category"]) == (1, "logStatusWarning")
    prefix = "host: the compiled engine the FMU carries is not used: "
    assert seen[0]["message"].startswith(prefix + says), seen[0]
    assert seen[0]["message"].endswith("; the engine compiles for this machine instead")
    assert seen[1]["message"].startswith(f"host: {NOTICE}")


@pytest.mark.slow
def test_where_this_flexure_stands_in_the_carried_engine_is_not_used(scene_fmus, tmp_path):
    """The host's flexure runs in place of the FMU's copy, with its own cache (this session's,
    compiled), so the carried engine is left alone: a note at status OK says so (logged with
    debug logging on only), nothing compiles, and the instantiation completes."""
    from flexure.core.numerics.jit import cache_root

    # the same code path compiled first, by a host of the same CPU target as the one below
    warm_up = start_host(scene_fmus("stage_planar_1dof"), cache_root())
    children.finish(warm_up, 600)
    assert warm_up.returncode == 0
    fmu = with_engine_folder(scene_fmus("stage_planar_1dof"), tmp_path, "{}")
    host = start_host(fmu, cache_root())
    out, err = children.finish(host, 600)
    assert host.returncode == 0, err[-3000:]
    result = json.loads(out.strip().splitlines()[-1])
    assert result["compiled"] == 0 and len(result["y"]) == 3
    assert out.strip().splitlines()[:-1] == []  # debug logging off: the OK note not passed
    loud = children.run([sys.executable, "-c", HOST.replace("loggingOn=False",
                                                            "loggingOn=True"),
                         str(fmu), "1.0", "1"], capture_output=True, text=True,
                        env={**os.environ, "FLEXURE_CACHE_DIR": str(cache_root()),
                             "TMPDIR": str(tmp_path)})
    notes = [json.loads(line) for line in loud.stdout.strip().splitlines()[:-1]]
    assert [(n["status"], n["message"]) for n in notes] == [(0, (
        "host: this Python's flexure has the FMU's sources and runs in place of its copy, "
        "with its own compiled-code cache; the compiled engine the FMU carries is not used "
        "(FLEXURE_FMU_OWN_COPY=1 uses it)")), (0, (
        "host: pythonfmu binary (linux64): flexure's corrected build of pythonfmu 0.7.0 "
        f"(patch 1, SHA-256 {CORRECTED_SHA256[:12]}): NULL state handles and freed instances "
        "answer fmi2Error"))]


def test_the_engine_is_left_out_when_asked(tmp_path, monkeypatch):
    """`flexure fmu build --no-engine` leaves it out whatever FLEXURE_FMU_ENGINE says, and
    FLEXURE_FMU_ENGINE=0 makes that the default (this suite's)."""
    from flexure.core.cli import main
    from flexure.fmu import build_scene_fmu

    def carried(fmu):
        with zipfile.ZipFile(fmu) as archive:
            return [n for n in archive.namelist() if n.startswith("resources/flexure-engine/")]

    monkeypatch.setenv("FLEXURE_FMU_ENGINE", "1")
    assert main(["fmu", "build", "truss_1dof_x", "--no-engine", "-o",
                 str(tmp_path / "a.fmu")]) == 0
    assert carried(tmp_path / "a.fmu") == []
    monkeypatch.setenv("FLEXURE_FMU_ENGINE", "0")
    assert carried(build_scene_fmu("truss_1dof_x", tmp_path / "b.fmu")) == []


def test_a_failed_compilation_of_the_engine_fails_the_build(tmp_path):
    """The child that compiles the engine fails (here: the file is not an FMU): the build
    raises FMUBuildError with the child's last lines, and leaves the file as it was."""
    from flexure.fmu import FMUBuildError
    from flexure.fmu.portable_engine import add_compiled_engine

    broken = tmp_path / "broken.fmu"
    broken.write_bytes(b"not a zip file")
    with pytest.raises(FMUBuildError) as error:
        add_compiled_engine(broken)
    message = str(error.value)
    assert message.startswith(f"{broken}: compiling its engine for a portable CPU target "
                              "failed (exit code 1):\n")
    assert "BadZipFile" in message
    assert broken.read_bytes() == b"not a zip file"


@pytest.mark.timeout(60)  # without the limit the build waits for the hung child for ever
def test_a_hung_compilation_of_the_engine_is_killed_after_the_limit(tmp_path, monkeypatch):
    """The child that compiles the engine hangs (here: a Python that sleeps): after
    CHILD_TIMEOUT it is killed, with what it started, and the build raises FMUBuildError
    saying so, with the child's last lines; the FMU is left as it was."""
    import time

    from flexure.fmu import FMUBuildError, portable_engine

    pids = tmp_path / "pids"
    hung = tmp_path / "python"
    # the child starts a grandchild that holds its stderr too; both must go
    hung.write_text(f"#!/bin/sh\necho starting >&2\nsleep 300 &\necho $$ $! > {pids}\n"
                    "wait\n")
    hung.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(hung))
    monkeypatch.setattr(portable_engine, "CHILD_TIMEOUT", 2.0)
    fmu = tmp_path / "a.fmu"
    fmu.write_bytes(b"left as it was")
    start = time.monotonic()
    with pytest.raises(FMUBuildError) as error:
        portable_engine.add_compiled_engine(fmu)
    assert time.monotonic() - start < 30
    assert str(error.value) == (f"{fmu}: compiling its engine for a portable CPU target took "
                                "over 2 s; the child was killed:\nstarting\n")
    assert fmu.read_bytes() == b"left as it was"
    def running(pid):  # neither gone nor dead and not yet reaped
        try:
            return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
        except FileNotFoundError:
            return False

    for pid in map(int, pids.read_text().split()):
        deadline = time.monotonic() + 10  # SIGKILL was sent; it ends when next scheduled
        while running(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not running(pid)


@pytest.mark.slow  # ~3 minutes: a portable compilation, a venv with pip, the host
def test_an_fmu_with_its_engine_instantiates_in_a_fresh_venv_without_compiling(tmp_path):
    from fmpy import __version__ as fmpy_version

    from flexure.core import Simulator, load_scene
    from flexure.fmu import build_scene_fmu
    from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

    fmu = build_scene_fmu("stage_planar_3dof", tmp_path / "stage_planar_3dof.fmu", engine=True)
    with zipfile.ZipFile(fmu) as archive:
        requirements = archive.read("resources/requirements.txt").decode()
        manifest = json.loads(archive.read("resources/flexure-engine/manifest.json"))
    assert (manifest["cpu_name"], manifest["cpu_features"]) == ("generic", "")
    assert manifest["not_cached"] == []
    # what a host loads: the entries of the engine's operations its integrator methods call
    # (one per operation: 21 measured) and the functions that call them, whose code holds
    # their callees'; not the 120 and more that a first compilation leaves in the cache
    assert 1 <= manifest["functions"] <= 40
    # a fresh venv: the FMU's pinned requirements and the host's fmpy, from the registry (or
    # pip's local cache); no flexure
    home = tmp_path / "venv"
    venv.create(home, with_pip=True)
    python = home / "bin" / "python"
    (tmp_path / "requirements.txt").write_text(requirements)
    children.run([str(python), "-m", "pip", "install", "-q", "-r",
                  str(tmp_path / "requirements.txt"), f"fmpy=={fmpy_version}"],
                 check=True, capture_output=True, timeout=1200)
    missing = children.run([str(python), "-c", "import flexure"], capture_output=True)
    assert missing.returncode != 0  # the FMU's own copy runs there
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    copy = shutil.copy(fmu, elsewhere)
    cache = tmp_path / "empty-cache"
    steps = 50  # with the default method (esdirk), then with each other method
    host = start_host(copy, cache, python=python, steps=steps, methods=METHODS)
    out, err = children.finish(host, 900)
    assert host.returncode == 0, err[-3000:]
    lines = out.strip().splitlines()
    result = json.loads(lines[-1])
    logged = [json.loads(line)["message"] for line in lines[:-1]]
    assert result["compiled"] == 0, logged
    assert not any("compil" in message for message in logged), logged
    # what is in the cache is what was installed, nothing compiled was added: besides it
    # only the object code of installed entries, copied out of numba's files for the next
    # process (numerics/object_code.py)
    installed = {p.relative_to(cache).parts[2:] for p in cache.rglob("*") if p.is_file()}
    with zipfile.ZipFile(fmu) as archive:
        shipped = {tuple(Path(name).parts[2:]) for name in archive.namelist()
                   if name.startswith("resources/flexure-engine/")
                   and not name.endswith("manifest.json")}
    copied = {path for path in installed if path[-1].endswith(".fxo")}
    assert installed - copied == shipped
    indexes = {(*path[:-1], path[-1].rsplit(".", 2)[0] + ".nbi") for path in copied}
    assert copied and indexes <= shipped
    print(f"first instantiate + initialise + {steps} steps: {result['cpu_s']:.2f} s of CPU")
    # the same steps here (this machine's CPU target): the same motion. The two compilations
    # differ in round-off (operations fused or reordered), on which the integrator's error
    # control at rtol 1e-6 chooses its steps a little differently: 8.5e-9 of the motion's
    # range apart, measured; allowed 1e-7, a tenth of what the integrator itself is off by at
    # that tolerance (docs/decisions.md: 3.1e-6 of the motion)
    simulator = Simulator(load_scene("stage_planar_3dof"), method=METHODS[0], rtol=DEFAULT_RTOL)
    here = []
    for k in range(steps):
        simulator.set_inputs([1.0])
        simulator.advance_to((k + 1) * 1e-3)
        here.append(simulator.output_values())
    here, there = np.array(here), np.array(result["y"])
    scale = np.ptp(here, axis=0).max()
    assert scale > 1e-6
    assert np.max(np.abs(there - here)) <= 1e-7 * scale
