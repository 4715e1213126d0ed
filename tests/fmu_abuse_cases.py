"""FMU abuse cases, each run in a process of its own by the tests (fmu_abuse_runs.py).

`python fmu_abuse_cases.py CASE FMU [OTHER_FMU]` runs `case_CASE` against a scene FMU (an
.fmu or its extracted folder) in fmpy, printing its events (fmu_abuse_host.py), and
"SURVIVED" when the case ran to its end (the process then exits normally, which also runs
the FMU binary's teardown at exit).
"""

import ctypes
import gc
import os
import pickle
import sys

from fmpy.fmi2 import FMU2Slave
from fmu_abuse_host import (
    Host,
    call,
    check_unchanged,
    outputs,
    restore,
    say,
    state_bytes,
    step,
)


class Exploit:
    """A pickle that runs a shell command when unpickled."""

    def __reduce__(self):
        return (os.system, (f"touch {MARKER}",))


MARKER = os.environ.get("ABUSE_MARKER", "/nonexistent/marker")


def case_pickle_state(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    before = outputs(host, fmu)
    restore(fmu, pickle.dumps(Exploit()))
    say("VALUE marker-exists", os.path.exists(MARKER))
    check_unchanged(host, fmu, before, 1e-3)


def case_flipped_byte(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    data = bytearray(state_bytes(fmu))
    step(fmu, 1e-3)
    before = outputs(host, fmu)
    for index in (len(data) // 2, len(data) - 1, 30):  # payload, last byte, checksum
        damaged = bytearray(data)
        damaged[index] ^= 0x01
        restore(fmu, bytes(damaged))
    check_unchanged(host, fmu, before, 2e-3)


def case_truncated_state(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    data = state_bytes(fmu)
    before = outputs(host, fmu)
    for n in (len(data) - 1, len(data) // 2, 40, 5):
        restore(fmu, data[:n])
    check_unchanged(host, fmu, before, 1e-3)


def case_empty_state(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    before = outputs(host, fmu)
    restore(fmu, b"")
    check_unchanged(host, fmu, before, 1e-3)


def case_garbage_state(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    before = outputs(host, fmu)
    restore(fmu, os.urandom(4096))
    restore(fmu, b"FLXSTATE" + os.urandom(200))  # the magic, then garbage
    check_unchanged(host, fmu, before, 1e-3)


def case_other_scene_state(host, other):
    other_fmu = other.instance("other")
    step(other_fmu, 0.0)
    data = state_bytes(other_fmu)
    fmu = host.instance()
    step(fmu, 0.0)
    before = outputs(host, fmu)
    restore(fmu, data)
    check_unchanged(host, fmu, before, 1e-3)


def case_state_round_trip(host, other):
    """The valid path still works: a serialized state restores into a second instance."""
    a = host.instance("a")
    step(a, 0.0)
    data = state_bytes(a)
    step(a, 1e-3)
    expected = outputs(host, a)
    b = host.instance("b")
    restore(b, data)
    step(b, 1e-3)
    say("VALUE same", outputs(host, b) == expected)


def case_unknown_vr(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    before = outputs(host, fmu)
    for _ in range(3):  # the owner measured: the third call after two Fatals killed the host
        status, values = call("fmi2GetReal", fmu.getReal, [99999])
        say("VALUE read", values)
    call("fmi2GetString", fmu.getString, [host.first("output")])  # a Real read as String
    check_unchanged(host, fmu, before, 1e-3)
    call("fmi2SetReal", fmu.setReal, [99999], [1.0])
    status, _ = step(fmu, 2e-3)
    say("VALUE after-set", status)
    call("fmi2Reset", fmu.reset)
    for name, function in (("fmi2SetupExperiment", lambda: fmu.setupExperiment(startTime=0.0)),
                           ("fmi2EnterInitializationMode", fmu.enterInitializationMode),
                           ("fmi2ExitInitializationMode", fmu.exitInitializationMode)):
        call(name, function)
    status, _ = step(fmu, 0.0)
    say("VALUE after-reset", status)


def case_set_output(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    before = outputs(host, fmu)
    call("fmi2SetReal", fmu.setReal, [host.first("output")], [123.0])
    say("VALUE unchanged", outputs(host, fmu) == before)
    status, _ = step(fmu, 1e-3)
    say("VALUE after-set", status)


def case_bad_parameters(host, other):
    for name, value in (("integrator.atol", -1.0), ("integrator.rtol", 0.0),
                        ("integrator.rtol", float("nan"))):
        fmu = host.instance(name, initialize=False)
        call("fmi2SetupExperiment", fmu.setupExperiment, startTime=0.0)
        call("fmi2EnterInitializationMode", fmu.enterInitializationMode)
        call("fmi2SetReal", fmu.setReal, [host.vr[name]], [value])
        call("fmi2ExitInitializationMode", fmu.exitInitializationMode)
        status, _ = step(fmu, 0.0)
        say("VALUE", name, value, status)
    fmu = host.instance("late")  # a fixed parameter after initialization
    call("fmi2SetReal", fmu.setReal, [host.vr["integrator.rtol"]], [1e-6])
    status, _ = step(fmu, 0.0)
    say("VALUE late", status)


def case_step_before_init(host, other):
    fmu = host.instance(initialize=False)
    step(fmu, 0.0)  # before setupExperiment
    call("fmi2SetupExperiment", fmu.setupExperiment, startTime=0.0)
    step(fmu, 0.0)  # before enterInitializationMode
    call("fmi2EnterInitializationMode", fmu.enterInitializationMode)
    step(fmu, 0.0)  # in initialization mode
    call("fmi2SetupExperiment", fmu.setupExperiment, startTime=0.0)  # too late
    call("fmi2ExitInitializationMode", fmu.exitInitializationMode)
    status, _ = step(fmu, 0.0)
    say("VALUE legal", status)


def case_step_after_terminate(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    call("fmi2Terminate", fmu.terminate)
    step(fmu, 1e-3)
    call("fmi2Terminate", fmu.terminate)
    call("fmi2ExitInitializationMode", fmu.exitInitializationMode)
    say("VALUE read", outputs(host, fmu) is not None)


def case_double_free(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    fmu.fmi2FreeInstance(fmu.component)
    say("VALUE first-free-done")
    fmu.fmi2FreeInstance(fmu.component)
    say("VALUE second-free-done")
    gc.collect()


def case_step_after_free(host, other):
    fmu = host.instance()
    step(fmu, 0.0)
    fmu.fmi2FreeInstance(fmu.component)
    say("VALUE free-done")
    step(fmu, 1e-3)


def case_many_instances(host, other):
    fmus = [host.instance(f"i{k}") for k in range(10)]
    for fmu in fmus:
        step(fmu, 0.0)
    for fmu in fmus:
        call("fmi2Terminate", fmu.terminate)
        fmu.fmi2FreeInstance(fmu.component)
    say("VALUE freed", len(fmus))


def case_interleaved(host, other):
    a, b = host.instance("a"), host.instance("b")
    c = other.instance("c")
    for k in range(5):
        for fmu in (a, c, b):
            step(fmu, k * 1e-3)
    state = a.getFMUstate()
    step(a, 5e-3)
    call("fmi2SetFMUstate", b.setFMUstate, state)  # a's state in b: same FMU, allowed
    call("fmi2SetFMUstate", c.setFMUstate, state)  # a's state in another scene's instance
    a.freeFMUstate(state)
    for fmu in (b, a, c):  # freed in another order than instantiated
        call("fmi2Terminate", fmu.terminate)
        fmu.fmi2FreeInstance(fmu.component)


def case_fatal_history(host, other):
    """What used to be two fmi2Fatal answers and then a SIGSEGV: every call is survivable."""
    fmu = host.instance()
    restore(fmu, b"garbage")
    call("fmi2GetReal", fmu.getReal, [99999])
    call("fmi2SetReal", fmu.setReal, [host.first("output")], [1.0])
    call("fmi2Reset", fmu.reset)
    call("fmi2SetupExperiment", fmu.setupExperiment, startTime=0.0)
    call("fmi2EnterInitializationMode", fmu.enterInitializationMode)
    call("fmi2ExitInitializationMode", fmu.exitInitializationMode)
    for k in range(3):
        step(fmu, k * 1e-3)
    call("fmi2Terminate", fmu.terminate)
    fmu.fmi2FreeInstance(fmu.component)


def case_set_freed_state(host, other):
    """fmi2SetFMUstate with a handle fmi2FreeFMUstate freed (pythonfmu leaves it non-NULL)."""
    fmu = host.instance()
    step(fmu, 0.0)
    state = fmu.getFMUstate()
    step(fmu, 1e-3)
    call("fmi2FreeFMUstate", fmu.freeFMUstate, state)
    say("VALUE handle-null", not state)
    gc.collect()
    for _ in range(200):  # what the freed memory would be reused for
        fmu.freeFMUstate(fmu.getFMUstate())
    before = outputs(host, fmu)
    call("fmi2SetFMUstate", fmu.setFMUstate, state)
    size = ctypes.c_size_t()
    call("fmi2SerializedFMUstateSize", fmu.fmi2SerializedFMUstateSize, fmu.component, state,
         ctypes.byref(size))
    say("VALUE size", size.value)
    check_unchanged(host, fmu, before, 2e-3)


def case_free_state_twice(host, other):
    """fmi2FreeFMUstate twice on one handle, then on with the instance and exit."""
    fmu = host.instance()
    step(fmu, 0.0)
    state = fmu.getFMUstate()
    call("fmi2FreeFMUstate", fmu.freeFMUstate, state)
    call("fmi2FreeFMUstate", fmu.freeFMUstate, state)
    gc.collect()
    before = outputs(host, fmu)
    check_unchanged(host, fmu, before, 1e-3)
    call("fmi2Terminate", fmu.terminate)
    fmu.fmi2FreeInstance(fmu.component)


def case_set_null_state(host, other):
    """fmi2SetFMUstate(NULL), then a doStep."""
    fmu = host.instance()
    step(fmu, 0.0)
    call("fmi2SetFMUstate", fmu.fmi2SetFMUstate, fmu.component, None)
    say("VALUE set-null-done")
    step(fmu, 1e-3)
    say("VALUE step-done")


def case_size_null_state(host, other):
    """fmi2SerializedFMUstateSize(NULL)."""
    fmu = host.instance()
    step(fmu, 0.0)
    size = ctypes.c_size_t()
    call("fmi2SerializedFMUstateSize", fmu.fmi2SerializedFMUstateSize, fmu.component, None,
         ctypes.byref(size))
    say("VALUE size-null-done")
    step(fmu, 1e-3)
    say("VALUE step-done")


def case_free_null_state(host, other):
    """fmi2FreeFMUstate of a NULL handle: FMI 2.0 says ignored."""
    fmu = host.instance()
    step(fmu, 0.0)
    null = ctypes.c_void_p(None)
    call("fmi2FreeFMUstate", fmu.fmi2FreeFMUstate, fmu.component, ctypes.byref(null))
    before = outputs(host, fmu)
    check_unchanged(host, fmu, before, 1e-3)


def case_null_handles(host, other):
    """Every FMU-state call given a NULL state or a NULL pointer, then a doStep."""
    fmu = host.instance()
    step(fmu, 0.0)
    before = outputs(host, fmu)
    component, null = fmu.component, ctypes.c_void_p(None)
    size = ctypes.c_size_t()
    call("fmi2SetFMUstate", fmu.fmi2SetFMUstate, component, None)
    call("fmi2SerializedFMUstateSize", fmu.fmi2SerializedFMUstateSize, component, None,
         ctypes.byref(size))
    buffer = ctypes.create_string_buffer(64)
    call("fmi2SerializeFMUstate", fmu.fmi2SerializeFMUstate, component, None, buffer, 64)
    call("fmi2GetFMUstate", fmu.fmi2GetFMUstate, component, None)
    state = fmu.getFMUstate()
    call("fmi2SerializedFMUstateSize", fmu.fmi2SerializedFMUstateSize, component, state, None)
    call("fmi2SerializeFMUstate", fmu.fmi2SerializeFMUstate, component, state, None, 64)
    data = state_bytes(fmu)
    call("fmi2DeSerializeFMUstate", fmu.fmi2DeSerializeFMUstate, component, data, len(data),
         None)
    call("fmi2DeSerializeFMUstate", fmu.fmi2DeSerializeFMUstate, component, None, len(data),
         ctypes.byref(null))
    fmu.freeFMUstate(state)
    say("VALUE handle-null", not state)  # FMI 2.0: fmi2FreeFMUstate returns NULL in it
    check_unchanged(host, fmu, before, 1e-3)


def case_serialize_sizes(host, other):
    """fmi2SerializeFMUstate into an array one byte short, and one 8 bytes long."""
    fmu = host.instance()
    step(fmu, 0.0)
    state = fmu.getFMUstate()
    size = ctypes.c_size_t()
    call("fmi2SerializedFMUstateSize", fmu.fmi2SerializedFMUstateSize, fmu.component, state,
         ctypes.byref(size))
    n = size.value
    short = ctypes.create_string_buffer(b"\x55" * (n - 1), n - 1)
    call("fmi2SerializeFMUstate", fmu.fmi2SerializeFMUstate, fmu.component, state, short,
         n - 1)
    say("VALUE short-untouched", short.raw == b"\x55" * (n - 1))
    long = ctypes.create_string_buffer(b"\x55" * (n + 8), n + 8)
    call("fmi2SerializeFMUstate", fmu.fmi2SerializeFMUstate, fmu.component, state, long,
         n + 8)
    say("VALUE long-holds-the-state", long.raw[:n] == fmu.serializeFMUstate(state)
        and long.raw[n:] == b"\x55" * 8)
    before = outputs(host, fmu)
    fmu.freeFMUstate(state)
    check_unchanged(host, fmu, before, 1e-3)


def case_freed_instance(host, other):
    """fmi2FreeInstance twice, then a doStep and a getReal on the freed instance; then a new
    instance works."""
    fmu = host.instance()
    step(fmu, 0.0)
    component = fmu.component
    fmu.fmi2FreeInstance(component)
    say("VALUE first-free-done")
    fmu.fmi2FreeInstance(component)
    say("VALUE second-free-done")
    step(fmu, 1e-3)
    call("fmi2GetReal", fmu.getReal, [host.first("output")])
    call("fmi2SetFMUstate", fmu.fmi2SetFMUstate, None, None)  # a NULL instance
    gc.collect()
    again = host.instance("b")
    status, _ = step(again, 0.0)
    say("VALUE new-instance-steps", status)
    call("fmi2Terminate", again.terminate)
    again.fmi2FreeInstance(again.component)


def case_raising_state_calls(host, other):
    """A plain pythonfmu slave (tests/test_fmu_native.py's Raiser) whose state methods raise
    on demand (RAISE_IN): each call answers, and a doStep after it steps on."""
    fmu = host.instance()
    t = 0.0
    step(fmu, t)
    state = fmu.getFMUstate()
    data = fmu.serializeFMUstate(state)
    size = ctypes.c_size_t()
    buffer = ctypes.create_string_buffer(len(data))
    calls = {
        "get": ("fmi2GetFMUstate", lambda: fmu.getFMUstate()),
        "set": ("fmi2SetFMUstate", lambda: fmu.setFMUstate(state)),
        "time": ("fmi2SetFMUstate", lambda: fmu.setFMUstate(state)),
        "not-a-time": ("fmi2SetFMUstate", lambda: fmu.setFMUstate(state)),
        "size": ("fmi2SerializedFMUstateSize", lambda: fmu.fmi2SerializedFMUstateSize(
            fmu.component, state, ctypes.byref(size))),
        "serialize": ("fmi2SerializeFMUstate", lambda: fmu.fmi2SerializeFMUstate(
            fmu.component, state, buffer, len(data))),
        "deserialize": ("fmi2DeSerializeFMUstate", lambda: fmu.deSerializeFMUstate(data)),
    }
    for where, (name, function) in calls.items():
        os.environ["RAISE_IN"] = where
        call(name, function)
        os.environ["RAISE_IN"] = ""
        t += 1e-3
        status, _ = step(fmu, t)
        say(f"VALUE steps-after-{where}", status)
    fmu.freeFMUstate(state)
    call("fmi2Terminate", fmu.terminate)
    fmu.fmi2FreeInstance(fmu.component)


def case_raising_step(host, other):
    """A plain pythonfmu slave whose doStep raises: fmi2Fatal; the calls after it."""
    fmu = host.instance()
    os.environ["RAISE_IN"] = "do_step"
    step(fmu, 0.0)
    os.environ["RAISE_IN"] = ""
    step(fmu, 0.0)
    call("fmi2GetReal", fmu.getReal, [host.first("output")])
    call("fmi2Reset", fmu.reset)
    fmu.fmi2FreeInstance(fmu.component)
    say("VALUE freed")


def case_leak(host, other, cycles=1000, warmup=10):
    """RSS growth (MB) over `cycles` instantiate/initialize/step/terminate/free cycles."""
    import resource

    fmu = FMU2Slave(guid=host.md.guid, unzipDirectory=host.dir, instanceName="leak",
                    modelIdentifier=host.md.coSimulation.modelIdentifier)

    def rss():
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * resource.getpagesize() / 1e6

    def cycle():
        fmu.instantiate(loggingOn=False)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.doStep(0.0, 1e-3)
        fmu.terminate()
        fmu.fmi2FreeInstance(fmu.component)

    for _ in range(warmup):
        cycle()
    gc.collect()
    start = rss()
    marks = []
    for k in range(cycles):
        cycle()
        if (k + 1) % (cycles // 4) == 0:
            gc.collect()
            marks.append(rss() - start)
    say("VALUE leak-mb", " ".join(f"{m:.3f}" for m in marks))
    # core's pair-index cache (flexure.core.mechanics.assembly._PAIRS) in the bundled copy, if any:
    caches = [len(getattr(module, "_PAIRS", ())) for name, module in list(sys.modules.items())
              if name.endswith(".core.assembly")]
    say("VALUE core-pair-cache", sum(caches))
    say("VALUE sys.path", len(sys.path))


def case_free_releases(host, other):
    """What one instantiate/initialize/step/terminate/free cycle leaves for the cyclic garbage
    collector (nothing: the slave instance is freed by fmi2FreeInstance itself)."""
    import weakref

    fmu = FMU2Slave(guid=host.md.guid, unzipDirectory=host.dir, instanceName="free",
                    modelIdentifier=host.md.coSimulation.modelIdentifier)
    identifier = host.md.coSimulation.modelIdentifier
    for _ in range(2):  # the first cycle warms up
        gc.collect()
        gc.disable()  # from here on only reference counting frees anything
        fmu.instantiate(loggingOn=False)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.doStep(0.0, 1e-3)
        instances = [o for o in gc.get_objects()
                     if type(o).__name__ == identifier and not isinstance(o, type)]
        instance = weakref.ref(instances[0])
        count = len(instances)
        del instances
        fmu.terminate()
        fmu.fmi2FreeInstance(fmu.component)
        alive = instance() is not None
        garbage = gc.collect()
        gc.enable()
    say("VALUE instances", count)
    say("VALUE alive-after-free", alive)
    say("VALUE cyclic-garbage", garbage)


if __name__ == "__main__":
    case, path = sys.argv[1], sys.argv[2]
    other = Host(sys.argv[3]) if len(sys.argv) > 3 else None
    globals()[f"case_{case}"](Host(path), other)
    say("SURVIVED")
