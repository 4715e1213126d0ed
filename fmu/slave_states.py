"""FMU states of a SafeSlave: snapshots that are data, taken, checked and restored.

fmi2GetFMUstate returns the immutable bytes of the versioned format (`state_format`): the
call-sequence phase, the error state, the time, every settable variable and the model's own
state (`SafeSlave.save_state`). Serialising is a copy; deserialising validates the bytes
(magic, version, length, SHA-256, the FMU's identity, tags) without running anything.
fmi2SetFMUstate refuses a state that does not validate, or whose content is not this
instance's, naming why, and leaves the instance as it was; a state the model refuses is rolled
back. The handle a host holds is an `FMUState` around the bytes, kept valid (and marked
freed) after fmi2FreeFMUstate, which pythonfmu's binary does not NULL. Nothing here raises
into pythonfmu's binary (see `slave`).
"""

import collections
import math
import sys

from pythonfmu import String

from . import state_format
from .pythonfmu_workarounds import hold_namespace

# The FMI 2.0 co-simulation states (the error state is `SafeSlave.broken` != "").
INSTANTIATED = "instantiated"
INITIALIZATION = "initialization mode"
STEP_COMPLETE = "step complete"
TERMINATED = "terminated"
PHASES = (INSTANTIATED, INITIALIZATION, STEP_COMPLETE, TERMINATED)
# The latest communication point a state may hold, in s after its start time: libcosim counts
# time in int64 nanoseconds (9.2e9 s), and at 1e9 s a float still resolves 1e-7 s.
TIME_SPAN = 1e9


def _as_set(variable, value):
    """A stored value as the host's setter would hand it over (an Integer as an int)."""
    if type(variable).__name__ == "Integer" and float(value).is_integer():
        return int(value)
    return value


class RefusedState:
    """What deserialising or taking a state answers when it cannot give a state: the reason.

    pythonfmu's binary cannot answer an error from fmi2DeSerializeFMUstate or fmi2GetFMUstate,
    so the refusal travels in the state: setFMUstate logs the reason and changes nothing.
    """

    __slots__ = ("reason",)

    def __init__(self, reason):
        self.reason = reason

    def __repr__(self):
        return f"RefusedState({self.reason!r})"


FREED = RefusedState("the state was freed by fmi2FreeFMUstate")


# pythonfmu 0.7.0's fmi2FreeFMUstate releases the host's reference to the state object and
# leaves the host's handle as it was (not NULL), so a host that uses the handle again (set,
# serialize, free) hands the binary freed memory: SIGSEGV, or a heap corrupted at exit. The
# handle is therefore an `FMUState`, which its finalizer keeps alive when the host frees it:
# its bytes are dropped, it is marked freed (a later setFMUstate refuses it by name), and
# HOLDS references to it are kept, so up to HOLDS - 1 more frees of the same handle only
# count down. The last FREED_KEPT freed handles stay valid (about 60 bytes each: 0.6 MB at
# most); an older one is released when its count shows no extra free, and kept for good when
# it does (releasing it would underflow the count). Both containers are never released (not
# even at interpreter exit, when releasing an over-freed handle would corrupt the heap).
HOLDS = 16
FREED_KEPT = 10_000
FREED_HOLDS = collections.deque()  # tuples of HOLDS references to a freed FMUState
OVER_FREED_HOLDS = []  # such tuples whose handle was freed more than once: never released
hold_namespace(FREED_HOLDS)
hold_namespace(OVER_FREED_HOLDS)


class FMUState:
    """What a host holds as an fmi2FMUstate: the state's bytes, or the reason there are none
    (`RefusedState`); after fmi2FreeFMUstate, a marker of that (`FREED`)."""

    __slots__ = ("data",)

    def __init__(self, data):
        self.data = data

    def __repr__(self):
        return f"FMUState({self.data!r})"

    def __del__(self):
        # the host freed it (its reference was the last): keep the object, drop the data
        try:
            self.data = FREED
            if len(FREED_HOLDS) >= FREED_KEPT:
                _release(FREED_HOLDS.popleft())
            FREED_HOLDS.append((self,) * HOLDS)
        except BaseException:  # noqa: BLE001, S110 -- nothing may raise out of a finalizer
            pass


def _release(holds):
    """Drop HOLDS references to a freed state, unless the host freed it more than once."""
    # held: the tuple's HOLDS, `handle` and getrefcount's argument; fewer after an extra free
    handle = holds[0]
    if sys.getrefcount(handle) != HOLDS + 2:
        OVER_FREED_HOLDS.append(holds)


def freed_states():
    """(freed FMU states kept valid, of which freed more than once), for the tests."""
    return len(FREED_HOLDS), len(OVER_FREED_HOLDS)


class StateSnapshots:
    """The FMU-state calls of `SafeSlave` (a mixin: it uses the slave's variables, logging
    and `save_state` / `load_state`)."""

    def _capture(self):
        """The instance's whole state as the dict `state_format` stores."""
        values = {}
        for variable in self.vars.values():
            if variable.setter is not None:
                convert = str if isinstance(variable, String) else float
                values[variable.name] = convert(variable.getter())
        return {"phase": self.phase, "broken": self.broken, "time": float(self.time),
                "start_time": float(self.start_time), "variables": values,
                "model": None if self.broken else self.save_state()}

    def _get_fmu_state(self):
        try:
            return FMUState(state_format.encode(self.state_identity(), self._capture()))
        except BaseException as error:  # noqa: BLE001
            reason = (f"fmi2GetFMUstate failed: {type(error).__name__}: {error}")
            self._error(f"{reason}; the state returned is empty and fmi2SetFMUstate will "
                        "refuse it")
            return FMUState(RefusedState(reason))

    def _set_fmu_state(self, state):
        """Restore `state`; False when it is refused (logged): flexure's corrected pythonfmu
        binary then answers fmi2Error, the stock one ignores the result and answers fmi2OK."""
        try:
            if isinstance(state, FMUState):
                state = state.data
            if isinstance(state, RefusedState):
                return self._refuse(f"fmi2SetFMUstate refused: {state.reason}; the instance "
                                    "is unchanged")
            if not isinstance(state, bytes):
                return self._refuse(f"fmi2SetFMUstate refused: not a state of this FMU "
                                    f"({type(state).__name__}); the instance is unchanged")
            try:
                data = state_format.decode(state, self.state_identity())
                problem = self._state_problem(data)
            except state_format.StateFormatError as error:
                problem = str(error)
            if problem:
                return self._refuse(f"fmi2SetFMUstate refused: {problem}; the instance is "
                                    "unchanged")
            before = self._capture()
            try:
                self._apply(data)
            except Exception as error:  # noqa: BLE001 -- the model refused it: roll back
                try:
                    self._apply(before)
                except Exception as inner:  # noqa: BLE001
                    self._fail(f"fmi2SetFMUstate ({error}); then restoring the "
                               "instance as it was", inner)
                    return False
                return self._refuse(f"fmi2SetFMUstate refused: the model does not accept the "
                                    f"state: {error}; the instance is unchanged")
            return True
        except BaseException as error:  # noqa: BLE001
            self._fail("fmi2SetFMUstate", error)
            return False

    def _refuse(self, message):
        """Log a refused fmi2SetFMUstate; False, the refusal flexure's binary answers."""
        self._error(message)
        return False

    def _last_successful_time(self):
        """The communication point, s: flexure's corrected pythonfmu binary asks it after
        fmi2SetFMUstate, for fmi2GetRealStatus(fmi2LastSuccessfulTime) (the stock binary
        reports the end of the last doStep until the next one)."""
        try:
            return float(self.time)
        except BaseException:  # noqa: BLE001 -- nothing may raise into the binary
            return None

    def _state_problem(self, data):
        """Why a decoded state cannot be this instance's, or None: its fields are checked as
        strictly as a host's calls would be (a forged state with a valid checksum is still
        only data)."""
        if not isinstance(data, dict) or set(data) != {"phase", "broken", "time",
                                                       "start_time", "variables", "model"}:
            return "the payload is not a SafeSlave state"
        if data["phase"] not in PHASES or not isinstance(data["broken"], str):
            return f"unknown call-sequence state {data['phase']!r}"
        for key in ("time", "start_time"):
            if not isinstance(data[key], float) or not math.isfinite(data[key]):
                return f"{key} = {data[key]!r} s: expected a finite float"
        start, time = data["start_time"], data["time"]
        if not start <= time <= start + TIME_SPAN:
            return (f"time = {time!r} s: expected a time from start_time = {start!r} s to "
                    f"{TIME_SPAN:g} s after it")
        by_name = {v.name: v for v in self.vars.values() if v.setter is not None}
        values = data["variables"]
        if not isinstance(values, dict) or set(values) != set(by_name):
            return "the variables stored are not this FMU's"
        for name, value in values.items():
            expected = str if isinstance(by_name[name], String) else float
            if not isinstance(value, expected):
                return f"variable {name!r} = {value!r}: expected a {expected.__name__}"
            if expected is float and not math.isfinite(value):
                return f"variable {name!r} = {value!r}: expected a finite number"
            problem = (None if name in self.unchecked_inputs
                       else self.check_value(name, _as_set(by_name[name], value)))
            if problem:
                return f"variable {problem}"
        return None

    def _apply(self, data):
        by_name = {v.name: v for v in self.vars.values()}
        for name, value in data["variables"].items():
            by_name[name].setter(value)
        self.time = data["time"]
        self.start_time = data["start_time"]
        self.phase = data["phase"]
        self.broken = data["broken"]
        if not self.broken:
            self.load_state(data["model"])

    @classmethod
    def _fmu_state_to_bytes(cls, state):
        # Called on the class (no instance, nothing to log to): a state is its bytes already;
        # a refused or freed one has none (deserialized, the empty bytes are refused by name).
        if isinstance(state, FMUState):
            state = state.data
        return state if isinstance(state, bytes) else b""

    @classmethod
    def _fmu_state_from_bytes(cls, data):
        # Called on the class: validated here, refused (with the reason) by fmi2SetFMUstate.
        try:
            state_format.decode(data, cls.state_identity())
            return FMUState(bytes(data))
        except state_format.StateFormatError as error:
            return FMUState(RefusedState(f"fmi2DeSerializeFMUstate: {error}"))
        except BaseException as error:  # noqa: BLE001
            return FMUState(RefusedState(f"fmi2DeSerializeFMUstate failed: "
                                         f"{type(error).__name__}: {error}"))
