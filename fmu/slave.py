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
  at status error; the stock binary gives the Python side no way to answer fmi2Error.
  flexure's corrected build of it (fmu/native, `pythonfmu_binary`) answers fmi2Error when
  `_set_fmu_state` returns False, and asks `_last_successful_time` after a restore.

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

The variables' registration is in `slave_variables`, the value getters and setters in
`slave_values`, the FMU states in `slave_states`: mixins of `SafeSlave`.
"""

from __future__ import annotations

import functools
import hashlib
import math
import traceback
from typing import Any

from pythonfmu import Fmi2Slave
from pythonfmu.enums import Fmi2Status

from .compiled_engine import WARNING, take_notes
from .pythonfmu_workarounds import (
    FMI2_WARNING,
    binary_note,
    guard_exit,
    log_to_host,
    tidy_sys_path,
)
from .slave_states import (
    INITIALIZATION,
    INSTANTIATED,
    STEP_COMPLETE,
    TERMINATED,
    StateSnapshots,
)
from .slave_values import SlaveValues
from .slave_variables import SlaveVariables, UnitReal

# Relative tolerance on the communication point a do_step starts from (hosts that count time
# in integer nanoseconds, e.g. libcosim, round it).
TIME_TOLERANCE = 1e-9



def escape_log(message: object) -> str:
    """A message safe to hand to a printf-style FMI logger: every '%' doubled.

    Parameters
    ----------
    message : object
        The message (str() of it is taken).

    Returns
    -------
    str
    """
    return str(message).replace("%", "%%")


def _fmi_call(call, phase, allowed, *, failure=None):
    """Decorate a `SafeSlave` method of the FMI call sequence: it runs only in `phase` and out
    of the error state, else the call is refused as an illegal call sequence (`allowed` says
    where it is allowed) and changes nothing; whatever it raises enters the error state,
    logged under `failure` (default `call`), instead of reaching pythonfmu's binary."""
    def decorate(method):
        @functools.wraps(method)
        def guarded(self, *args, **kwargs):
            try:
                if self.broken or self.phase != phase:
                    return self._illegal(call, allowed)
                return method(self, *args, **kwargs)
            except BaseException as error:  # noqa: BLE001
                self._fail(failure or call, error)
        return guarded
    return decorate


class SafeSlave(SlaveValues, SlaveVariables, StateSnapshots, Fmi2Slave):
    """Base of a co-simulation slave whose failures become FMI statuses, never exceptions.

    Subclasses implement `advance(t, h)` and, for state save/restore, `save_state()` and
    `load_state(state)`; `check_value(name, value)` validates what a host sets. They register
    variables with `add_real` / `add_string`. The attribute `time` (s) is the current
    communication point; `advance` need not update it (the base sets it to `t + h` on
    success, or to `last_good_time()` after a failure).

    Parameters
    ----------
    **kwargs
        pythonfmu's instantiation arguments (instance_name, resources, visible, ...), passed
        to `Fmi2Slave`.
    """

    # Names of inputs whose values `check_value` is not asked about: the model checks them
    # when it takes them (SceneSlave: the next doStep refuses a non-finite input). An input's
    # set is then a store and nothing more, the call a host makes before every doStep.
    unchecked_inputs: frozenset[str] = frozenset()

    def __init__(self, **kwargs: Any) -> None:
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
        self._settable_inputs = {}  # {variable kind: {value reference: (name, setter, checked)}}
        self._getters = {}  # {variable kind: {value reference: getter} of the readable ones}
        self._unchecked_reals = {}  # {value reference: setter} of the unchecked Real inputs
        # which pythonfmu binary this is, logged at fmi2EnterInitializationMode: a message
        # queued here reaches the host only at its next call, or else from fmi2FreeInstance,
        # where libcosim's logger is gone (SIGSEGV: an FMU libcosim instantiates and frees
        # with nothing in between, test_cosim_six's stale FMU)
        self._binary_note = binary_note(self.resources) if self.resources else None
        for status, message in take_notes():  # what became of the compiled engine it carries
            if status == WARNING:
                self.warn_host(kwargs, message)
            else:
                self.log_message(f"{self.instance_name}: {message}", Fmi2Status.ok)

    # -- to override -------------------------------------------------------------------------

    def advance(self, t: float, h: float) -> None:
        """Integrate over [t, t + h] with the inputs held (to override).

        Parameters
        ----------
        t : float
            The communication point, s.
        h : float
            The step, s, > 0.

        Raises
        ------
        FlexureError
            A model failure: logged, the step answered fmi2Discard, the model staying at
            `last_good_time()`. Any other exception is a bug: the instance enters the error
            state.
        """
        raise NotImplementedError

    def last_good_time(self) -> float:
        """The time the model is at after a failed `advance` (default: unchanged).

        Returns
        -------
        float
            s.
        """
        return self.time

    def initialize(self, start_time: float) -> None:
        """Prepare to step from `start_time`, after the parameters are set (to override).

        Parameters
        ----------
        start_time : float
            s.
        """

    def check_value(self, name: str, value: object) -> str | None:
        """Why the value a host sets for a variable is refused (to override).

        Parameters
        ----------
        name : str
            The variable's name.
        value : float, int, bool or str
            The value, in the variable's unit.

        Returns
        -------
        str or None
            What is wrong with it, or None to accept it.
        """
        return None

    def save_state(self) -> object:
        """The model's state beyond the registered variables (to override).

        Returns
        -------
        object
            Data `state_format` can store: None, bool, int, float, str, numpy arrays, and
            dicts, lists, tuples of those.
        """
        return None

    def load_state(self, state: object) -> None:
        """Restore what `save_state` returned (to override).

        Parameters
        ----------
        state : object
            Decoded from bytes: a private copy.

        Raises
        ------
        Exception
            When the state does not fit the model; the base then puts the instance back as
            it was.
        """

    @classmethod
    def identity_text(cls) -> str:
        """What the FMU is built from, for the identity a state carries. A state is accepted
        only by an FMU of the same identity.

        Returns
        -------
        str
            Default: the class's module and qualified name.
        """
        return f"{cls.__module__}.{cls.__qualname__}"

    @classmethod
    def state_identity(cls) -> str:
        """The identity a state carries.

        Returns
        -------
        str
            "<model identifier> <12 hex digits of identity_text's SHA-256>".
        """
        digest = hashlib.sha256(cls.identity_text().encode()).hexdigest()[:12]
        return f"{cls.__name__} {digest}"

    # -- logging and the error state -----------------------------------------------------------

    def log_message(self, message: object, status: Fmi2Status = Fmi2Status.ok) -> None:
        """Queue a message for the host's logger, '%' escaped.

        Parameters
        ----------
        message : object
            The message (str() of it is taken).
        status : Fmi2Status
            The status it is logged at.
        """
        self.log(escape_log(message), status=status)

    def warn_host(self, constructor_kwargs: dict, message: object) -> None:
        """Log a message at status warning through the host's logger now, from the
        constructor, even with the host's debug logging off (`log_to_host`), e.g. that the
        engine is about to compile for a minute; queued as `log_message` does when this
        binary's logger cannot be reached.

        Parameters
        ----------
        constructor_kwargs : dict
            The constructor's keyword arguments (the host's logger is among them).
        message : object
            The message (str() of it is taken), after the instance name.
        """
        text = f"{self.instance_name}: {message}"
        if not log_to_host(constructor_kwargs, text, FMI2_WARNING):
            self.log_message(text, Fmi2Status.warning)

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
    # The calls of the call sequence state the states they are allowed in (`_fmi_call`).

    @_fmi_call("fmi2SetupExperiment", INSTANTIATED, "state instantiated")
    def setup_experiment(self, start_time: float, stop_time: float | None = None,
                         tolerance: float | None = None) -> None:
        """fmi2SetupExperiment; refused arguments enter the error state.

        Parameters
        ----------
        start_time : float
            s, finite.
        stop_time : float, optional
            s, >= start_time.
        tolerance : float, optional
            > 0 (relative).
        """
        problem = _experiment_problem(start_time, stop_time, tolerance)
        if problem:
            return self._break(f"fmi2SetupExperiment refused: {problem}")
        self.start_time = float(start_time)
        self.time = self.start_time

    @_fmi_call("fmi2EnterInitializationMode", INSTANTIATED, "state instantiated")
    def enter_initialization_mode(self) -> None:
        """fmi2EnterInitializationMode."""
        if self._binary_note:
            self.log_message(f"{self.instance_name}: {self._binary_note}", Fmi2Status.ok)
            self._binary_note = None
        self.phase = INITIALIZATION

    @_fmi_call("fmi2ExitInitializationMode", INITIALIZATION,
               "initialization mode (after fmi2EnterInitializationMode)",
               failure="initialization")
    def exit_initialization_mode(self) -> None:
        """fmi2ExitInitializationMode: `initialize(start_time)`, then step complete."""
        self.initialize(self.start_time)
        self.time = self.start_time
        self.phase = STEP_COMPLETE

    @_fmi_call("fmi2Terminate", STEP_COMPLETE, "state step complete")
    def terminate(self) -> None:
        """fmi2Terminate."""
        self.phase = TERMINATED

    def do_step(self, current_time: float, step_size: float) -> bool:
        """fmi2DoStep: `advance` over [current_time, current_time + step_size].

        Parameters
        ----------
        current_time : float
            The communication point, s: the current `time` (relative tolerance 1e-9).
        step_size : float
            h, s, > 0 and finite.

        Returns
        -------
        bool
            True for fmi2OK; False for fmi2Discard (a refused or failed step, logged).
        """
        try:
            time = self.time
            # one test for the usual step (NaN fails every comparison), the refusals after it
            if not (self.phase == STEP_COMPLETE and not self.broken
                    and 0.0 < step_size < math.inf
                    and abs(current_time - time) <= TIME_TOLERANCE * max(1.0, abs(time))):
                return self._refuse_step(current_time, step_size)
            self.advance(time, current_time + step_size - time)
            self.time = current_time + step_size
            return True
        except BaseException as error:  # noqa: BLE001 -- a raise here would be fmi2Fatal
            return self._step_failed(current_time, step_size, error)

    def _step_failed(self, current_time, step_size, error):
        """After `advance` raised: a model error is logged and the instance goes back to its
        last good time; anything else is a bug and enters the error state. Answers False
        (fmi2Discard)."""
        try:
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
        except BaseException as failure:  # noqa: BLE001
            self._fail(f"doStep at t = {current_time!r} s", failure)
        return False

    def _refuse_step(self, current_time, step_size):
        """Log why a doStep is refused (the error state, the call sequence, h or t) and
        answer False (fmi2Discard)."""
        if self.broken:
            self._error(f"step refused: {self.broken}")
        elif self.phase != STEP_COMPLETE:
            self._illegal("fmi2DoStep", "state step complete (after "
                                        "fmi2ExitInitializationMode, before fmi2Terminate)")
        elif not (math.isfinite(step_size) and step_size > 0.0):
            self._error(f"doStep at t = {current_time!r} s: expected a step size h > 0, "
                        f"got {step_size!r} s")
        else:
            self._error(f"doStep: expected the communication point t = {self.time!r} s, "
                        f"got {current_time!r} s")
        return False


def _experiment_problem(start_time, stop_time, tolerance):
    """Why setupExperiment's arguments are refused, or None."""
    if not math.isfinite(start_time):
        return f"startTime = {start_time!r} s: expected a finite time"
    if stop_time is not None and not (math.isfinite(stop_time) and stop_time >= start_time):
        return f"stopTime = {stop_time!r} s: expected a finite time >= startTime"
    if tolerance is not None and not (math.isfinite(tolerance) and tolerance > 0):
        return f"tolerance = {tolerance!r}: expected a finite number > 0"
    return None


def _is_model_error(error):
    """True for the errors a model reports on purpose (flexure's FlexureError family).

    Matched by class name along the MRO, so a bundled copy of flexure (another module name)
    is recognised as well.
    """
    return any(cls.__name__ == "FlexureError" for cls in type(error).__mro__)


# UnitReal is defined in slave_variables and kept importable from here (the bundled
# flexure.fmu of an FMU takes its public names from this module)
__all__ = ["TIME_TOLERANCE", "SafeSlave", "UnitReal", "escape_log"]
