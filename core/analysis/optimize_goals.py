"""The objective and constraints of `optimize`: a small grammar, parsed, never executed.

    objective   := ("max" | "min") ":" QUANTITY
    constraint  := QUANTITY ("<=" | ">=") BOUND
                 | QUANTITY "=" NUMBER "+-" NUMBER        (a target and its tolerance, >= 0)
    QUANTITY    := "frequency[" K "]"                      Hz, the K-th lowest natural frequency
                 | "buckling[" K "]"                       1, the K-th smallest buckling factor
                 | "output[" NAME "]"                      m or rad, a position output at the
                                                           static equilibrium
                 | "von_mises"                             Pa, the largest von Mises stress there
                 | "dc_gain[" IN "->" OUT "]"              the state space's DC gain
    BOUND       := NUMBER | NUMBER "*yield" | "yield"      (yield: the --yield stress, Pa, or
                                                           the sections' yield_stress)
    NUMBER      := a finite decimal number (1e-3, 30, -0.5)

    "max:frequency[2]"   "frequency[1]=30+-1"   "buckling[1]>=3"   "von_mises<=0.5*yield"

K counts from 1. Spaces are ignored. The quantities are those of `sensitivities`
(`sensitivity_quantities`), so every one has a derivative with respect to every scene key;
`Quantity.name_in` finds a quantity's row among them by name. A text that does not follow the
grammar is a UsageError naming the option and what was expected.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import UsageError

__all__ = ["Constraint", "Objective", "Quantity", "parse_constraint", "parse_objective",
           "parse_quantity", "scene_yield_stress"]

QUANTITIES = "frequency[K], buckling[K], output[NAME], von_mises or dc_gain[IN->OUT]"
_INDEXED = re.compile(r"^(?P<kind>frequency|buckling)\[(?P<k>\d+)\]$")
_NAMED = re.compile(r"^output\[(?P<name>[^\[\]]+)\]$")
_GAIN = re.compile(r"^dc_gain\[(?P<input>[^\[\]]+?)->(?P<output>[^\[\]]+)\]$")
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


@dataclass(frozen=True)
class Quantity:
    """One quantity of the grammar: `kind` ("frequency", "buckling", "output", "von_mises",
    "dc_gain"), `index` K (from 1) of a frequency or buckling factor, `name` of an output
    (or "IN->OUT" of a DC gain), and `text` as written."""

    kind: str
    text: str
    index: int = 0
    name: str = ""

    @property
    def unit(self) -> str:
        """The quantity's SI unit as a table prints it ('' where it depends on the port)."""
        return {"frequency": "Hz", "buckling": "1", "von_mises": "Pa"}.get(self.kind, "")

    def name_in(self, names: list[str]) -> int | None:
        """The row of this quantity among the `sensitivities` quantity `names`, or None."""
        wanted = {"frequency": f"frequency {self.index}",
                  "buckling": f"buckling factor {self.index}",
                  "output": f"output {self.name}", "dc_gain": f"DC gain {self.name}"}
        for row, name in enumerate(names):
            if self.kind == "von_mises" and name.startswith("largest von Mises"):
                return row
            if name == wanted.get(self.kind):
                return row
        return None


@dataclass(frozen=True)
class Objective:
    """`sense` "max" or "min" of `quantity`; `text` as written."""

    sense: str
    quantity: Quantity
    text: str


@dataclass(frozen=True)
class Constraint:
    """lower <= quantity <= upper (either bound may be None, not both); `text` as written;
    `uses_yield` when a bound was written in terms of the yield stress."""

    quantity: Quantity
    lower: float | None
    upper: float | None
    text: str
    uses_yield: bool = False


def parse_quantity(text: str, *, option: str) -> Quantity:
    """The Quantity that `text` names (module docstring); UsageError naming `option`."""
    compact = "".join(text.split())
    if compact == "von_mises":
        return Quantity("von_mises", compact)
    if indexed := _INDEXED.match(compact):
        k = int(indexed["k"])
        if k < 1:
            raise UsageError(f"{option} {text!r}: {indexed['kind']}[{k}]: K counts from 1")
        return Quantity(indexed["kind"], compact, index=k)
    if named := _NAMED.match(compact):
        return Quantity("output", compact, name=named["name"])
    if gain := _GAIN.match(compact):
        return Quantity("dc_gain", compact, name=f"{gain['input']}->{gain['output']}")
    raise UsageError(f"{option} {text!r}: unknown quantity {compact!r}; expected {QUANTITIES}")


def parse_objective(text: str) -> Objective:
    """The Objective of "max:QUANTITY" or "min:QUANTITY"; UsageError naming --objective."""
    sense, sep, rest = "".join(text.split()).partition(":")
    if not sep or sense not in ("max", "min") or not rest:
        raise UsageError(f"--objective {text!r}: expected max:QUANTITY or min:QUANTITY "
                         f"(QUANTITY {QUANTITIES}), e.g. max:frequency[2]")
    return Objective(sense, parse_quantity(rest, option="--objective"), text)


def parse_constraint(text: str, *, yield_stress: float | None = None) -> Constraint:
    """The Constraint of "Q<=BOUND", "Q>=BOUND" or "Q=TARGET+-TOL" (module docstring).

    Parameters
    ----------
    text : str
        The constraint as written.
    yield_stress : float, optional
        The yield stress (Pa) that "yield" in a bound stands for.

    Raises
    ------
    UsageError
        Naming --constraint and what is wrong: no operator, an unknown quantity, a bound that
        is no finite number, a negative tolerance, "yield" without a yield stress or on a
        quantity that is not von_mises.
    """
    compact = "".join(text.split())
    option = "--constraint"
    for operator in ("<=", ">="):
        left, sep, right = compact.partition(operator)
        if sep:
            quantity = parse_quantity(left, option=option)
            bound, uses_yield = _bound(right, text, quantity, yield_stress)
            lower, upper = (None, bound) if operator == "<=" else (bound, None)
            return Constraint(quantity, lower, upper, text, uses_yield)
    left, sep, right = compact.partition("=")
    if not sep:
        raise UsageError(f"{option} {text!r}: expected QUANTITY<=BOUND, QUANTITY>=BOUND or "
                         "QUANTITY=TARGET+-TOL, e.g. buckling[1]>=3 or frequency[1]=30+-1")
    if right[:1] in ("<", ">", "=") or left[-1:] in ("<", ">", "!"):
        raise UsageError(f"{option} {text!r}: the operators are <=, >= and =TARGET+-TOL, "
                         f"e.g. buckling[1]>=3")
    quantity = parse_quantity(left, option=option)
    target, pm, tolerance = right.partition("+-")
    if not pm:
        raise UsageError(f"{option} {text!r}: an equality needs its tolerance, "
                         f"{quantity.text}={right}+-TOL: an optimiser cannot hold a computed "
                         "quantity to an exact number")
    centre = _number(target, text, "the target")
    width = _number(tolerance, text, "the tolerance")
    if width <= 0.0:
        raise UsageError(f"{option} {text!r}: the tolerance must be > 0, got {tolerance}")
    return Constraint(quantity, centre - width, centre + width, text)


def scene_yield_stress(scene: dict) -> float | None:
    """The yield stress (Pa) the scene's sections give (`yield_stress`), or None where none
    does; UsageError where they give different ones (which would "yield" be?)."""
    given = {name: section["yield_stress"] for name, section in
             (scene.get("sections") or {}).items()
             if isinstance(section, dict) and "yield_stress" in section}
    if len(set(given.values())) > 1:
        raise UsageError("--constraint: the sections give different yield stresses ("
                         + ", ".join(f"{k}: {v:g} Pa" for k, v in given.items())
                         + "): say which with --yield PA")
    return float(next(iter(given.values()))) if given else None


def _bound(right, text, quantity, yield_stress):
    """(bound, whether it used yield) of BOUND := NUMBER | NUMBER*yield | yield."""
    factor, star, name = right.rpartition("*")
    if right == "yield" or (star and name == "yield"):
        if quantity.kind != "von_mises":
            raise UsageError(f"--constraint {text!r}: yield is a stress, so it bounds "
                             f"von_mises, not {quantity.text}")
        if yield_stress is None:
            raise UsageError(f"--constraint {text!r}: the bound uses yield but no yield stress "
                             "is given: add --yield PA (e.g. --yield 1.1e9), or give the "
                             "scene's sections yield_stress")
        scale = 1.0 if right == "yield" else _number(factor, text, "the factor of yield")
        if scale <= 0.0:
            raise UsageError(f"--constraint {text!r}: the factor of yield must be > 0, got "
                             f"{factor}")
        return scale * yield_stress, True
    return _number(right, text, "the bound"), False


def _number(part, text, what):
    """float(part), refusing anything but a finite decimal number (no names, no code)."""
    if not _NUMBER.match(part) or not math.isfinite(float(part)):
        raise UsageError(f"--constraint {text!r}: {what} must be a finite number, got "
                         f"{part!r}")
    return float(part)
