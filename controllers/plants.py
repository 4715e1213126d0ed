"""Plants of the closed-loop runner: the same tiny interface around three simulators.

    plant.reset() -> outputs at t0;  plant.set_input(u);  plant.advance(t_end);
    plant.output() -> outputs (n_outputs,);  plant.close()

- `InProcessPlant`: flexure.core's Simulator in this process.
- `LinearPlant`: flexure.core's LinearSimulator, the linearised model stepped exactly.
- `FmuPlant`: the scene's co-simulation FMU (flexure.fmu.build_scene_fmu) stepped by fmpy.

InProcessPlant and FmuPlant integrate the same nonlinear model with the same integrator and
tolerances (the FMU runs flexure's Simulator too, from its bundled copy of the same sources);
all three hold the input over each step, so for the same inputs the two nonlinear plants give
the same outputs to within the integrator's tolerance, and the linear plant what the
linearisation does. The loop's fourth plant, the controller FMU and the scene FMU connected in
libcosim, is a whole co-simulation rather than a plant; it lives in `cosim.py`.
"""

import shutil
import tempfile
from pathlib import Path

import numpy as np

from flexure.core import SimulationError
from flexure.core.simulation.methods import LOOP_METHOD, LOOP_RTOL


class SimulatorPlant:
    """A plant around a simulator with flexure.core.Simulator's interface (`reset`,
    `set_inputs`, `advance`, `outputs`), in this process."""

    def __init__(self, model, simulator):
        self.model = model
        self.simulator = simulator
        self.input_names = list(simulator.input_names)
        self.output_names = list(simulator.output_names)

    def reset(self):
        self.simulator.reset(t0=0.0)
        return self.output()

    def set_input(self, u):
        self.simulator.set_inputs(u)

    def advance(self, t_end):
        self.simulator.advance_to(t_end)

    def output(self):
        return np.asarray(self.simulator.outputs(), float)

    def close(self):
        pass


class InProcessPlant(SimulatorPlant):
    """The scene's nonlinear model integrated by flexure.core.Simulator in this process; its
    kinematic inputs, if any, move along the scene's quintic in `motion_duration` s from
    t = 0 (`Simulator(..., motion_duration=)`)."""

    kind = "inprocess"

    def __init__(self, model, *, method=LOOP_METHOD, rtol=LOOP_RTOL, motion_duration=None):
        from flexure.core import Simulator  # the models (numba, scipy) on first use

        super().__init__(model, Simulator(model, method=method, rtol=rtol,
                                          motion_duration=motion_duration))

    @property
    def statistics(self):
        return self.simulator.statistics

    def close(self):
        self.simulator.close()  # its solver's memory now, not when the collector finds it


class LinearPlant(SimulatorPlant):
    """The scene's linearisation stepped exactly by flexure.core.LinearSimulator: it starts
    where InProcessPlant starts and takes and gives the same absolute inputs and outputs
    (LinearSimulator says to what order off the DOFs).

    Parameters
    ----------
    model : Model
    linear_model : LinearModel, optional
        The linearisation (default: at the static equilibrium under the scene's loads).
    """

    kind = "linear"

    def __init__(self, model, *, linear_model=None):
        from flexure.core import LinearSimulator  # scipy on first use

        super().__init__(model, LinearSimulator(model, linear_model=linear_model))


class FmuPlant:
    """A scene FMU (co-simulation, FMI 2.0) stepped by fmpy with the held input.

    Parameters
    ----------
    fmu_path : str or Path
        The scene's FMU (`flexure.fmu.build_scene_fmu`).
    method, rtol : str, float
        Set on the FMU's parameters "integrator.method" and "integrator.rtol".
    inputs, outputs : list of str, optional
        The ports, by name, in the order `set_input` takes and `output` gives them (the
        model's `inputs` and `outputs`, so that a loop's port indices hold on the FMU too);
        default: every input and output of the FMU in its model description's order.
        SimulationError names a port the FMU lacks.
    """

    kind = "fmu"

    def __init__(self, fmu_path, *, method=LOOP_METHOD, rtol=LOOP_RTOL, inputs=None,
                 outputs=None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.path = Path(fmu_path)
        md = read_model_description(str(self.path))
        variables = {v.name: v for v in md.modelVariables}
        self.input_names = _ports(self.path, md, "input", inputs)
        self.output_names = _ports(self.path, md, "output", outputs)
        self._in = [variables[n].valueReference for n in self.input_names]
        self._out = [variables[n].valueReference for n in self.output_names]
        self._dir = extract(str(self.path), unzipdir=tempfile.mkdtemp(prefix="flexure_plant_"))
        self._fmu = FMU2Slave(guid=md.guid, unzipDirectory=self._dir,
                              modelIdentifier=md.coSimulation.modelIdentifier,
                              instanceName="plant")
        self._fmu.instantiate(loggingOn=False)
        self._method_vr = variables["integrator.method"].valueReference
        self._rtol_vr = variables["integrator.rtol"].valueReference
        self._settings = (method, float(rtol))
        self._initialized = False
        self.time = 0.0

    def reset(self):
        from fmpy.fmi1 import FMICallException

        if self._initialized:
            self._fmu.reset()
        method, rtol = self._settings
        try:
            self._fmu.setupExperiment(startTime=0.0)
            self._fmu.enterInitializationMode()
            self._fmu.setString([self._method_vr], [method])
            self._fmu.setReal([self._rtol_vr], [rtol])
            self._fmu.exitInitializationMode()
        except FMICallException as error:
            raise SimulationError(f"{self.path}: initialization failed: {error}") from None
        self._initialized = True
        self.time = 0.0
        return self.output()

    def set_input(self, u):
        self._fmu.setReal(self._in, [float(v) for v in np.atleast_1d(u)])

    def advance(self, t_end):
        from fmpy.fmi1 import FMICallException

        try:
            self._fmu.doStep(currentCommunicationPoint=self.time,
                             communicationStepSize=t_end - self.time)
        except FMICallException as error:
            raise SimulationError(f"{self.path}: doStep at t = {self.time:.9g} s failed: "
                                  f"{error}") from None
        self.time = t_end

    def output(self):
        return np.asarray(self._fmu.getReal(self._out), float)

    def close(self):
        if self._fmu is not None:
            try:
                self._fmu.terminate()
            finally:
                self._fmu.freeInstance()
                self._fmu = None
                shutil.rmtree(self._dir, ignore_errors=True)

    def __del__(self):  # pragma: no cover - a safety net; close() is the normal way
        try:
            self.close()
        except Exception:  # noqa: BLE001
            pass


def _ports(path, md, causality, names):
    """The FMU's variables of `causality` named `names` (all of them if None), checked."""
    present = [v.name for v in md.modelVariables if v.causality == causality]
    if names is None:
        return present
    missing = [name for name in names if name not in present]
    if missing:
        raise SimulationError(f"{path}: the FMU has no {causality} {missing[0]!r}; its "
                              f"{causality}s are {', '.join(present) or 'none'}")
    return list(names)
