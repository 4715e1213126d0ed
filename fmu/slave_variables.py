"""The variables of a SafeSlave: `UnitReal` (a pythonfmu Real with a unit) and the
registration of Real, Integer and String variables with FMI 2.0's defaults.

The getters and setters hold the instance weakly (`pythonfmu_workarounds.weakly_bound`), so
that fmi2FreeInstance frees it at once. Nothing here is called by pythonfmu's binary after
instantiation, so it may raise (a mistake in a slave's own __init__).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Variability, Real, String
from pythonfmu.variables import Integer, ScalarVariable

from .pythonfmu_workarounds import weakly_bound

if TYPE_CHECKING:  # names for the annotations only
    from xml.etree.ElementTree import Element


class UnitReal(Real):
    """A pythonfmu `Real` that also declares its unit (pythonfmu 0.7.0 has no unit attribute).

    The unit is written on the <Real> element; `fix_model_description` adds the matching
    <UnitDefinitions> entry.

    Parameters
    ----------
    name : str
        The variable's name.
    start : float, optional
        Its start value, in `unit`.
    unit : str, optional
        Its SI unit as FMI writes it ("m", "N", "rad/s", "N.m"); None for none.
    **kwargs
        pythonfmu's `Real` arguments (causality, variability, initial, description, getter,
        setter).
    """

    def __init__(self, name: str, start: float | None = None, *, unit: str | None = None,
                 **kwargs: Any) -> None:
        super().__init__(name, start=start, **kwargs)
        self.unit = unit

    def to_xml(self) -> Element:
        """The <ScalarVariable> element, with the unit on its <Real>.

        Returns
        -------
        xml.etree.ElementTree.Element
        """
        element = super().to_xml()
        if self.unit:
            element.find("Real").set("unit", self.unit)
        return element


class SlaveVariables:
    """The variable registration of `SafeSlave` (a pythonfmu `Fmi2Slave`)."""

    def add_real(self, name: str, *, causality: str, unit: str | None = None,
                 start: float | None = None, variability: Fmi2Variability | None = None,
                 initial: Fmi2Initial | None = None, description: str | None = None,
                 getter: Callable[[], float] | None = None,
                 setter: Callable[[float], None] | None = None) -> None:
        """Register a Real variable.

        Defaults follow FMI 2.0: inputs are continuous with a start value, outputs
        continuous and calculated, parameters fixed and exact.

        Parameters
        ----------
        name : str
        causality : {"input", "output", "parameter", "local"}
        unit : str, optional
            Its SI unit as FMI writes it ("m", "N", "rad/s", "N.m").
        start : float, optional
            The start value, in `unit`.
        variability : Fmi2Variability or its name, optional
            Default: fixed for a parameter, continuous otherwise; an input's is continuous
            or discrete (ValueError otherwise).
        initial : Fmi2Initial, optional
            Default: exact for a parameter, pythonfmu's otherwise.
        description : str, optional
        getter : callable, optional
            () -> value; default: the attribute of the same name.
        setter : callable, optional
            (value) -> None; default: set the attribute of the same name (none for an
            output).
        """
        causality = Fmi2Causality[causality]
        if variability is None:
            variability = (Fmi2Variability.fixed if causality == Fmi2Causality.parameter
                           else Fmi2Variability.continuous)
        elif isinstance(variability, str):
            variability = Fmi2Variability[variability]
        if causality == Fmi2Causality.input and variability not in (
                Fmi2Variability.continuous, Fmi2Variability.discrete):
            # a host sets an input while stepping, which FMI 2.0 allows only for these
            raise ValueError(f"{name}: an input is continuous or discrete (FMI 2.0), not "
                             f"{variability.name}")
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

    def add_integer(self, name: str, *, start: int, description: str | None = None,
                    getter: Callable[[], int] | None = None,
                    setter: Callable[[int], None] | None = None) -> None:
        """Register a fixed, exact Integer parameter (e.g. the integrator's step budget).

        Parameters
        ----------
        name : str
        start : int
        description : str, optional
        getter, setter : callable, optional
            Default: the attribute of the same name.
        """
        self._add_fixed(Integer, name, start, description, getter, setter)

    def add_string(self, name: str, *, start: str, description: str | None = None,
                   getter: Callable[[], str] | None = None,
                   setter: Callable[[str], None] | None = None) -> None:
        """Register a fixed, exact String parameter (e.g. the integration method).

        Parameters
        ----------
        name : str
        start : str
        description : str, optional
        getter, setter : callable, optional
            Default: the attribute of the same name.
        """
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

    def register_variable(self, var: ScalarVariable, nested: bool = True) -> None:
        """pythonfmu's registration, with the getter and setter holding the instance weakly
        (`weakly_bound`): fmi2FreeInstance then frees the instance at once.

        Parameters
        ----------
        var : pythonfmu.variables.ScalarVariable
        nested : bool
            pythonfmu's: whether a dotted name is an attribute path.
        """
        super().register_variable(var, nested=nested)
        var.getter = weakly_bound(var.getter, self)
        var.setter = weakly_bound(var.setter, self)


__all__ = ["SlaveVariables", "UnitReal"]
