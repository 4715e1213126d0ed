"""The co-simulation slave of a scene: its variables, and a do_step that is one core call.

A generated script (see `flexure.fmu.builder.build_scene_fmu`) subclasses `SceneSlave` with
the scene's TOML text and the scene keys a user may tune:

    class stage_planar_3dof(SceneSlave):
        scene_toml = '''...'''
        tunable = ("sections.leaf.EdA", "sections.leaf.EdI")

Variables (only what the scene has):

- one input per scene input (force N or moment N.m, start 0; a moment about a global axis of
  a 3-D rotational node too), held over each step; an input a voice-coil actuator drives is
  its amplifier's drive signal (V);
- one input per kinematic input ([inputs.NAME] kind = "motion"; m, rad on an angle, start
  the scene's `start`): the position at the end of each step (set before fmi2DoStep; set in
  initialization mode, where it starts), which the simulator makes a smooth path
  (`flexure.core.simulation.stepwise_motion`); and one output "NAME.effort" (N, N.m on an
  angle): the generalised force that realises it in the current state;
- one output per scene output (its quantity's unit: position m / rad, velocity m/s / rad/s,
  ...: `flexure.core.mechanics.output_quantities`; about a global axis of a 3-D rotational
  node the angle, rad, or its rates), then one per
  output on an element (SPACAR's OUTE, OUTF): its deformation (m) or its stress resultant
  (N, S e + D edot with the viscous term; a prescribed deformation's is minus its effort, a
  rigid one's its reaction: `flexure.core.simulation.element_readings`), all updated after
  every step;
- one output "NAME.current" (A) per voltage-driven actuator [actuators.NAME]: its coil
  current, a state of the FMU;
- on request (`von_mises = True`), the output "von_mises_max" (Pa): the largest von Mises
  stress at the ends of the scene's beams with a cross-section, in the current state
  (`flexure.core.stresses_along`), computed when a host reads it and at most once per state:
  it costs about ten times a doStep of the model (the wire tripod), so a host that steps
  without reading it pays nothing for it;
- parameters "integrator.method" (String: esdirk (default), esdirk3, cvode-bdf, cvode-adams,
  ida; the one-step esdirk takes a host's new inputs at each doStep without a restart),
  "integrator.rtol" (1, default 1e-6), "integrator.atol" (0 means the simulator's default) and
  "integrator.max_steps" (Integer: the step budget of one doStep, beyond which it answers
  fmi2Discard);
- one parameter per tunable scene key, named by its key ("sections.leaf.EdA", N.s), applied
  by rebuilding the model from the scene with the new value when initialization ends.

`advance(t, h)` is `simulator.set_inputs(u); simulator.advance_to(t + h)` (with kinematic
inputs `simulator.move_to(positions, t + h)` in place of advance_to): the simulator picks its
own internal steps; any h works. A `SimulationError` (non-finite input, integrator or Newton
failure) leaves the simulator at its last good state and the step is answered with
fmi2Discard (see `SafeSlave`). The FMU state is the simulator's whole state plus the inputs
and parameters, stored as data (`flexure.fmu.state_format`); what follows from it (outputs,
coil currents, stress) is computed again on a restore, and a restored state is range-checked
(`restored_state_problem`) as a host's values are. Its identity is the scene
name and a digest of the embedded scene text, tunable keys and outputs, so a state of another
scene (or of the same scene built from another scene file) is refused by name.

Values a host sets are checked when set (`check_value`): the method must be one of METHODS,
0 < rtol < 1, atol >= 0 (finite), a tunable damping (EdA, cx, ...) >= 0 and any other tunable
value > 0, all finite (every method integrates kinematic inputs). A refused value puts the
instance in the error state (see `SafeSlave`). A tunable key's unit, and whether it is a
damping, are its schema's (`flexure.core.scene.building.scene_key`: the element section
schemas, the node keys and the actuators').
"""


import copy
import math
import tomllib
from dataclasses import replace
from functools import partial

import numpy as np
from pythonfmu import DefaultExperiment
from pythonfmu.enums import Fmi2Status

from flexure.core import (
    Mechanics,
    Simulator,
    build_model,
    mechanism_size,
    port_description,
    stresses_along,
)
from flexure.core.numerics.jit import compile_notices
from flexure.core.scene.building import scene_key
from flexure.core.simulation.methods import METHODS as CORE_METHODS
from flexure.core.simulation.methods import ONE_STEP_METHODS
from flexure.core.simulation.simulation import effort_unit

from .slave import SafeSlave
from .slave_states import STEP_COMPLETE, TERMINATED

# The first is the default, with DEFAULT_RTOL. A host changes the inputs at most doSteps, and
# the one-step esdirk takes a change without a restart (CVODE restarts at order 1). With the
# inputs held too it is the faster at this tolerance: stage_planar_3dof, 1 N held, 1 ms doSteps
# for 1 s, in process (docs/decisions.md): esdirk at rtol 1e-6 0.062 s, error 3.1e-6 of the
# motion; CVODE BDF at rtol 1e-6 or 1e-8 about 0.2 s (its high orders are unstable beside the
# stage's lightly damped 2.1 and 3.6 kHz modes, so it takes ~50 steps per ms at any
# tolerance), error 6e-9. A host that wants the smaller error sets the method and rtol.
# Every registered method (flexure.core.simulation.methods), the one-step ones first.
METHODS = (*ONE_STEP_METHODS, *(name for name in CORE_METHODS if name not in ONE_STEP_METHODS))
DEFAULT_RTOL = 1e-6
# a doStep's step budget: far above a normal step (the 3-DOF stage with CVODE: about 50 steps
# per ms, 50 000 for a 1 s doStep), far below a runaway (a 1e9 N input took 80 s)
DEFAULT_MAX_STEPS = 200_000
# How far a restored state's nodes may be from their start, in times the mechanism's size
# (`flexure.core.mechanism_size`): 400 times the range of validity (a quarter of that size), so
# a run that went beyond that range with a warning still restores, and a forged 1e300 m does
# not; the same size at every scale (a MEMS model's too).
RESTORE_DISTANCE = 100.0


def scene_value(scene, key):
    """The value at a dotted scene key ("sections.leaf.EdA"); KeyError if absent."""
    node = scene
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            raise KeyError(key)
        node = node[part]
    return node


def set_scene_value(scene, key, value):
    """Set the value at a dotted scene key in place."""
    *path, last = key.split(".")
    node = scene
    for part in path:
        node = node[part]
    node[last] = value


class SceneSlave(SafeSlave):
    """Base class of a scene's slave; subclasses set `scene_toml` and `tunable`."""

    scene_toml = ""
    tunable = ()
    von_mises = False  # report the largest von Mises stress as the output "von_mises_max"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.0, step_size=1e-3)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.scene = tomllib.loads(self.scene_toml)
        header = self.scene.get("scene", {})
        self.scene_name = header.get("name", type(self).__name__)
        self.description = header.get("description", f"flexure scene {self.scene_name}")
        self.author = "flexure"
        self.method = METHODS[0]
        self.rtol = DEFAULT_RTOL
        self.atol = 0.0
        self.max_steps = DEFAULT_MAX_STEPS
        self._warned = set()  # the kinds of range warning already logged
        self.parameters = {key: float(scene_value(self.scene, key)) for key in self.tunable}
        self.simulator = None
        # the first model built in a process loads the compiled engine, or compiles it for a
        # minute: the host's log says so then, and again when it is done
        with compile_notices(partial(self.warn_host, kwargs)):
            self._build()
        model = self._model
        # What the getters and setters read and write, lists of floats kept for the life of
        # the instance (a variable's getter and setter are that list's own item access, the
        # cheapest call there is): the inputs the host set (N, N m or V), held from the next
        # doStep on; the outputs and coil currents of the current state (`_refresh`).
        self.inputs = [0.0] * len(model.inputs)
        self.outputs = [math.nan] * len(self.simulator.output_names)
        self.currents = [math.nan] * len(model.coil_actuators)
        # the kinematic inputs' positions (m, rad) the host set: where each is at the end of
        # the next step (where it starts, before the first); their efforts (N, N.m) now
        self.motions = ([float(v) for v in model.motion_starts] if model.kinematic_inputs
                        else [])
        self.efforts = [math.nan] * len(model.kinematic_inputs)
        self.unchecked_inputs = frozenset(port.name for port in
                                          [*model.inputs, *model.kinematic_inputs])
        self._stress = None  # Pa, von_mises_max of the current state, None until read
        self.stress_evaluations = 0  # how often it was computed (each costs ~10 doSteps)
        self._refresh()

        drivers = {a.input: a for a in model.actuators}
        for i, port in enumerate(model.inputs):
            description = port_description(model, port, is_input=True)
            if i in drivers:  # the port's own force or moment, which the actuator's acts as
                acting = port_description(model, replace(port, quantity="force"), is_input=True)
                description = (f"drive signal of actuator {drivers[i].name} ({drivers[i].drive} "
                               f"amplifier) of the {acting}")
            self.add_real(port.name, causality="input", unit=port.unit, start=0.0,
                          description=description,
                          getter=partial(self.inputs.__getitem__, i),
                          setter=partial(self.inputs.__setitem__, i))
        for i, port in enumerate(model.kinematic_inputs):
            self.add_real(port.name, causality="input", unit=port.unit,
                          start=self.motions[i],
                          description=f"kinematic input: the {motion_description(model, port)} "
                                      "at the end of each step (set in initialization mode: "
                                      "where it starts)",
                          getter=partial(self.motions.__getitem__, i),
                          setter=partial(self.motions.__setitem__, i))
        for j, port in enumerate([*model.outputs, *model.element_outputs]):
            self.add_real(port.name, causality="output", unit=port.unit,
                          description=port_description(model, port, is_input=False),
                          getter=partial(self.outputs.__getitem__, j))
        for i, port in enumerate(model.kinematic_inputs):
            self.add_real(f"{port.name}.effort", causality="output",
                          unit=effort_unit(port).replace(" ", "."),
                          description=f"effort of kinematic input {port.name}: the "
                                      "generalised force that realises it",
                          getter=partial(self.efforts.__getitem__, i))
        for k, actuator in enumerate(model.coil_actuators):
            self.add_real(f"{actuator.name}.current", causality="output", unit="A",
                          description=f"coil current of actuator {actuator.name}",
                          getter=partial(self.currents.__getitem__, k))
        if self.von_mises:
            self.add_real("von_mises_max", causality="output", unit="Pa",
                          description="largest von Mises stress at the ends of the beams",
                          getter=self.von_mises_max)
        self.add_string("integrator.method", start=self.method,
                        description="integration method: " + ", ".join(METHODS),
                        getter=lambda: self.method,
                        setter=lambda value: setattr(self, "method", str(value)))
        self.add_real("integrator.rtol", causality="parameter", unit="1", start=self.rtol,
                      description="relative tolerance of the integrator",
                      getter=lambda: self.rtol,
                      setter=lambda value: setattr(self, "rtol", value))
        # unit "1": one number compared with every state in that state's SI unit (m, rad,
        # m/s, rad/s, A for a coil current); FMI 2.0 has no unit for such a mix
        self.add_real("integrator.atol", causality="parameter", unit="1", start=self.atol,
                      description="absolute tolerance on q and qdot (and the coil currents), "
                                  "each in its SI unit (0: the simulator's default, scaled "
                                  "from rtol)",
                      getter=lambda: self.atol,
                      setter=lambda value: setattr(self, "atol", value))
        self.add_integer("integrator.max_steps", start=self.max_steps,
                         description="step budget of one doStep: more integrator steps answer "
                                     "fmi2Discard (a normal step takes tens to thousands)",
                         getter=lambda: self.max_steps,
                         setter=lambda value: setattr(self, "max_steps", int(value)))
        for key in self.tunable:
            schema = scene_key(key, model)
            self.add_real(key, causality="parameter",
                          unit=schema.unit if schema is not None else None,
                          start=self.parameters[key], description=f"scene key {key}",
                          getter=lambda key=key: self.parameters[key],
                          setter=lambda value, key=key: self.parameters.__setitem__(key, value))

    @classmethod
    def identity_text(cls):
        return f"{cls.__name__}\0{cls.scene_toml}\0{tuple(cls.tunable)!r}\0{cls.von_mises!r}"

    def check_value(self, name, value):
        if name == "integrator.method":
            if value not in METHODS:
                return f"integrator.method = {value!r}: expected one of {', '.join(METHODS)}"
            return None
        if name == "integrator.rtol":
            if not (math.isfinite(value) and 0.0 < value < 1.0):
                return f"integrator.rtol = {value!r}: expected a finite number in (0, 1)"
        elif name == "integrator.max_steps":
            if not (isinstance(value, int) and 1 <= value <= 10**9):
                return f"integrator.max_steps = {value!r}: expected an integer from 1 to 1e9"
        elif name == "integrator.atol":
            if not (math.isfinite(value) and value >= 0.0):
                return (f"integrator.atol = {value!r}: expected a finite number >= 0 (0: the "
                        "simulator's default)")
        elif name in self.parameters:
            schema = scene_key(name, self._model)
            damping = schema is not None and schema.damping
            if not (math.isfinite(value) and (value >= 0.0 if damping else value > 0.0)):
                return (f"{name} = {value!r}: expected a finite number "
                        f"{'>= 0' if damping else '> 0'}")
        return None

    # -- the model -----------------------------------------------------------------------------

    def _settings(self):
        return (self.method, float(self.rtol), float(self.atol),
                tuple(sorted(self.parameters.items())))

    def _build(self):
        """(Re)build the model and the simulator from the scene and the parameters."""
        scene = copy.deepcopy(self.scene)
        for key, value in self.parameters.items():
            set_scene_value(scene, key, float(value))
        self._model = build_model(scene, source=f"{self.scene_name}.fmu (embedded scene)",
                                  default_name=self.scene_name)
        self.simulator = Simulator(self._model, method=self.method, rtol=float(self.rtol),
                                   atol=float(self.atol) if self.atol > 0 else None,
                                   stepwise_motion=bool(self._model.kinematic_inputs))
        self.simulator.reset(t0=self.start_time)
        self._mechanics = Mechanics(self._model) if self.von_mises else None
        self._built_with = self._settings()
        self._inputs_given = None  # the inputs the simulator holds: none of the host's yet

    def _refresh(self):
        """Read the outputs, coil currents (and the stress) of the simulator's current state
        into the lists the getters read."""
        self.outputs[:] = self.simulator.output_values()
        if self.currents:  # a model without coils has no currents to copy
            self.currents[:] = self.simulator.currents.tolist()
        if self.efforts:
            self.efforts[:] = self.simulator.efforts().tolist()
        self._stress = None  # of the state before: computed again when next read

    def von_mises_max(self):
        """The output von_mises_max: the largest von Mises stress at the beam ends in the
        current state, computed on the first read after a change of state.

        Returns
        -------
        float
            Pa; NaN when it cannot be computed (logged at status error once per state: a
            getter that raised would be fmi2Fatal).
        """
        if self._stress is None:
            try:
                # the inputs the state was reached with: those the simulator holds
                state = np.concatenate([self.simulator.q, self.simulator.qdot, self.currents])
                # a kinematic input's acceleration, which the state does not hold: its path's
                moved = ([self.simulator.prescribed_values()[2]]
                         if self._model.kinematic_inputs else None)
                _, stresses = stresses_along(self._model, [state],
                                             inputs=[self.simulator.inputs],
                                             prescribed_accelerations=moved,
                                             mechanics=self._mechanics)
                self._stress = float(np.nanmax(stresses))
            except Exception as error:  # noqa: BLE001
                self._stress = math.nan
                self._error(f"von_mises_max at t = {self.time!r} s: {error}")
            self.stress_evaluations += 1
        return self._stress

    def initialize(self, start_time):
        if self._settings() != self._built_with:
            self._build()
        if self.motions:  # where the host put them in initialization mode
            self.simulator.hold_motion(self.motions)
        self.simulator.reset(t0=start_time)
        self._inputs_given = None
        self._refresh()

    def advance(self, t, h):
        # a host sets every input before every doStep, mostly to the value held already; the
        # simulator refuses a non-finite one here, and then again at every doStep until the
        # host sets a finite value (`_inputs_given` is kept only once the simulator took it)
        if self.inputs != self._inputs_given:
            self.simulator.set_inputs(self.inputs)
            self._inputs_given = self.inputs.copy()
        if self.motions:  # the positions at t + h, made a path by the simulator
            self.simulator.move_to(self.motions, t + h, max_steps=self.max_steps)
        else:
            self.simulator.advance_to(t + h, max_steps=self.max_steps)
        self._refresh()
        warnings = self.simulator.range_warnings()  # empty within the range
        if warnings:
            self._warn_once(t + h, warnings)

    def _warn_once(self, t, warnings):
        """Log each kind of range warning the first time it occurs (t in s)."""
        for kind, message in warnings.items():
            if kind not in self._warned:
                self._warned.add(kind)
                self.log_message(f"{self.instance_name}: t = {t:.9g} s: {message}",
                                 Fmi2Status.warning)

    def last_good_time(self):
        self._refresh()
        return self.simulator.time

    # -- state ---------------------------------------------------------------------------------

    def save_state(self):
        # what follows from the simulator's state (the outputs, the coil currents, the
        # stress) is not stored: a restore computes it again, so no state can set it apart
        return {"settings": self._built_with, "simulator": self.simulator.get_state()}

    def load_state(self, state):
        settings = self._checked_state(state)
        method, rtol, atol, parameters = settings
        self.method, self.rtol, self.atol = method, rtol, atol
        self.parameters = dict(parameters)
        if self._built_with != settings:
            self._build()
        self.simulator.set_state(state["simulator"])  # sizes, model, finite: core checks
        self._inputs_given = None
        self._refresh()  # raises when the kinematics cannot be solved at the state
        problem = restored_state_problem(self, state["simulator"])
        if problem:
            raise ValueError(problem)

    def _checked_state(self, state):
        """The settings of a decoded model state; ValueError naming what does not fit."""
        if not isinstance(state, dict) or set(state) != {"settings", "simulator"}:
            raise ValueError("the model part is not a scene slave's state")
        settings = state["settings"]
        if not (isinstance(settings, tuple) and len(settings) == 4
                and isinstance(settings[3], tuple)
                and all(isinstance(p, tuple) and len(p) == 2 for p in settings[3])):
            raise ValueError(f"settings {settings!r}: expected (method, rtol, atol, "
                             "parameters)")
        method, rtol, atol, parameters = settings
        checks = [("integrator.method", method), ("integrator.rtol", rtol),
                  ("integrator.atol", atol)]
        if sorted(str(key) for key, _ in parameters) != sorted(self.tunable):
            raise ValueError(f"the state's parameters {[k for k, _ in parameters]} are not "
                             f"this FMU's {list(self.tunable)}")
        for name, value in checks + list(parameters):
            if name != "integrator.method" and not isinstance(value, float):
                raise ValueError(f"{name} = {value!r}: expected a float")
            problem = self.check_value(name, value)
            if problem:
                raise ValueError(problem)
        if not isinstance(state["simulator"], dict):
            raise ValueError("the simulator state is not a dict")
        return settings


def restored_state_problem(slave, simulator_state):
    """Why a simulator state, restored into `slave`'s simulator, is not one a run of this
    model can reach, or None: checked after core's own checks (sizes, finite numbers) and
    the kinematics (the outputs computed from it), against the limits of a host's input and
    of the model's range of validity.

    - its time must be the slave's communication point once initialized;
    - every output finite, every node within RESTORE_DISTANCE times the model's size of its
      start (the range of validity is a quarter of it: `flexure.core` only warns beyond
      that, so a run can legitimately be there; a hundredfold is no flexure motion);
    - the held inputs finite (core), the coil currents finite.
    """
    simulator = slave.simulator
    if slave.phase in (STEP_COMPLETE, TERMINATED):
        t = simulator.time
        if abs(t - slave.time) > 1e-9 * max(1.0, abs(slave.time)):
            return (f"simulator.t = {t!r} s: expected the state's communication point "
                    f"time = {slave.time!r} s")
    names = slave.simulator.output_names  # the coordinate outputs, those on elements
    for name, value in zip(names, slave.outputs, strict=True):
        if not math.isfinite(value):
            return f"output {name} = {value!r}: expected a finite number"
    for actuator, value in zip(slave._model.coil_actuators, slave.currents, strict=True):
        if not math.isfinite(value):
            return f"{actuator.name}.current = {value!r} A: expected a finite number"
    for port, value in zip(slave._model.kinematic_inputs, slave.efforts, strict=True):
        if not math.isfinite(value):
            return f"{port.name}.effort = {value!r}: expected a finite number"
    model = slave._model
    translations = np.asarray(model.translations, dtype=np.int64)
    if translations.size:
        start = np.asarray(model.initial_coordinates, float)[translations]
        # the coordinates the state stores, and its DOFs q in their places: q drives the
        # outputs and x the kinematics' start, and a forged state may set either apart
        for where, coordinates in (("x", np.asarray(simulator_state["x"], float)),
                                   ("q", _with_dofs(model, simulator))):
            problem = _moved_too_far(model, where, coordinates[translations], start,
                                     translations)
            if problem:
                return problem
    return None


def motion_description(model, port):
    """What a kinematic input prescribes, in words: "position of coordinate 3.x",
    "deformation actuator.e1" or, on a 3-D rotational node, "rotation 4.rz"."""
    if port.coordinate is not None:
        return f"position of coordinate {model.coordinate_names[port.coordinate]}"
    kind = "rotation" if port.unit == "rad" else "deformation"
    return f"{kind} {model.deformation_names[port.deformation]}"


def _with_dofs(model, simulator):
    """The initial coordinates with the simulator's DOFs q in their places (m, rad)."""
    coordinates = np.array(model.initial_coordinates, float)
    coordinates[model.dof_coordinates] = simulator.q
    return coordinates


def _moved_too_far(model, where, x, start, translations):
    """Why translations x (m) are beyond RESTORE_DISTANCE times the mechanism's size from
    their start, or None."""
    size = mechanism_size(model)  # m
    moved = np.abs(x - start)
    worst = int(np.argmax(moved))
    if moved[worst] > RESTORE_DISTANCE * size:
        name = model.coordinate_names[translations[worst]]
        return (f"simulator.{where}: coordinate {name} = {float(x[worst])!r} m is "
                f"{moved[worst]:.3g} m from its start; expected at most "
                f"{RESTORE_DISTANCE:g} times the model's size ({size:.3g} m)")
    return None
