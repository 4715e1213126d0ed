"""The fmu row group: stage_planar_3dof's FMU stepped by fmpy at 1 ms, its speed, its overhead
beyond the engine (`FmuMaster`, through FMU2Slave's methods or the FMU's C functions, against
`in_process_steps`) and the latency of its first instantiate in a fresh process."""

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ..fmu_benchmark import Timed
from .measure import alternate, log
from .table import Row

FMU_STEP = 1e-3  # s
# A host's first instantiate + initialise + doStep in a new process: its wall and CPU seconds,
# the whole process's CPU seconds, and the output (fmu_overhead's and portable's rows)
FIRST_INSTANTIATE = r"""
import json, resource, sys, time
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
vr = {v.name: v.valueReference for v in md.modelVariables}
folder = extract(sys.argv[1])
ready, ready_cpu = time.perf_counter(), time.process_time()
fmu = FMU2Slave(guid=md.guid, unzipDirectory=folder,
                modelIdentifier=md.coSimulation.modelIdentifier, instanceName="first")
fmu.instantiate()
fmu.setupExperiment(startTime=0.0)
fmu.enterInitializationMode()
fmu.exitInitializationMode()
fmu.setReal([vr["F"]], [1.0])
fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
x = fmu.getReal([vr["x"]])[0]
done, done_cpu = time.perf_counter(), time.process_time()
fmu.terminate()
fmu.freeInstance()
usage = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"first_step_s": done - ready, "first_cpu_s": done_cpu - ready_cpu, "x": x,
                  "process_cpu_s": usage.ru_utime + usage.ru_stime}))
"""

# The floor of any pythonfmu slave around the same simulator: setReal keeps the values,
# doStep hands a changed input over and advances, getReal reads the output; no call-sequence
# or value checks, no range-of-validity check, no error handling
BARE_SLAVE = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Real

from flexure.core import Simulator, load_scene
from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS


class BareStage(Fmi2Slave):
    author = "flexure benchmarks"
    description = "stage_planar_3dof in the least a pythonfmu slave can be"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.F, self.x = 0.0, 0.0
        self.register_variable(Real("F", causality=Fmi2Causality.input))
        self.register_variable(Real("x", causality=Fmi2Causality.output))
        self.simulator = Simulator(load_scene("stage_planar_3dof"), method=METHODS[0],
                                   rtol=DEFAULT_RTOL)
        self.held = None

    def set_real(self, vrs, values):
        self.F = values[0]

    def get_real(self, vrs):
        return [float(self.simulator.outputs()[0])]

    def do_step(self, current_time, step_size):
        if self.F != self.held:
            self.simulator.set_inputs([self.F])
            self.held = self.F
        self.simulator.advance_to(current_time + step_size)
        return True
'''


class FmuMaster:
    """An extracted FMU, instantiated and initialised by fmpy's FMU2Slave per `run`."""

    def __init__(self, path):
        from fmpy import extract, read_model_description

        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.folder = extract(str(path))

    def run(self, steps, force=1.0, *, master="fmpy"):
        """Wall (s) of `steps` setReal / doStep / getReal at FMU_STEP (after initialise), and
        (x, (the slave's simulator time inside `advance`, its time inside do_step) or None).

        The master calls: "fmpy", FMU2Slave's Python methods; "ctypes", the FMU's C functions
        from a Python loop (fmpy's ctypes handles, value arrays allocated once); "compiled",
        the same C functions from compiled code (`compiled_master`), as libcosim calls them:
        the FMU's cost without any master's own."""
        import gc
        from ctypes import c_double, c_uint

        from fmpy.fmi2 import FMU2Slave, fmi2True

        from .compiled_master import compiled_steps

        def slaves():  # the Python slaves of this FMU alive in this process (pythonfmu)
            return {id(o): o for o in gc.get_objects()
                    if type(o).__name__ == self.md.coSimulation.modelIdentifier
                    and hasattr(o, "simulator")}

        before = slaves()
        fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.folder,
                        modelIdentifier=self.md.coSimulation.modelIdentifier,
                        instanceName="bench")
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        inputs, outputs = [self.vr["F"]], [self.vr["x"]]
        new = [o for key, o in slaves().items() if key not in before]
        in_step = None
        if len(new) == 1 and master == "fmpy":  # the binary looks do_step up on the instance
            new[0].do_step = in_step = Timed(new[0].do_step)
        try:
            if master == "compiled":
                stepping = compiled_steps(fmu, inputs[0], outputs[0], force, FMU_STEP)
                start = time.perf_counter()
                x = stepping(steps)
                wall = time.perf_counter() - start
            elif master == "ctypes":
                set_real, do_step, get_real = (getattr(fmu.dll, name) for name in (
                    "fmi2SetReal", "fmi2DoStep", "fmi2GetReal"))
                component = fmu.component
                vr_in, vr_out = (c_uint * 1)(*inputs), (c_uint * 1)(*outputs)
                value, y = (c_double * 1)(force), (c_double * 1)()
                start = time.perf_counter()
                for k in range(steps):
                    if set_real(component, vr_in, 1, value) or do_step(
                            component, k * FMU_STEP, FMU_STEP, fmi2True) or get_real(
                            component, vr_out, 1, y):
                        raise RuntimeError(f"the FMU answered an error status at step {k}")
                wall = time.perf_counter() - start
                x = y[0]
            else:
                start = time.perf_counter()
                for k in range(steps):
                    fmu.setReal(inputs, [force])
                    fmu.doStep(currentCommunicationPoint=k * FMU_STEP,
                               communicationStepSize=FMU_STEP)
                    x = fmu.getReal(outputs)[0]
                wall = time.perf_counter() - start
            inside = None
            if len(new) == 1:  # (its simulator's time inside advance, its time inside do_step)
                inside = (new[0].simulator.statistics["wall_time_s"],
                          in_step.seconds if in_step is not None else None)
        finally:
            try:
                fmu.terminate()
            finally:
                fmu.freeInstance()
        return wall, (x, inside)

    def close(self):
        shutil.rmtree(self.folder, ignore_errors=True)


def in_process_steps(model, steps, force=1.0, *, method=None, rtol=None):
    """The same 1 ms advances on a Simulator, with the FMU's defaults unless given: (wall,
    (engine s, x)), the engine time being the simulator's own time inside `advance`."""
    from flexure.core import Simulator
    from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

    sim = Simulator(model, method=method or METHODS[0], rtol=rtol or DEFAULT_RTOL)
    start = time.perf_counter()
    for k in range(steps):
        sim.set_inputs([force])
        sim.advance_to((k + 1) * FMU_STEP)
        x = sim.outputs()[0]
    return time.perf_counter() - start, (sim.statistics["wall_time_s"], x)


def first_instantiate(path, cache_dir=None):
    """(whole process s, first instantiate + initialise + doStep s) in a fresh process."""
    import json

    env = dict(os.environ)
    if cache_dir is not None:
        env["FLEXURE_CACHE_DIR"] = str(cache_dir)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", FIRST_INSTANTIATE, str(path)], env=env,
                          capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"the FMU's first instantiate failed: {done.stderr[-2000:]}")
    return wall, json.loads(done.stdout.strip().splitlines()[-1])["first_step_s"]


def fmu(*, repeat=5, quick=False):
    """stage_planar_3dof's FMU stepped by fmpy at 1 ms: x real time, overhead, latency."""
    from flexure.core import load_scene
    from flexure.fmu import build_scene_fmu, build_slave_fmu
    from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

    steps = int(round(1.0 / FMU_STEP))
    rows = []
    with tempfile.TemporaryDirectory(prefix="flexure_compare_") as temp:
        temp = Path(temp)
        log("fmu: building stage_planar_3dof.fmu")
        # hosted here, where this flexure stands in for its copy: no carried engine (the
        # portable group measures that)
        path = build_scene_fmu("stage_planar_3dof", temp / "stage_planar_3dof.fmu", engine=False)
        master = FmuMaster(path)
        script = temp / "BareStage.py"
        script.write_text(BARE_SLAVE)
        bare = FmuMaster(build_slave_fmu(script, temp / "BareStage.fmu", bundle=("core",)))
        model = load_scene("stage_planar_3dof")
        engine_times = []

        def ours():
            wall, (engine, x) = in_process_steps(model, steps)
            engine_times.append(engine)
            return wall, x

        try:
            master.run(10)  # loads the slaves into this process
            bare.run(10)
            # per run: 1 - its simulator's time / wall
            beyond = {"fmu": [], "fmu ctypes": [], "fmu compiled": [], "bare compiled": []}

            def fmu_run(name, fmu, master):
                wall, (x, inside) = fmu.run(steps, master=master)
                if inside is not None:
                    beyond[name].append(1.0 - inside[0] / wall)
                return wall, (x, inside)

            t = alternate({"fmu": lambda: fmu_run("fmu", master, "fmpy"),
                           "fmu ctypes": lambda: fmu_run("fmu ctypes", master, "ctypes"),
                           "fmu compiled": lambda: fmu_run("fmu compiled", master, "compiled"),
                           "bare compiled": lambda: fmu_run("bare compiled", bare, "compiled"),
                           "in-process": ours}, repeat, "fmu")
        finally:
            master.close()
            bare.close()
        f, d, p = t["fmu"], t["fmu compiled"], t["in-process"]
        log("fmu: the accuracy reference (CVODE BDF at rtol 1e-11, in process)")
        exact = in_process_steps(model, steps, method="cvode-bdf", rtol=1e-11)[1][1]
        motion = abs(exact - model.initial_coordinates[model.outputs[0].coordinate])
        engine = statistics.median(engine_times)
        speed = 1.0 / f.median
        # of the FMU, for a compiled master's calls: each run's wall against the time of the
        # FMU's own simulator inside advance in that run (robust to the machine's load
        # changing between runs), the median over the runs
        overhead = statistics.median(beyond["fmu compiled"])
        overhead_python_master = statistics.median(beyond["fmu"])
        overhead_ctypes = statistics.median(beyond["fmu ctypes"])
        same = abs(f.info[0] - p.info)
        split = ""
        if f.info[1] is not None and f.info[1][1] is not None:  # from the last FMU run
            simulator, slave = f.info[1]
            last = f.walls[-1]
            split = (f"; of the last run's wall {last:.3f} s: the slave's simulator inside "
                     f"advance {simulator:.3f} s, flexure's slave in Python beyond it "
                     f"{100 * (slave - simulator) / last:.1f} %, fmpy and pythonfmu's binary "
                     f"{100 * (last - slave) / last:.1f} %")
        rows.append(Row(f"FMU of stage_planar_3dof by fmpy, 1 ms steps for 1 s ({METHODS[0]}, "
                        f"rtol {DEFAULT_RTOL:g}, its defaults): >= 10 x real time",
                        f"{speed:.2f} x ({f.text()}; x after 1 s "
                        f"{abs(f.info[0] - exact) / motion:.1e} of its motion from CVODE at "
                        "rtol 1e-11)", ">= 10 x", speed / 10,
                        speed >= 10))
        rows.append(Row("FMU overhead beyond the engine (1 - engine / FMU wall) <= 10 %, "
                        "the master calling the FMU's C functions from compiled code (as "
                        "libcosim does)",
                        f"{100 * overhead:.1f} % (median of each run's 1 - its simulator's "
                        f"time / its wall; FMU {d.text()}; the in-process loop {p.text()}, "
                        f"its engine {engine:.3f} s; |x_FMU - x| = {same:.0e} m)", "<= 10 %",
                        overhead / 0.10, overhead <= 0.10))
        rows.append(Row("the floor: the same simulator in a bare pythonfmu slave (setReal "
                        "keeps the value, doStep advances, getReal reads the output; no "
                        "checks), its C functions called from compiled code",
                        f"{100 * statistics.median(beyond['bare compiled']):.1f} % (FMU "
                        f"{t['bare compiled'].text()}; x {t['bare compiled'].info[0]:.9g} m, "
                        f"flexure's FMU {d.info[0]:.9g} m)", "(information)"))
        rows.append(Row("flexure's FMU, its C functions called from a Python loop (fmpy's "
                        "ctypes handles; the master's ctypes calls included)",
                        f"{100 * overhead_ctypes:.1f} % (FMU {t['fmu ctypes'].text()})",
                        "(information)"))
        rows.append(Row("the same through fmpy's FMU2Slave methods (the master's Python "
                        "wrapper included)",
                        f"{100 * overhead_python_master:.1f} % (FMU {f.text()}{split})",
                        "(information)"))
        log("fmu: first instantiate in fresh processes")
        warm = [first_instantiate(path) for _ in range(max(1, min(repeat, 3)))]
        warm_text = (f"warm cache: {statistics.median(w[1] for w in warm):.2f} s "
                     f"(process {statistics.median(w[0] for w in warm):.2f} s)")
        if quick:
            cold_text = "cold cache: not measured (--quick)"
        else:
            with tempfile.TemporaryDirectory(prefix="flexure_cold_cache_") as cold:
                log("fmu: first instantiate with an empty FLEXURE_CACHE_DIR (compiles)")
                process, first = first_instantiate(path, cold)
            cold_text = f"empty cache: {first:.1f} s (process {process:.1f} s)"
        rows.append(Row("FMU's first instantiate + initialise + doStep in a fresh process",
                        f"{warm_text}; {cold_text}", "(latency, no target)"))
    return rows
