"""The host of the FMU abuse cases (fmu_abuse_cases.py): a scene FMU loaded by fmpy, each FMI
call printed with its status, each message the FMU logs printed as it comes.

It prints one line per event: "CALL <function> -> <status>" for each FMI call made through
`call`, "LOG <status> <message>" for each message the FMU logs, and "VALUE ..." (`say`) for
what a case observed.
"""

import ctypes
import os

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

STATUS = ["OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING"]


def say(*parts):
    print(*parts, flush=True)


def _logger(environment, name, status, category, message):
    say("LOG", status, message.decode(errors="replace").replace("%%", "%").replace("\n", " | "))


_LOGGER = fmi2CallbackLoggerTYPE(_logger)
_CALLOC = ctypes.CDLL(None).calloc
_CALLOC.restype, _CALLOC.argtypes = ctypes.c_void_p, [ctypes.c_size_t, ctypes.c_size_t]
_FREE = ctypes.CDLL(None).free
_FREE.argtypes = [ctypes.c_void_p]
_ALLOCATE = fmi2CallbackAllocateMemoryTYPE(lambda n, size: _CALLOC(n, size))
_RELEASE = fmi2CallbackFreeMemoryTYPE(lambda p: _FREE(p))


class Host:
    """One FMU loaded by fmpy; `instance(name)` instantiates (logging on, all messages)."""

    def __init__(self, path):
        self.md = read_model_description(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.causality = {v.name: v.causality for v in self.md.modelVariables}
        self.dir = path if os.path.isdir(path) else extract(path)

    def instance(self, name="a", *, initialize=True):
        fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir, instanceName=name,
                        modelIdentifier=self.md.coSimulation.modelIdentifier)
        callbacks = fmi2CallbackFunctions()
        callbacks.logger, callbacks.allocateMemory = _LOGGER, _ALLOCATE
        callbacks.freeMemory = _RELEASE
        fmu._keep_callbacks = callbacks
        fmu.instantiate(callbacks=callbacks, loggingOn=True)
        if initialize:
            call("fmi2SetupExperiment", fmu.setupExperiment, startTime=0.0)
            call("fmi2EnterInitializationMode", fmu.enterInitializationMode)
            call("fmi2ExitInitializationMode", fmu.exitInitializationMode)
        return fmu

    def first(self, causality):
        return next(self.vr[n] for n, c in self.causality.items() if c == causality)


def call(name, function, *args, **kwargs):
    """Call an FMI function through fmpy; print and return its status name (and result)."""
    try:
        result = function(*args, **kwargs)
        status = "OK"
    except FMICallException as error:
        result, status = None, STATUS[error.status]
    say("CALL", name, "->", status)
    return status, result


def step(fmu, t, h=1e-3):
    return call("fmi2DoStep", fmu.doStep, currentCommunicationPoint=t, communicationStepSize=h)


def restore(fmu, data):
    """Deserialize bytes into a state and set it: the path a crafted or damaged file takes."""
    _, state = call("fmi2DeSerializeFMUstate", fmu.deSerializeFMUstate, data)
    if state is not None:
        call("fmi2SetFMUstate", fmu.setFMUstate, state)
        call("fmi2FreeFMUstate", fmu.freeFMUstate, state)


def outputs(host, fmu):
    names = [n for n, c in host.causality.items() if c == "output"]
    return call("fmi2GetReal", fmu.getReal, [host.vr[n] for n in names])[1]


def state_bytes(fmu):
    state = fmu.getFMUstate()
    data = fmu.serializeFMUstate(state)
    fmu.freeFMUstate(state)
    return data


def check_unchanged(host, fmu, before, t):
    """The instance goes on as if the refused call never happened."""
    after = outputs(host, fmu)
    say("VALUE unchanged", after == before)
    status, _ = step(fmu, t)
    say("VALUE steps-on", status)


# -- the cases ---------------------------------------------------------------------------------
