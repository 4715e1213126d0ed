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
        def save_state(self): ...     # data only: numbers, strings, numpy arrays, dicts...
        def load_state(self, state): ...

Why everything here is defensive: pythonfmu 0.7.0's binary turns an exception raised by any
Python method it calls into fmi2Fatal *and* releases its references to the slave class, the
instance and its log queue without forgetting them (PySlaveInstance::handle_py_exception ->
cleanPyObject). The next call then runs on freed objects (SIGSEGV) and fmi2FreeInstance
releases them a second time (heap corruption, "corrupted double-linked list" at exit). So no
method pythonfmu calls may raise, ever: each one below catches everything and turns it into
a logged message and the best status that binary can carry:

- doStep: fmi2OK or fmi2Discard (Python returns True / False);
- every other call (setupExperiment, enter/exitInitializationMode, terminate, get/set of
  values, get/set/serialize/deserialize of FMU states): fmi2OK only. A refused call is logged
  at status error; the binary gives the Python side no way to answer fmi2Error.

What the base does, Reference-FMUs style:

- the FMI 2.0 call sequence: instantiated -> (setupExperiment) -> initialization mode ->
  step complete -> terminated, plus the error state. A call outside its states is refused and
  logged ("Illegal call sequence") and changes nothing; doStep outside step complete answers
  fmi2Discard. Getters are allowed in every state (the values are well defined from
  instantiation on, and a refusal could only hand the host NaN under fmi2OK);
- setters: an unknown value reference, a variable of another type, an output, a fixed
  parameter after initialization, or a value the model refuses (`check_value`, e.g. a
  negative tolerance) is refused, and the instance enters the error state: since the setter
  itself can only answer fmi2OK, the next doStep answers fmi2Discard naming the refused value
  (fmi2Reset or restoring a state recovers), instead of running with a value the host did
  not ask for;
- doStep checks h > 0 and finite, and that the step starts at the current communication
  point (relative tolerance 1e-9); then calls `advance(t, h)` inside a try: a `FlexureError`
  (a failed Newton, an integrator failure, a non-finite input) is logged at status error and
  answered with fmi2Discard, the model staying at its last good time (flexure's Simulator
  does); any other exception is a bug: logged with its traceback, the instance enters the
  error state, and the step is answered with fmi2Discard;
- FMU states are data, never code (`flexure.fmu.state_format`): a state is the immutable
  bytes of the versioned format, so getFMUstate returns a snapshot nothing can change,
  serialising is a copy, and deserialising validates the bytes (magic, version, length,
  SHA-256, identity of the FMU, tags) without running anything. A state that does not
  validate is refused by setFMUstate with a log line naming what is wrong, and the instance
  stays exactly as it was (a state that validates but that the model refuses is rolled back);
- '%' is escaped in every logged message: pythonfmu passes messages to the host's logger as
  a printf format (libcosim and fmpy crash on "%s").
"""

import hashlib
import math
import time as _time
import traceback

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Real, String
from pythonfmu.enums import Fmi2Status
from pythonfmu.variables import Boolean, Integer

from .pythonfmu_workarounds import guard_exit, tidy_sys_path, weakly_bound
from .slave_states import (
    INITIALIZATION,
    INSTANTIATED,
    STEP_COMPLETE,
    TERMINATED,
    StateSnapshots,
)

# Relative tolerance on the communication point a do_step starts from (hosts that count time
# in integer nanoseconds, e.g. libcosim, round it).
TIME_TOLERANCE = 1e-9



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


class SafeSlave(StateSnapshots, Fmi2Slave):
    """Base of a co-simulation slave whose failures become FMI statuses, never exceptions.

    Subclasses implement `advance(t, h)` and, for state save/restore, `save_state()` and
    `load_state(state)`; `check_value(name, value)` validates what a host sets. They register
    variables with `add_real` / `add_string`. The attribute `time` (s) is the current
    communication point; `advance` need not update it (the base sets it to `t + h` on
    success, or to `last_good_time()` after a failure).
    """

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        try:
            tidy_sys_path(self.resources)
            guard_exit(self.resources, type(self).__name__)
        except Exception as error:  # noqa: BLE001 -- a work-around must not stop the FMU
            self.log_message(f"{self.instance_name}: pythonfmu work-arounds not applied: "
                             f"{error}", Fmi2Status.warning)
        self.time = 0.0  # s, the current communication point
        self.start_time = 0.0  # s
        self.phase = INSTANTIATED  # where the instance is in the FMI call sequence
        self.broken = ""  # why this instance is in the error state ("" while it is not)
        self.step_seconds = 0.0  # wall time spent in do_step (s), for benchmarks
        self._settable_inputs = {}  # {variable kind: its inputs' value references}

    # -- to override -------------------------------------------------------------------------

    def advance(self, t, h):
        """Integrate over [t, t + h] (s) with the inputs held. Raise on failure."""
        raise NotImplementedError

    def last_good_time(self):
        """The time (s) the model is at after a failed `advance` (default: unchanged)."""
        return self.time

    def initialize(self, start_time):
        """Prepare to step from `start_time` (s), after the parameters are set."""

    def check_value(self, name, value):
        """Why the value a host sets for variable `name` is refused, or None to accept it."""
        return None

    def save_state(self):
        """The model's state beyond the registered variables, as data `state_format` can store
        (None, bool, int, float, str, numpy arrays, and dicts, lists, tuples of those)."""
        return None

    def load_state(self, state):
        """Restore what `save_state` returned (decoded from bytes: a private copy). Raise if
        the state does not fit the model; the base then puts the instance back as it was."""

    @classmethod
    def identity_text(cls):
        """What the FMU is built from, for the identity a state carries (default: the class's
        module and name). A state is accepted only by an FMU of the same identity."""
        return f"{cls.__module__}.{cls.__qualname__}"

    @classmethod
    def state_identity(cls):
        """"<model identifier> <12 hex digits of identity_text's SHA-256>"."""
        digest = hashlib.sha256(cls.identity_text().encode()).hexdigest()[:12]
        return f"{cls.__name__} {digest}"

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

    def add_integer(self, name, *, start, description=None, getter=None, setter=None):
        """Register a fixed Integer parameter (e.g. the integrator's step budget)."""
        self._add_fixed(Integer, name, start, description, getter, setter)

    def add_string(self, name, *, start, description=None, getter=None, setter=None):
        """Register a fixed String parameter (e.g. the integration method)."""
        self._add_fixed(String, name, start, description, getter, setter)

    def _add_fixed(self, kind, name, start, description, getter, setter):
        """Register a fixed, exact parameter of pythonfmu's variable class `kind`; getter and
        setter default to the attribute of the same name."""
        if getter is None:
            def getter():
                return getattr(self, name)
        if setter is None:
            def setter(value):
                setattr(self, name, value)
        self.register_variable(kind(
            name, start=start, causality=Fmi2Causality.parameter,
            variability=Fmi2Variability.fixed, initial=Fmi2Initial.exact,
            description=description, getter=getter, setter=setter), nested=False)

    def register_variable(self, var, nested=True):
        """pythonfmu's registration, with the getter and setter holding the instance weakly
        (`weakly_bound`): fmi2FreeInstance then frees the instance at once."""
        super().register_variable(var, nested=nested)
        var.getter = weakly_bound(var.getter, self)
        var.setter = weakly_bound(var.setter, self)

    # -- logging and the error state -----------------------------------------------------------

    def log_message(self, message, status=Fmi2Status.ok):
        """Queue a message for the host's logger, '%' escaped."""
        self.log(escape_log(message), status=status)

    def _error(self, message):
        """Log a refused call at status error (nothing else changes)."""
        self.log_message(f"{self.instance_name}: {message}", Fmi2Status.error)

    def _illegal(self, call, allowed):
        """Refuse a call made in the wrong state of the FMI call sequence."""
        self._error(f"{call}: illegal call sequence: the instance is in "
                    f"{self._state_name()}; {call} is allowed in {allowed}")

    def _state_name(self):
        return f"the error state ({self.broken})" if self.broken else f"state {self.phase}"

    def _break(self, reason):
        """Enter the error state for `reason` (the first reason is kept) and log it."""
        if not self.broken:
            self.broken = reason
        self._error(f"{reason}; this instance cannot go on until fmi2Reset or a restored "
                    "state")

    def _fail(self, what, error):
        """Enter the error state after an exception and log why.

        A model error (FlexureError) is reported by its message; anything else is a bug and
        is logged with its traceback.
        """
        if _is_model_error(error):
            reason = f"{what} failed: {error}"
            detail = ""
        else:
            exception = "".join(traceback.format_exception_only(type(error), error)).strip()
            reason = f"{what} failed unexpectedly: {exception}"
            detail = "\n" + traceback.format_exc()
        self.broken = self.broken or reason
        self._error(f"{reason}; this instance cannot go on until fmi2Reset or a restored "
                    f"state{detail}")

    # -- FMI calls ---------------------------------------------------------------------------
    # Every method pythonfmu calls catches BaseException: anything escaping is fatal (above).

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        try:
            if self.broken or self.phase != INSTANTIATED:
                return self._illegal("fmi2SetupExperiment", "state instantiated")
            problem = _experiment_problem(start_time, stop_time, tolerance)
            if problem:
                return self._break(f"fmi2SetupExperiment refused: {problem}")
            self.start_time = float(start_time)
            self.time = self.start_time
        except BaseException as error:  # noqa: BLE001
            self._fail("fmi2SetupExperiment", error)

    def enter_initialization_mode(self):
        try:
            if self.broken or self.phase != INSTANTIATED:
                return self._illegal("fmi2EnterInitializationMode", "state instantiated")
            self.phase = INITIALIZATION
        except BaseException as error:  # noqa: BLE001
            self._fail("fmi2EnterInitializationMode", error)

    def exit_initialization_mode(self):
        try:
            if self.broken or self.phase != INITIALIZATION:
                return self._illegal("fmi2ExitInitializationMode",
                                     "initialization mode (after fmi2EnterInitializationMode)")
            self.initialize(self.start_time)
            self.time = self.start_time
            self.phase = STEP_COMPLETE
        except BaseException as error:  # noqa: BLE001
            self._fail("initialization", error)

    def terminate(self):
        try:
            if self.broken or self.phase != STEP_COMPLETE:
                return self._illegal("fmi2Terminate", "state step complete")
            self.phase = TERMINATED
        except BaseException as error:  # noqa: BLE001
            self._fail("fmi2Terminate", error)

    def do_step(self, current_time, step_size):
        start = _time.perf_counter()
        try:
            return self._do_step(current_time, step_size)
        except BaseException as error:  # noqa: BLE001
            self._fail(f"doStep at t = {current_time!r} s", error)
            return False
        finally:
            self.step_seconds += _time.perf_counter() - start

    def _do_step(self, current_time, step_size):
        if self.broken:
            self._error(f"step refused: {self.broken}")
            return False
        if self.phase != STEP_COMPLETE:
            self._illegal("fmi2DoStep", "state step complete (after "
                                        "fmi2ExitInitializationMode, before fmi2Terminate)")
            return False
        if not (math.isfinite(step_size) and step_size > 0.0):
            self._error(f"doStep at t = {current_time!r} s: expected a step size h > 0, "
                        f"got {step_size!r} s")
            return False
        if not (math.isfinite(current_time) and abs(current_time - self.time)
                <= TIME_TOLERANCE * max(1.0, abs(self.time))):
            self._error(f"doStep: expected the communication point t = {self.time!r} s, "
                        f"got {current_time!r} s")
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
            self._error(f"doStep from t = {current_time!r} s over h = {step_size!r} s "
                        f"discarded: {error}; the instance stays at its last good time "
                        f"t = {self.time!r} s")
            return False
        self.time = current_time + step_size
        return True

    # -- values ------------------------------------------------------------------------------

    def get_real(self, vrs):
        return self._get("fmi2GetReal", vrs, Real, float, math.nan)

    def get_integer(self, vrs):
        return self._get("fmi2GetInteger", vrs, Integer, int, 0)

    def get_boolean(self, vrs):
        return self._get("fmi2GetBoolean", vrs, Boolean, bool, False)

    def get_string(self, vrs):
        return self._get("fmi2GetString", vrs, String, str, "")

    def _get(self, call, vrs, kind, convert, default):
        """One value per reference, always (the binary reads exactly that many); a reference
        that cannot be read gives `default` and a logged error."""
        values = []
        try:
            for vr in vrs:
                value = default
                try:
                    problem = self._variable_problem(vr, kind)
                    if problem:
                        self._error(f"{call}: {problem}")
                    else:
                        value = convert(self.vars[vr].getter())
                except BaseException as error:  # noqa: BLE001
                    self._error(f"{call}: reading value reference {vr!r} failed: "
                                f"{type(error).__name__}: {error}")
                values.append(value)
        except BaseException as error:  # noqa: BLE001 -- vrs itself unreadable
            self._error(f"{call}: {type(error).__name__}: {error}")
        return values

    def set_real(self, vrs, values):
        self._set("fmi2SetReal", vrs, values, Real)

    def set_integer(self, vrs, values):
        self._set("fmi2SetInteger", vrs, values, Integer)

    def set_boolean(self, vrs, values):
        self._set("fmi2SetBoolean", vrs, values, Boolean)

    def set_string(self, vrs, values):
        self._set("fmi2SetString", vrs, values, String)

    def _set(self, call, vrs, values, kind):
        """Set values in order; the first one refused stops the call and enters the error
        state (see the module docstring: the setter itself can only answer fmi2OK)."""
        try:
            if self.broken or self.phase not in (INSTANTIATED, INITIALIZATION, STEP_COMPLETE):
                return self._illegal(call, "states instantiated, initialization mode and "
                                           "step complete")
            inputs = self._inputs_of(kind)
            for vr, value in zip(vrs, values, strict=True):
                # an input of this kind is always settable: only its value is checked
                problem = None if vr in inputs else (self._variable_problem(vr, kind)
                                                     or self._settable_problem(vr))
                if not problem:
                    problem = self.check_value(self.vars[vr].name, value)
                if problem:
                    return self._break(f"{call} refused: {problem}")
                self.vars[vr].setter(value)
        except BaseException as error:  # noqa: BLE001
            self._fail(call, error)

    def _inputs_of(self, kind):
        """The value references of the settable inputs of `kind` (found once per kind: the
        variables are registered in __init__, before any set)."""
        found = self._settable_inputs.get(kind)
        if found is None:
            found = self._settable_inputs[kind] = frozenset(
                vr for vr, variable in self.vars.items()
                if isinstance(variable, kind) and variable.causality == Fmi2Causality.input
                and variable.setter is not None)
        return found

    def _variable_problem(self, vr, kind):
        variable = self.vars.get(vr)
        if variable is None:
            return (f"unknown value reference {vr!r} (this FMU has value references 0 to "
                    f"{len(self.vars) - 1})")
        if not isinstance(variable, kind):
            return (f"{variable.name!r} (value reference {vr}) is a "
                    f"{_kind_name(type(variable))}, not a {kind.__name__}")
        return None

    def _settable_problem(self, vr):
        variable = self.vars[vr]
        causality, variability = variable.causality, variable.variability
        if variable.setter is None or causality in (Fmi2Causality.output,
                                                    Fmi2Causality.calculatedParameter):
            name = causality.name if causality is not None else "read-only"
            return f"{variable.name!r} (value reference {vr}) is {_article(name)}: it cannot " \
                   "be set"
        if variability == Fmi2Variability.constant:
            return f"{variable.name!r} (value reference {vr}) is a constant"
        if variability == Fmi2Variability.fixed and self.phase == STEP_COMPLETE:
            return (f"{variable.name!r} (value reference {vr}) is a fixed parameter: it can be "
                    "set before fmi2ExitInitializationMode only")
        return None


def _experiment_problem(start_time, stop_time, tolerance):
    """Why setupExperiment's arguments are refused, or None."""
    if not math.isfinite(start_time):
        return f"startTime = {start_time!r} s: expected a finite time"
    if stop_time is not None and not (math.isfinite(stop_time) and stop_time >= start_time):
        return f"stopTime = {stop_time!r} s: expected a finite time >= startTime"
    if tolerance is not None and not (math.isfinite(tolerance) and tolerance > 0):
        return f"tolerance = {tolerance!r}: expected a finite number > 0"
    return None


def _kind_name(cls):
    for kind in (Real, Integer, Boolean, String):
        if issubclass(cls, kind):
            return kind.__name__
    return cls.__name__


def _article(word):
    return ("an " if word[:1] in "aeiou" else "a ") + word


def _is_model_error(error):
    """True for the errors a model reports on purpose (flexure's FlexureError family).

    Matched by class name along the MRO, so a bundled copy of flexure (another module name)
    is recognised as well.
    """
    return any(cls.__name__ == "FlexureError" for cls in type(error).__mro__)
