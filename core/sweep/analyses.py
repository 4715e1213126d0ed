"""The analyses a sweep runs beyond static, modes and buckling: `simulate` (here) and those
other packages register by name, such as the closed loop (`loop`, flexure.controllers).

Why a registry of names and not an import: data flows one way in flexure, from core to the
packages built on it; core never imports controllers. The closed loop belongs to controllers,
so controllers registers it, as the `flexure` subcommands register themselves: an entry point
of the group "flexure.sweep_analyses" (pyproject.toml) names a `SweepAnalysis` object. core
looks an analysis up by its name where the point runs: a Dask worker resolves the same entry
point in its own process, so a task carries names and option values (plain data), never code,
and a package outside flexure adds its own analysis the same way.

A `SweepAnalysis` has a name, its options (`SweepOption`: a name, a default, a parser from the
command line's text, a help text with the unit) and two functions of the model and the option
values: `columns` (the quantity columns it fills, "NAME.QUANTITY [UNIT]"; a UsageError if the
options do not fit the scene) and `evaluate` ({column: float}, SI units; a FlexureError naming
what failed makes the point's status). The command line offers each option as
`--ANALYSIS-OPTION` (`--simulate-t-end 0.05`, `--loop-stroke 1e-4`).

simulate: a step response from rest. The inputs are held from t = 0 (by default the scene's
first input at 1 N, or 1 N m on a rotation); for each scene output NAME:

- `simulate.NAME.final [unit]`: the output's change at t_end;
- `simulate.NAME.peak [unit]`: the change of largest magnitude (with its sign) over the
  integrator's accepted steps (flexure.core.simulate's default output grid).
"""

import importlib.metadata
import math
from dataclasses import dataclass, field

from ..errors import UsageError

__all__ = ["ENTRY_POINT_GROUP", "SIMULATE", "SweepAnalysis", "SweepOption", "available",
           "find", "option_values"]

ENTRY_POINT_GROUP = "flexure.sweep_analyses"


@dataclass(frozen=True)
class SweepOption:
    """One option of a sweep analysis; `parse(text)` raises ValueError saying what is
    expected."""

    name: str
    default: object
    parse: object
    help: str
    metavar: str = "VALUE"


@dataclass(frozen=True)
class SweepAnalysis:
    """A named analysis of one sweep point (see the module docstring)."""

    name: str
    columns: object  # (model, options dict) -> list of column names
    evaluate: object  # (model, options dict) -> {column: float}
    options: tuple = field(default_factory=tuple)

    def defaults(self) -> dict:
        """{option name: default value}."""
        return {option.name: option.default for option in self.options}


def positive(text):
    """A finite number > 0 (float), from text or a number; ValueError otherwise."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ValueError(f"expected a number > 0, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"expected a number > 0, got {text!r}")
    return value


def nonnegative(text):
    """A finite number >= 0 (float); ValueError otherwise."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ValueError(f"expected a number >= 0, got {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise ValueError(f"expected a number >= 0, got {text!r}")
    return value


def fraction(text):
    """A number in (0, 1); ValueError otherwise."""
    value = positive(text)
    if value >= 1:
        raise ValueError(f"expected a number in (0, 1), got {text!r}")
    return value


def method(text):
    """An integration method of flexure.core.METHODS."""
    from ..simulation.methods import METHODS

    if text not in METHODS:
        raise ValueError(f"expected one of {', '.join(METHODS)}, got {text!r}")
    return text


def held_inputs(text):
    """{input name: value} of "F=1" or "F=1,M=0.5" (N, or N m on a rotation); "" for the
    default (the first input at 1)."""
    if isinstance(text, dict):
        return dict(text)
    inputs = {}
    for part in filter(None, (p.strip() for p in str(text).split(","))):
        name, sep, value = part.partition("=")
        if not sep or not name.strip():
            raise ValueError(f"expected NAME=VALUE[,NAME=VALUE...], got {text!r}")
        try:
            number = float(value)
        except ValueError:
            raise ValueError(f"{part!r}: expected a number after '='") from None
        if not math.isfinite(number):
            raise ValueError(f"{part!r}: expected a finite number")
        inputs[name.strip()] = number
    return inputs


def _simulate_inputs(model, options):
    inputs = held_inputs(options["input"])
    if not inputs and model.inputs:
        return {model.inputs[0].name: 1.0}
    names = [port.name for port in model.inputs]
    for name in inputs:
        if name not in names:
            raise UsageError(f"--simulate-input {name}: the scene has no input {name!r}; its "
                             f"inputs: {', '.join(names) or '(none)'}")
    return inputs


def _simulate_columns(model, options):
    _simulate_inputs(model, options)  # a name the scene lacks is refused before the sweep
    return [f"simulate.{port.name}.{quantity} [{port.unit}]" for port in model.outputs
            for quantity in ("final", "peak")]


def _simulate(model, options):
    import numpy as np

    from ..simulation.simulation import simulate

    result = simulate(model, options["t_end"], inputs=_simulate_inputs(model, options),
                      method=options["method"], rtol=options["rtol"])
    row = {}
    for port, values in zip(model.outputs, result.output_array.T, strict=True):
        change = values - values[0]
        row[f"simulate.{port.name}.final [{port.unit}]"] = float(change[-1])
        row[f"simulate.{port.name}.peak [{port.unit}]"] = float(change[np.argmax(np.abs(
            change))])
    return row


SIMULATE = SweepAnalysis(
    name="simulate", columns=_simulate_columns, evaluate=_simulate,
    options=(
        SweepOption("t_end", 0.1, positive, "simulated time (s)", "T"),
        SweepOption("input", "", held_inputs,
                    "inputs held from t = 0, N (N m on a rotation): NAME=VALUE[,...] "
                    "(default: the first input at 1)", "NAME=VALUE"),
        SweepOption("method", "cvode-bdf", method, "integration method", "METHOD"),
        SweepOption("rtol", 1e-8, fraction, "relative tolerance of the integrator", "RTOL"),
    ))

BUILT_IN = {SIMULATE.name: SIMULATE}
_FOUND = {}  # name -> SweepAnalysis or the reason its entry point did not load


def available() -> dict:
    """{name: SweepAnalysis} of the built-in analyses and of every entry point of the group
    ENTRY_POINT_GROUP that loads (see `find` for one that does not)."""
    for entry in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        if entry.name not in _FOUND and entry.name not in BUILT_IN:
            try:
                analysis = entry.load()
                if not isinstance(analysis, SweepAnalysis) or analysis.name != entry.name:
                    raise TypeError(f"expected a SweepAnalysis named {entry.name!r}, got "
                                    f"{analysis!r}")
                _FOUND[entry.name] = analysis
            except Exception as error:  # noqa: BLE001 -- one broken plugin is not all
                _FOUND[entry.name] = f"{entry.value}: {type(error).__name__}: {error}"
    found = {name: a for name, a in _FOUND.items() if isinstance(a, SweepAnalysis)}
    return {**BUILT_IN, **found}


def find(name: str) -> SweepAnalysis:
    """The analysis registered as `name`; UsageError if there is none or it did not load."""
    analyses = available()
    if name in analyses:
        return analyses[name]
    if name in _FOUND:
        raise UsageError(f"sweep analysis {name!r} could not be loaded: {_FOUND[name]}")
    raise UsageError(f"unknown sweep analysis {name!r}; registered: {', '.join(analyses)}")


def option_values(analysis: SweepAnalysis, given: dict | None) -> dict:
    """The analysis's option values: its defaults updated by `given` {option: value or text},
    each parsed; UsageError naming an unknown option or a bad value."""
    values = analysis.defaults()
    names = {option.name: option for option in analysis.options}
    for key, value in (given or {}).items():
        if key not in names:
            raise UsageError(f"{analysis.name}: unknown option {key!r}; expected one of "
                             f"{', '.join(names) or '(none)'}")
        try:
            values[key] = names[key].parse(value)
        except ValueError as error:
            raise UsageError(f"{analysis.name} option {key}: {error}") from None
    return values
