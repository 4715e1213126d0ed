"""A pythonfmu slave that never takes its host down: the shared base of flexure's FMUs.

`SafeSlave` is the FMI glue between a host and a model that advances in time; a subclass
supplies only the model part:

    class Lag(SafeSlave):
        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.u, self.y = 0.0, 0.0
            self.add_real("u", causality="input", unit="N", start=0.0)
            self.add_real("y", causality="output", unit="m")
        def advance(self, t, h):      # integrate over [t, t + h]; raise on failure
            ...
        def save_state(self): ...     # picklable; returned values are deep-copied
        def load_state(self, state): ...

What the base does (the FMI side of every do_step, Reference-FMUs style):

- checks the call: the instance is not broken, h > 0 and finite, and the step starts at the
  current communication point (relative tolerance 1e-9);
- calls `advance(t, h)` inside a try: a `FlexureError` (a failed Newton, an integrator failure,
  a non-finite input) is logged at status error and answered with fmi2Discard; the subclass
  must leave itself at its last good time (flexure's Simulator does). Any other exception is a
  bug: it is logged with its traceback, the instance is marked broken (every later do_step is
  refused with the reason until fmi2Reset or a state restore) and the step is answered with
  fmi2Discard. pythonfmu 0.7.0 cannot answer fmi2Error from do_step: a raised exception
  becomes fmi2Fatal, which makes hosts give up on the whole simulation;
- escapes '%' in every logged message: pythonfmu passes messages to the host's logger as a
  printf format (libcosim and fmpy crash on "%s");
- saves and restores the whole state (`_get_fmu_state` / `_set_fmu_state`) as deep copies
  (pythonfmu's default keeps references, so the next step would change a saved state) and
  serialises it with pickle;
- guards the other calls (setup, initialization, terminate) the same way.

Setters never raise (an exception there would be fmi2Fatal): values are stored as given and
checked by the subclass when it steps.
"""

import copy
import math
import pickle
import time as _time
import traceback

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Real, String
from pythonfmu.enums import Fmi2Status

# Relative tolerance on the communication point a do_step starts from (hosts that count time
# in integer nanoseconds, e.g. libcosim, round it).
TIME_TOLERANCE = 1e-9


# pythonfmu 0.7.0's binary finds the slave class by importing the script module, executing the
# script once more in the module's namespace, and then releasing one reference to that
# namespace it never owned (findClass in PySlaveInstance.cpp: Py_DECREF on the borrowed
# PyModule_GetDict). The first instance frees the module's __dict__; the next instantiation of
# the same FMU in the process then fails ("module has no attribute ...") or reads garbage.
_SCRIPT_NAMESPACES = []


def keep_script_namespace(namespace):
    """Take one reference to a slave script's namespace; call as `(globals())` at module level.

    The script runs once on import and once more per instantiation, so every release by
    pythonfmu's binary is matched by one reference here (kept for the life of the process).
    `build_slave_fmu` appends the call to every script it builds.
    """
    _SCRIPT_NAMESPACES.append(namespace)


class UnitReal(Real):
    """A pythonfmu `Real` that also declares its unit (pythonfmu 0.7.0 has no unit attribute).

    The unit is written on the <Real> element; `fix_model_description` adds the matching
    <UnitDefinitions> entry.
    """

    def __init__(self, name, start=None, *, unit=None, **kwargs):
        super().__init__(name, start=start, **kwargs)
        self.unit = unit

    def to_xml(self):
        element = super().to_xml()
        if self.unit:
            element.find("Real").set("unit", self.unit)
        return element


def escape_log(message):
    """A message safe to hand to a printf-style FMI logger: every '%' doubled."""
    return str(message).replace("%", "%%")


class SafeSlave(Fmi2Slave):
    """Base of a co-simulation slave whose failures become FMI statuses, never exceptions.

    Subclasses implement `advance(t, h)` and, for state save/restore, `save_state()` and
    `load_state(state)`. They register variables with `add_real` / `add_string`. The attribute
    `time` (s) is the current communication point; `advance` need not update it (the base sets
    it to `t + h` on success, or to `last_good_time()` after a failure).
    """

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.time = 0.0  # s, the current communication point
        self.start_time = 0.0  # s
        self.broken = ""  # why this instance cannot go on ("" while it can)
        self.step_seconds = 0.0  # wall time spent in do_step (s), for benchmarks

    # -- to override -------------------------------------------------------------------------

    def advance(self, t, h):
        """Integrate over [t, t + h] (s) with the inputs held. Raise on failure."""
        raise NotImplementedError

    def last_good_time(self):
        """The time (s) the model is at after a failed `advance` (default: unchanged)."""
        return self.time

    def initialize(self, start_time):
        """Prepare to step from `start_time` (s), after the parameters are set."""

    def save_state(self):
        """The model's state beyond the registered variables (picklable); default None."""
        return None

    def load_state(self, state):
        """Restore what `save_state` returned (already a private deep copy)."""

    # -- variables ---------------------------------------------------------------------------

    def add_real(self, name, *, causality, unit=None, start=None, variability=None,
                 initial=None, description=None, getter=None, setter=None):
        """Register a Real variable; causality is "input", "output", "parameter" or "local".

        Defaults follow FMI 2.0: inputs are continuous with a start value, outputs
        continuous and calculated, parameters fixed and exact. `getter` / `setter` default to
        the attribute of the same name.
        """
        causality = Fmi2Causality[causality]
        if variability is None:
            variability = (Fmi2Variability.fixed if causality == Fmi2Causality.parameter
                           else Fmi2Variability.continuous)
        if initial is None and causality == Fmi2Causality.parameter:
            initial = Fmi2Initial.exact
        if getter is None:
            def getter():
                return getattr(self, name)
        if setter is None and causality != Fmi2Causality.output:
            def setter(value):
                setattr(self, name, value)
        self.register_variable(UnitReal(
            name, start=start, unit=unit, causality=causality, variability=variability,
            initial=initial, description=description, getter=getter, setter=setter),
            nested=False)

    def add_string(self, name, *, start, description=None, getter=None, setter=None):
        """Register a fixed String parameter (e.g. the integration method)."""
        if getter is None:
            def getter():
                return getattr(self, name)
        if setter is None:
            def setter(value):
                setattr(self, name, value)
        self.register_variable(String(
            name, start=start, causality=Fmi2Causality.parameter,
            variability=Fmi2Variability.fixed, initial=Fmi2Initial.exact,
            description=description, getter=getter, setter=setter), nested=False)

    # -- logging -----------------------------------------------------------------------------

    def log_message(self, message, status=Fmi2Status.ok):
        """Queue a message for the host's logger, '%' escaped."""
        self.log(escape_log(message), status=status)

    def _fail(self, what, error):
        """Mark the instance broken (it cannot go on) and log why.

        A model error (FlexureError) is reported by its message; anything else is a bug and
        is logged with its traceback.
        """
        if _is_model_error(error):
            self.broken = f"{what} failed: {error}"
            detail = ""
        else:
            exception = "".join(traceback.format_exception_only(type(error), error)).strip()
            self.broken = f"{what} failed unexpectedly: {exception}"
            detail = "\n" + traceback.format_exc()
        self.log_message(f"{self.instance_name}: {self.broken}; this instance cannot go on "
                         f"until fmi2Reset or a restored state{detail}", Fmi2Status.error)

    # -- FMI calls ---------------------------------------------------------------------------

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self.start_time = float(start_time)
        self.time = self.start_time

    def exit_initialization_mode(self):
        try:
            self.initialize(self.start_time)
        except Exception as error:  # noqa: BLE001 -- anything here would be fmi2Fatal
            self._fail("initialization", error)

    def do_step(self, current_time, step_size):
        start = _time.perf_counter()
        try:
            return self._do_step(current_time, step_size)
        finally:
            self.step_seconds += _time.perf_counter() - start

    def _do_step(self, current_time, step_size):
        if self.broken:
            self.log_message(f"{self.instance_name}: step refused: {self.broken}",
                             Fmi2Status.error)
            return False
        if not (math.isfinite(step_size) and step_size > 0.0):
            self.log_message(f"{self.instance_name}: doStep at t = {current_time!r} s: "
                             f"expected a step size h > 0, got {step_size!r} s",
                             Fmi2Status.error)
            return False
        if abs(current_time - self.time) > TIME_TOLERANCE * max(1.0, abs(self.time)):
            self.log_message(f"{self.instance_name}: doStep: expected the communication point "
                             f"t = {self.time!r} s, got {current_time!r} s", Fmi2Status.error)
            return False
        try:
            self.advance(self.time, current_time + step_size - self.time)
        except Exception as error:  # noqa: BLE001 -- a raise here would be fmi2Fatal
            if not _is_model_error(error):
                self._fail(f"doStep at t = {current_time!r} s", error)
                return False
            try:
                self.time = float(self.last_good_time())
            except Exception as inner:  # noqa: BLE001
                self._fail(f"doStep from t = {current_time!r} s over h = {step_size!r} s "
                           f"({error}); then recovering the last good state", inner)
                return False
            self.log_message(f"{self.instance_name}: doStep from t = {current_time!r} s "
                             f"over h = {step_size!r} s discarded: {error}; the instance "
                             f"stays at its last good time t = {self.time!r} s",
                             Fmi2Status.error)
            return False
        self.time = current_time + step_size
        return True

    def terminate(self):
        pass

    # -- FMU state ---------------------------------------------------------------------------

    def _get_fmu_state(self):
        values = {}
        for variable in self.vars.values():
            if variable.setter is not None:
                values[variable.name] = copy.deepcopy(variable.getter())
        state = {"variables": values, "time": self.time, "start_time": self.start_time,
                 "broken": self.broken, "model": None}
        try:
            state["model"] = copy.deepcopy(self.save_state())
        except Exception as error:  # noqa: BLE001 -- a raise here would be fmi2Fatal
            # The state is still returned (pythonfmu cannot answer an error here); restoring
            # it breaks the instance with the reason instead of continuing from garbage.
            self._fail("getting the FMU state", error)
            state["broken"] = self.broken
            self.broken = ""
        return state

    def _set_fmu_state(self, state):
        state = copy.deepcopy(state)
        try:
            by_name = {v.name: v for v in self.vars.values()}
            for name, value in state["variables"].items():
                by_name[name].setter(value)
            self.time = state["time"]
            self.start_time = state["start_time"]
            self.broken = state["broken"]
            if not self.broken:
                self.load_state(state["model"])
        except Exception as error:  # noqa: BLE001
            self._fail("restoring an FMU state", error)

    @staticmethod
    def _fmu_state_to_bytes(state):
        return pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)

    @staticmethod
    def _fmu_state_from_bytes(data):
        return pickle.loads(data)


def _is_model_error(error):
    """True for the errors a model reports on purpose (flexure's FlexureError family).

    Matched by class name along the MRO, so a bundled copy of flexure (another module name)
    is recognised as well.
    """
    return any(cls.__name__ == "FlexureError" for cls in type(error).__mro__)
