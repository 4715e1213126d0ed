"""Scene FMUs in other masters: libcosim (libcosimpy), the JVM (FMI4j), and a generic slave.

The JVM master is tests/hosts/fmi4j/Host.java on FMI4j 0.38.0 from Maven Central (fetched by
`mvn dependency:build-classpath` into ~/.m2 on first use), run as a single-file Java program
with the environment `flexure fmu env` prints: libpython preloaded, the venv's site-packages.
"""

import os
import shutil
import sys
import textwrap
from pathlib import Path

import children
import numpy as np
import pytest
from fmpy import read_model_description
from fmpy_slave import Slave

from flexure.fmu import (
    FMUBuildError,
    build_scene_fmu,
    build_slave_fmu,
    fmu_environment,
    validate_fmu_file,
)

HOSTS = Path(__file__).parent / "hosts"
NS = 1_000_000_000


@pytest.fixture(scope="module")
def stage_fmu(tmp_path_factory):
    return build_scene_fmu("stage_planar_3dof",
                           tmp_path_factory.mktemp("hosts") / "stage_planar_3dof.fmu")


def fmpy_run(path, forces, h, *, state_at=None):
    """Outputs after each step of fmpy's FMU2Slave, step k from k h with forces[k].

    Taking an FMU state marks a restart point of the integrator; `state_at` takes one before
    that step, as the JVM host does.
    """
    slave = Slave(path, "reference")
    ys = []
    for k, force in enumerate(forces):
        if k == state_at:
            slave.fmu.freeFMUstate(slave.fmu.getFMUstate())
        slave.set(force)
        ys.append(slave.step(k * h, h))
    slave.close()
    return np.array(ys)


def test_libcosim_steps_overrides_and_observes(stage_fmu):
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    h = 1e-3
    execution = CosimExecution.from_step_size(step_size=int(h * NS))
    stage = execution.add_local_slave(CosimLocalSlave(fmu_path=str(stage_fmu),
                                                      instance_name="stage"))
    vr = {v.name.decode(): v.reference for v in execution.slave_variables(stage)}
    manipulator = CosimManipulator.create_override()
    execution.add_manipulator(manipulator=manipulator)
    last = CosimObserver.create_last_value()
    execution.add_observer(observer=last)
    series = CosimObserver.create_time_series()
    execution.add_observer(observer=series)
    series.start_time_series(stage, vr["x"], CosimVariableType.REAL)
    assert execution.step()  # initialises, then one step with F = 0
    manipulator.slave_real_values(stage, [vr["F"]], [0.5])
    assert execution.step(step_count=9)
    x, y, force = last.last_real_values(stage, [vr["x"], vr["y"], vr["F"]])
    assert force == 0.5
    expected = fmpy_run(stage_fmu, [0.0] + [0.5] * 9, h)
    # libcosim counts time in integer nanoseconds: the same steps up to rounding of t.
    np.testing.assert_allclose([x, y], expected[-1], rtol=0, atol=1e-12)
    times, _, values = series.time_series_real_samples(stage, vr["x"], from_step=1,
                                                       sample_count=10)
    np.testing.assert_allclose(values, expected[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.array(times) / NS, h * np.arange(1, 11), atol=1e-12)
    # A NaN force: the step is refused, libcosim reports it, this process goes on.
    manipulator.slave_real_values(stage, [vr["F"]], [float("nan")])
    assert not execution.step()
    assert last.last_real_values(stage, [vr["x"]])[0] == x


@pytest.fixture(scope="module")
def fmi4j_classpath(tmp_path_factory):
    """The classpath of FMI4j 0.38.0 from Maven Central (cached in ~/.m2 by Maven)."""
    mvn, java = shutil.which("mvn"), shutil.which("java")
    assert mvn and java, "the JVM host test needs java (>= 11) and mvn on PATH"
    output = tmp_path_factory.mktemp("fmi4j") / "classpath.txt"
    children.run([mvn, "-q", "-B", "-f", str(HOSTS / "fmi4j" / "pom.xml"),
                  "dependency:build-classpath", f"-Dmdep.outputFile={output}"],
                 check=True, capture_output=True)
    return output.read_text().strip()


@pytest.mark.slow
def test_jvm_host_fmi4j_steps_and_replays_state(stage_fmu, fmi4j_classpath, tmp_path):
    md = read_model_description(str(stage_fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    h, steps, force = 1e-3, 20, 0.5
    env = dict(os.environ, **fmu_environment())
    # a run takes a few seconds (more when the bundle's engine compiles first); a JVM that
    # crashes exits at once without writing an error report (which could hang)
    done = children.run(
        ["java", "-XX:+SuppressFatalErrorMessage", "-XX:-CreateCoredumpOnCrash", "-cp",
         fmi4j_classpath, str(HOSTS / "fmi4j" / "Host.java"), str(stage_fmu),
         str(steps * h), str(h), str(vr["F"]), str(force), f"{vr['x']},{vr['y']}"],
        capture_output=True, text=True, env=env, timeout=240, cwd=tmp_path)
    lines = [line.split(",") for line in done.stdout.splitlines() if line[:1].isdigit()]
    jvm = np.array([[float(v) for v in line[1:]] for line in lines])
    replay = [line for line in done.stdout.splitlines() if line.startswith("state-replay,")]
    assert replay == ["state-replay,0.0"], done.stderr[-3000:]  # restored: bit for bit
    expected = fmpy_run(stage_fmu, [force] * steps, h, state_at=steps // 2)
    assert jvm.shape == expected.shape
    np.testing.assert_allclose(jvm, expected, rtol=0, atol=1e-12)
    if done.returncode != 0:
        # Known defect, not ours to fix here: pythonfmu 0.7.0's binary releases its
        # interpreter guard twice at process exit (fmu/pythonfmu_workarounds.py,
        # guard_exit); in a JVM host that release is the interpreter's finalisation, and
        # the static destructors of the compiled engine's LLVM run between the two releases
        # and reuse the freed block, so the JVM can die after its last line (malloc's
        # unlink_chunk). Every result above has been checked; the exit status is reported,
        # not hidden.
        pytest.xfail(f"the JVM exited with {done.returncode} after a complete, correct run "
                     "(pythonfmu 0.7.0's double release of its guard at exit)")


GENERIC_SLAVE = '''
"""A SafeSlave whose steps fail on request, with '%' in every message."""

from flexure.core import SimulationError
from flexure.fmu.slave import SafeSlave


class percent_slave(SafeSlave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.mode = 0.0
        self.y = 0.0
        self.add_real("mode", causality="input", start=0.0)
        self.add_real("y", causality="output", unit="m")

    def advance(self, t, h):
        if self.mode in (1, 3):
            raise SimulationError("100% off at %s %d %n")
        if self.mode == 2:
            raise ZeroDivisionError("a bug, %s")
        self.y += h

    def last_good_time(self):
        if self.mode == 3:
            raise SimulationError("no last good state either")
        return self.time

    def save_state(self):
        return self.y

    def load_state(self, state):
        self.y = state
'''

GENERIC_HOST = '''
import sys
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

path = sys.argv[1]
md = read_model_description(path)
vr = {v.name: v.valueReference for v in md.modelVariables}
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), instanceName="p",
                modelIdentifier=md.coSimulation.modelIdentifier)
fmu.instantiate(loggingOn=True)  # fmpy's own logger, which formats printf-style


def initialize():
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()


def step_in_modes(modes, t):
    """For each mode: set it, try a 0.25 s step from t, print its status."""
    for mode in modes:
        fmu.setReal([vr["mode"]], [mode])
        try:
            fmu.doStep(t, 0.25)
            print("status ok", flush=True)
        except FMICallException as error:
            print("status", error, flush=True)


initialize()
fmu.doStep(0.0, 0.25)
step_in_modes((1.0, 2.0, 0.0), 0.25)
print("y", fmu.getReal([vr["y"]])[0], flush=True)
fmu.reset()
initialize()
fmu.setReal([vr["mode"]], [0.0])
fmu.doStep(0.0, 0.5)
print("after reset", fmu.getReal([vr["y"]])[0], flush=True)
step_in_modes((3.0, 0.0), 0.5)
'''


def test_generic_slave_failures_are_discards_with_escaped_messages(tmp_path):
    """build_slave_fmu on a SafeSlave script: a model error and a bug are fmi2Discard (the
    bug, or a model that cannot report its last good state, breaks the instance until
    reset), messages with '%s %d %n' reach fmpy's printf-style
    logger intact (unescaped they crash the process), and the process survives."""
    script = tmp_path / "percent_slave_test.py"
    script.write_text(textwrap.dedent(GENERIC_SLAVE))
    path = build_slave_fmu(script, tmp_path / "percent.fmu")
    assert validate_fmu_file(path) == []
    md = read_model_description(str(path))
    assert md.coSimulation.modelIdentifier == "percent_slave"
    assert [u.name for u in md.unitDefinitions] == ["m"]
    host = tmp_path / "host.py"
    host.write_text(GENERIC_HOST)
    done = children.run([sys.executable, str(host), str(path)], capture_output=True,
                        text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    assert out.count("status fmi2DoStep failed with status 2 (discard)") == 5, out
    assert "status ok" not in out
    assert "100% off at %s %d %n" in out
    assert "a bug, %s" in out and "ZeroDivisionError" in out
    assert "step refused" in out  # the bug broke the instance: mode 0 is refused too
    assert "y 0.25" in out and "after reset 0.5" in out
    # mode 3: the model cannot report its last good state either: the instance is broken.
    assert "then recovering the last good state failed: no last good state either" in out
    assert out.count("step refused") == 2


def test_build_is_not_fooled_by_a_loaded_module_of_the_same_name(tmp_path):
    """A slave script named like a module this process already runs (another FMU's) still
    builds its own class, and unknown bundle parts are refused."""
    script = tmp_path / "same_name_slave.py"
    script.write_text(textwrap.dedent(GENERIC_SLAVE))
    first = build_slave_fmu(script, tmp_path / "first.fmu")
    running = Slave(first, "running")  # loads the module `same_name_slave`
    script.write_text(textwrap.dedent(GENERIC_SLAVE).replace('"y"', '"z"').replace(
        "class percent_slave", "class other_slave"))
    second = build_slave_fmu(script, tmp_path / "second.fmu")
    running.close()
    md = read_model_description(str(second))
    assert md.coSimulation.modelIdentifier == "other_slave"
    assert [v.name for v in md.modelVariables] == ["mode", "z"]
    with pytest.raises(FMUBuildError, match="unknown flexure package 'plots'"):
        build_slave_fmu(script, tmp_path / "third.fmu", bundle=("core", "plots"))
