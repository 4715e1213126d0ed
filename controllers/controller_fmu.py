"""The closed-loop controller as an FMI 2.0 co-simulation FMU (pythonfmu, flexure.fmu glue).

The slave runs the very `LoopController` of the in-process loop (loop_controller.py), configured by
the dictionary `LoopController.to_dict()` embedded in the generated script, so it computes the
same numbers. Variables, per loop (named after the plant's ports so that connections read
plainly):

- input  `<output>` (m, or rad on an angle): the measured position y, e.g. "x";
- output `<input>` (N, N m on an angle, or V where a voice coil's drive signal is the plant's
  input): the force u, e.g. "F";
- outputs `<output>_reference` and `<output>_error` (as y): r_k and e_k = r_k - y_k.

Each variable carries the unit of the plant's port it connects to.

Timing: a doStep over [t_k, t_k+1] (t_k = k / fs, the step must be exactly 1 / fs) reads y_k
and sets the force output to u_k+1 = C e_k + u_ff,k+1, the force for the next interval. A
master that transfers values once per macro step (libcosim) then applies u_k+1 on
[t_k+1, t_k+2): the one-sample computation delay the feedback design assumes. Before the first
step the force output is u_0 = u_ff,0.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from pythonfmu import DefaultExperiment

from flexure.core import FlexureError
from flexure.fmu.slave import SafeSlave

from .loop_controller import LoopController

if TYPE_CHECKING:  # names for the annotations only
    from flexure.core import Model

    from .feedback import FeedbackDesign


class ControllerStepError(FlexureError, ValueError):
    """The master stepped the controller FMU off its sample grid."""


class ControllerSlave(SafeSlave):
    """Base of a generated controller slave; subclasses set `config_json`."""

    config_json = "{}"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=2.5e-4)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.author = "flexure"
        self.description = "flexure closed-loop controller: PID-like feedback + feedforward"
        data = json.loads(self.config_json)
        self.loop = LoopController.from_dict(data)
        self.names = [tuple(pair) for pair in data["loops"]]  # (input name, output name)
        n = len(self.names)
        units = [tuple(pair) for pair in data["units"]]  # the plant's: (input, output)
        self.y = self.loop.offsets.copy()
        self.u = self.loop.initial_output()
        self.r = self.loop.reference[0].copy()
        self.e = np.zeros(n)
        for i, ((force, position), (force_unit, unit)) in enumerate(
                zip(self.names, units, strict=True)):
            self.add_real(position, causality="input", unit=unit, start=float(self.y[i]),
                          description=f"measured position of loop {i}",
                          getter=lambda i=i: float(self.y[i]),
                          setter=lambda value, i=i: self.y.__setitem__(i, value))
            self.add_real(force, causality="output", unit=force_unit,
                          description=f"force of loop {i}, for the next sample interval",
                          getter=lambda i=i: float(self.u[i]))
            self.add_real(f"{position}_reference", causality="output", unit=unit,
                          description=f"reference of loop {i} at the last step's start",
                          getter=lambda i=i: float(self.r[i]))
            self.add_real(f"{position}_error", causality="output", unit=unit,
                          description=f"tracking error of loop {i} at the last step's start",
                          getter=lambda i=i: float(self.e[i]))

    def initialize(self, start_time):
        self.loop.reset()
        self.u = self.loop.initial_output()

    def advance(self, t, h):
        fs = self.loop.fs
        k = int(round((t - self.start_time) * fs))
        if abs(h * fs - 1.0) > 1e-6 or abs((t - self.start_time) * fs - k) > 1e-6:
            raise ControllerStepError(
                f"the controller samples at {fs:g} Hz: expected a step of {1 / fs:.9g} s "
                f"from a sample time, got t = {t!r} s, h = {h!r} s")
        self.r = self.loop.reference[min(k, self.loop.samples)].copy()
        self.u, self.e = self.loop.step(k, self.y)

    def save_state(self):
        return {"x": self.loop.controller.x.copy(), "u": self.u.copy(), "r": self.r.copy(),
                "e": self.e.copy()}

    def load_state(self, state):
        self.loop.controller.x = np.array(state["x"], float)
        self.u, self.r, self.e = (np.array(state[k], float) for k in ("u", "r", "e"))


def controller_config(controller, design, model):
    """The JSON-able dictionary a controller FMU is generated from."""
    data = controller.to_dict()
    data["loops"] = [(p.input_name, p.output_name) for p in design.pairs]
    # each loop's units as the plant's ports have them: N or N m, or V where a voice coil's
    # drive signal is the input; m or rad
    data["units"] = [(model.inputs[p.input_index].unit, model.outputs[p.output_index].unit)
                     for p in design.pairs]
    data["scene"] = model.name
    return data


def build_controller_fmu(controller: LoopController, design: FeedbackDesign, model: Model,
                         dest: str | Path) -> Path:
    """Build the controller FMU of a designed loop; returns its path.

    `dest` is the .fmu file (or a folder for `flexure_controller.fmu`). The script is named
    after a digest of the configuration so FMUs of different designs do not share a module.
    """
    # the builder is not part of the bundle inside an FMU, which imports this module too
    from flexure.fmu import build_slave_fmu

    config = json.dumps(controller_config(controller, design, model), sort_keys=True)
    digest = hashlib.sha256(config.encode()).hexdigest()[:10]
    script = (
        '"""Controller FMU of a flexure closed loop (generated by flexure loop)."""\n\n'
        "from flexure.controllers.controller_fmu import ControllerSlave\n\n\n"
        "class flexure_controller(ControllerSlave):\n"
        f"    config_json = {config!r}\n"
    )
    with tempfile.TemporaryDirectory(prefix="flexure_ctrl_") as temp:
        path = Path(temp) / f"flexure_controller_{digest}.py"
        path.write_text(script)
        return build_slave_fmu(path, dest, bundle=("core", "fmu", "controllers"))
