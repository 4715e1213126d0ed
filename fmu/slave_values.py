"""The values of a SafeSlave: fmi2Get* and fmi2Set* that never raise into pythonfmu's binary.

A getter answers one value per reference, always (the binary reads exactly that many); a
reference that cannot be read gives a default (NaN, 0, false, "") and a logged error. A setter
refuses an unknown value reference, a variable of another type, an output, a fixed parameter
after initialization, or a value the model refuses (`SafeSlave.check_value`), and the instance
then enters the error state: the setter itself can only answer fmi2OK, so the next doStep
answers fmi2Discard naming the refused value (see `slave`).
"""

from __future__ import annotations

import math

from pythonfmu import Fmi2Causality, Fmi2Variability, Real, String
from pythonfmu.variables import Boolean, Integer

from .slave_states import INITIALIZATION, INSTANTIATED, STEP_COMPLETE

SETTABLE_PHASES = frozenset((INSTANTIATED, INITIALIZATION, STEP_COMPLETE))


class SlaveValues:
    """The value getters and setters of `SafeSlave` (which sets up what they use: `vars`,
    `phase`, `broken`, `_settable_inputs`, `_unchecked_reals`, `_getters`, `check_value`,
    `unchecked_inputs` and the error state's `_error`, `_illegal`, `_break`, `_fail`). Each is
    called by pythonfmu's binary and catches everything."""

    def get_real(self, vrs: list[int]) -> list[float]:
        """fmi2GetReal.

        Parameters
        ----------
        vrs : list of int
            Value references.

        Returns
        -------
        list of float
            One value per reference, in each variable's unit; NaN where it cannot be read.
        """
        try:  # the call a host makes after every doStep, without `_get`'s frame
            getters = self._getters[Real]
            return [float(getters[vr]()) for vr in vrs]
        except BaseException:  # noqa: BLE001 -- then `_get`, which names what failed
            return self._get("fmi2GetReal", vrs, Real, float, math.nan)

    def get_integer(self, vrs: list[int]) -> list[int]:
        """fmi2GetInteger.

        Parameters
        ----------
        vrs : list of int
            Value references.

        Returns
        -------
        list of int
            One value per reference; 0 where it cannot be read.
        """
        return self._get("fmi2GetInteger", vrs, Integer, int, 0)

    def get_boolean(self, vrs: list[int]) -> list[bool]:
        """fmi2GetBoolean.

        Parameters
        ----------
        vrs : list of int
            Value references.

        Returns
        -------
        list of bool
            One value per reference; False where it cannot be read.
        """
        return self._get("fmi2GetBoolean", vrs, Boolean, bool, False)

    def get_string(self, vrs: list[int]) -> list[str]:
        """fmi2GetString.

        Parameters
        ----------
        vrs : list of int
            Value references.

        Returns
        -------
        list of str
            One value per reference; "" where it cannot be read.
        """
        return self._get("fmi2GetString", vrs, String, str, "")

    def _get(self, call, vrs, kind, convert, default):
        """One value per reference, always (the binary reads exactly that many); a reference
        that cannot be read gives `default` and a logged error."""
        try:  # the common case: every reference readable and every getter answering
            getters = self._getters.get(kind)
            if getters is None:
                getters = self._readable(kind)
            return [convert(getters[vr]()) for vr in vrs]
        except BaseException:  # noqa: BLE001 -- then value by value, naming what failed
            pass
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

    def set_real(self, vrs: list[int], values: list[float]) -> None:
        """fmi2SetReal; a refused value enters the error state (module docstring).

        Parameters
        ----------
        vrs : list of int
            Value references.
        values : list of float
            One per reference, in each variable's unit.
        """
        # the call a host makes before every doStep, unchecked inputs while stepping, as one
        # store each; at a reference that is not one (the stores before it are `_set`'s
        # too) or lists that do not pair up, `_set`, which names what it refuses
        if self.phase == STEP_COMPLETE and not self.broken:
            setters = self._unchecked_reals
            try:
                for vr, value in zip(vrs, values, strict=True):
                    setter = setters.get(vr)
                    if setter is None:
                        break
                    try:
                        setter(value)
                    except BaseException as error:  # noqa: BLE001 -- as `_set` answers it
                        self._fail("fmi2SetReal", error)
                        return
                else:
                    return
            except BaseException:  # noqa: BLE001 -- lists of another length, or not lists
                pass
        self._set("fmi2SetReal", vrs, values, Real)

    def set_integer(self, vrs: list[int], values: list[int]) -> None:
        """fmi2SetInteger; a refused value enters the error state.

        Parameters
        ----------
        vrs : list of int
            Value references.
        values : list of int
            One per reference.
        """
        self._set("fmi2SetInteger", vrs, values, Integer)

    def set_boolean(self, vrs: list[int], values: list[bool]) -> None:
        """fmi2SetBoolean; a refused value enters the error state.

        Parameters
        ----------
        vrs : list of int
            Value references.
        values : list of bool
            One per reference.
        """
        self._set("fmi2SetBoolean", vrs, values, Boolean)

    def set_string(self, vrs: list[int], values: list[str]) -> None:
        """fmi2SetString; a refused value enters the error state.

        Parameters
        ----------
        vrs : list of int
            Value references.
        values : list of str
            One per reference.
        """
        self._set("fmi2SetString", vrs, values, String)

    def _set(self, call, vrs, values, kind):
        """Set values in order; the first one refused stops the call and enters the error
        state (see the module docstring: the setter itself can only answer fmi2OK)."""
        try:
            if self.broken or self.phase not in SETTABLE_PHASES:
                return self._illegal(call, "states instantiated, initialization mode and "
                                           "step complete")
            inputs = self._settable_inputs.get(kind)
            if inputs is None:
                inputs = self._settable(kind)
            for vr, value in zip(vrs, values, strict=True):
                # an input of this kind is always settable: at most its value is checked
                entry = inputs.get(vr)
                if entry is None:
                    problem = self._variable_problem(vr, kind) or self._settable_problem(vr)
                    if problem:
                        return self._break(f"{call} refused: {problem}")
                    entry = (self.vars[vr].name, self.vars[vr].setter, True)
                name, setter, checked = entry
                if checked:
                    problem = self.check_value(name, value)
                    if problem:
                        return self._break(f"{call} refused: {problem}")
                setter(value)
        except BaseException as error:  # noqa: BLE001
            self._fail(call, error)

    def _readable(self, kind):
        """{value reference: getter} of the variables of `kind` that pass the variable checks,
        kept in `_getters` (made on a kind's first get, as `_settable`)."""
        found = self._getters[kind] = {
            vr: variable.getter for vr, variable in self.vars.items()
            if variable.getter is not None and not self._variable_problem(vr, kind)}
        return found

    def _settable(self, kind):
        """{value reference: (name, setter, whether `check_value` sees its values)} of the
        inputs of `kind` that pass the variable checks, kept in `_settable_inputs` (made on a
        kind's first set, by those checks: the variables are registered in __init__, before
        any set, and an input's settability does not depend on the phase)."""
        found = self._settable_inputs[kind] = {
            vr: (variable.name, variable.setter, variable.name not in self.unchecked_inputs)
            for vr, variable in self.vars.items()
            if variable.causality == Fmi2Causality.input
            and not (self._variable_problem(vr, kind) or self._settable_problem(vr))}
        if kind is Real:
            self._unchecked_reals = {vr: setter for vr, (_, setter, checked) in found.items()
                                     if not checked}
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


def _kind_name(cls):
    for kind in (Real, Integer, Boolean, String):
        if issubclass(cls, kind):
            return kind.__name__
    return cls.__name__


def _article(word):
    return ("an " if word[:1] in "aeiou" else "a ") + word


__all__ = ["SlaveValues"]
