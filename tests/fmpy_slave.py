"""The host side of the scene FMU tests: `Slave`, an FMU loaded by fmpy's FMU2Slave with a
capturing logger, initialised and ready to step; the built-in scenes whose FMUs they test
(`SCENES`); a variable communication grid with its inputs. Each scene's FMU is built once
per session by the `scene_fmus` fixture (conftest.py)."""

import shutil

import numpy as np
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from flexure.core import builtin_scenes

# the manipulator's scenes (hundreds of DOFs, one refused by design): tests/test_manipulator.py
SCENES = [name for name in builtin_scenes() if not name.startswith("manipulator")]


def do_step(slave, t, h=1e-3):
    """fmi2DoStep's status: 0 OK, 2 Discard (fmpy raises on any status but OK)."""
    try:
        slave.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        return 0
    except FMICallException as error:
        return error.status


class Slave:
    """An FMU2Slave with a capturing logger, initialised and ready to step."""

    def __init__(self, path, instance_name="a", *, parameters=None, strings=None,
                 integers=None):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.outputs = [v.name for v in self.md.modelVariables if v.causality == "output"]
        self.inputs = [v.name for v in self.md.modelVariables if v.causality == "input"]
        self.dir = extract(str(path))
        self.logs = []
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._callbacks = callbacks
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=instance_name)
        self.fmu.instantiate(callbacks=callbacks, loggingOn=True)
        self.initialize(parameters, strings, integers)

    def _log(self, environment, name, status, category, message):
        self.logs.append((status, message.decode().replace("%%", "%")))

    def initialize(self, parameters=None, strings=None, integers=None):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in (parameters or {}).items():
            self.fmu.setReal([self.vr[name]], [value])
        for name, value in (integers or {}).items():
            self.fmu.setInteger([self.vr[name]], [value])
        for name, value in (strings or {}).items():
            self.fmu.setString([self.vr[name]], [value])
        self.fmu.exitInitializationMode()

    def set(self, u):
        self.fmu.setReal([self.vr[n] for n in self.inputs], list(np.atleast_1d(u)))

    def y(self):
        return np.array(self.fmu.getReal([self.vr[n] for n in self.outputs]))

    def step(self, t, h):
        self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        return self.y()

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def grid_and_inputs():
    """A variable communication grid (s) and the force held over each step (N)."""
    steps = np.array([1e-3, 2.5e-3, 0.4e-3, 1.7e-3, 3e-3, 0.9e-3, 1e-3, 2e-3] * 3)
    times = np.concatenate([[0.0], np.cumsum(steps)])
    forces = 0.5 * np.sin(2 * np.pi * 40 * times[:-1]) + 0.2
    return times, forces
