"""Design sensitivities: derivatives of the analyses' results with respect to scene numbers.

    from flexure.core import sensitivities
    found = sensitivities("stage_planar_3dof", ["sections.leaf.height", "sections.bar.rho_A"])
    found.derivatives        # (n_quantities, n_keys): d quantity / d key, SI units
    found.methods            # "analytic" or "central difference", per entry
    found.errors             # the difference scheme's error estimate (0 where analytic)

A key is a dotted scene key as `--set` takes it (`core/scene/overrides.py`) that the scene
gives a number for, e.g. "sections.leaf.height" (m), "nodes.3.mass" (kg), "sections.bar.rho_A"
(kg/m); a number inside a list is named by its index, "nodes.3.position[1]" (the y of node 3,
m). The quantities are those of `sensitivity_quantities` (frequencies, buckling factors,
position outputs, compliances, the largest von Mises stress, DC gains).

Two methods, chosen per key and quantity:

- analytic, where the model's stiffness and mass matrices are linear in the key and the
  quantity follows from them alone (`sensitivity_analytic`: the check, the formulas and where
  a preload rules them out);
- otherwise central differences of the full analysis: the scene is rebuilt with the key at
  p +- h and p +- h/2 and analysed again, D(h) = (F(p + h) - F(p - h)) / (2 h), and
  Richardson's extrapolation of the order-2 scheme gives the value and its error estimate,

      D = D(h/2) + (D(h/2) - D(h)) / 3,    error = |D(h/2) - D(h)| / 3 + round-off,

  round-off = ROUND_OFF max|F| / h: the analyses' results carry a relative error of about
  ROUND_OFF (eigenvalues to eps ||K||, the static equilibrium by Newton's method to round-off),
  and the difference divides it by h. The step h = `step` |p|; for a position, or a value of
  0 in m or rad, `step` times the model's length scale (m) or 1 rad, so that a node at the
  origin moves as much as any other. The modes (and buckling shapes) of the perturbed models
  are matched to the base model's by MAC before differencing, so that a derivative follows
  its mode through a crossing (`sensitivity_quantities.track`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SceneError
from .sensitivity_analytic import analytic_derivatives, nonlinearity
from .sensitivity_engine import statics_path, sweep_evaluations
from .sensitivity_quantities import Request, evaluate, tracked_values

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model
    from ..scene.api import Scene

STEP = 1e-3  # the relative step h / |p| of the difference scheme
ROUND_OFF = 1e-12  # the relative error of an analysis' results (module docstring)
ANALYTIC, DIFFERENCE = "analytic", "central difference"
INDEXED = re.compile(r"^(?P<key>.+)\[(?P<index>\d+)\]$")
LIST_UNITS = {"position": "m", "force": "N", "gravity": "m/s2"}  # units of list-valued keys


@dataclass
class Sensitivities:
    """Design sensitivities of a model's quantities to scene keys (module docstring).

    quantities, units: the quantities' names and SI units; values (n_quantities,) at the
    scene's values; keys, key_units: the scene keys and their units; derivatives
    (n_quantities, n_keys) d quantity / d key in units/key_units; methods (n_quantities,
    n_keys) "analytic" or "central difference"; errors (n_quantities, n_keys) the difference
    scheme's error estimate (same unit as the derivative; 0 where analytic); steps (n_keys,)
    h of the difference scheme, in the key's unit; worst_mac the smallest MAC of a mode
    match in the difference scheme (1 where none was made).
    """

    quantities: list
    units: list
    values: np.ndarray
    keys: list
    key_units: list
    derivatives: np.ndarray
    methods: np.ndarray
    errors: np.ndarray
    steps: np.ndarray
    worst_mac: float = 1.0

    def as_dict(self) -> dict[str, object]:
        """The sensitivities as plain lists (the `--json` entry `sensitivity`).

        Returns
        -------
        dict
            "quantities", "units", "values", "keys", "key_units", "derivatives" (one row per
            quantity), "methods", "errors", "steps", "worst_mac"; SI units.
        """
        return {"quantities": self.quantities, "units": self.units,
                "values": self.values.tolist(), "keys": self.keys,
                "key_units": self.key_units, "derivatives": self.derivatives.tolist(),
                "methods": self.methods.tolist(), "errors": self.errors.tolist(),
                "steps": self.steps.tolist(), "worst_mac": self.worst_mac}


@dataclass(frozen=True)
class Key:
    """A scene key resolved on a scene: the dotted key, the index into a list value (or
    None), the value p, its unit, and whether it is a position component."""

    text: str
    key: str
    index: int | None
    value: float
    unit: str

    def value_for(self, data, number):
        """The override that sets this key to `number` (a whole list where indexed)."""
        if self.index is None:
            return number
        from ..scene.overrides import declared_value

        values = list(declared_value(data, self.key))
        values[self.index] = number
        return values


def resolve_key(model: Model, text: str, *, option: str = "--sensitivity") -> Key:
    """The scene key `text` of `model`'s scene, checked: the override checks (a table of the
    scene format, a name the scene declares), a value the scene gives, and a number (an
    element of a list named by its index). SceneError naming the key otherwise."""
    from ..scene.building import scene_key
    from ..scene.overrides import declared_value

    source = model.source
    if not isinstance(text, str):
        raise SceneError(f"{source}: {option}: expected a dotted scene key, got {text!r}")
    indexed = INDEXED.match(text)
    key, index = (indexed["key"], int(indexed["index"])) if indexed else (text, None)
    value = declared_value(model.scene or {}, key, source=source, option=option)

    def refuse(what):
        raise SceneError(f"{source}: {option} {text}: {what}; a derivative needs a number")

    if index is not None:
        if not isinstance(value, list):
            refuse(f"{key} is not a list, so it has no element [{index}]")
        if index >= len(value):
            refuse(f"{key} has {len(value)} elements, so no element [{index}]")
        value = value[index]
    elif isinstance(value, list):
        numbers = all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        refuse(f"the value is a list of {len(value)}" + (
            f" numbers; name one element, e.g. {text}[0]" if numbers and value else
            f", {value!r}"))
    if isinstance(value, bool) or not isinstance(value, int | float):
        refuse(f"the value is {type(value).__name__} {value!r}")
    if key.startswith("elements.") and key.endswith(".segments"):
        refuse("segments is a count of elements")
    if not np.isfinite(value):
        refuse(f"the value is {value}")
    schema = scene_key(key, model)
    last = key.rpartition(".")[2]
    unit = schema.unit if schema is not None else LIST_UNITS.get(last, "?")
    return Key(text, key, index, float(value), unit)


def _build(model, key, number):
    """The model of `model`'s scene with `key` set to `number`."""
    from ..scene.building import build_model

    override = {key.key: key.value_for(model.scene, number)}
    return build_model(model.scene, overrides=override, source=model.source,
                       default_name=model.name)


def _linearity_models(model, key, d):
    """The models at p + d and p + 2 d that `nonlinearity` compares with the base, or None
    where the key cannot be linear: a position (the geometry), or a model that cannot be built
    there (an element of zero length, a value out of its range)."""
    from ..errors import FlexureError

    if key.key.endswith(".position"):
        return None
    try:
        return [_build(model, key, key.value + k * d) for k in (1, 2)]
    except FlexureError:
        return None


def difference_step(model: Model, key: Key, step: float = STEP) -> float:
    """h of the difference scheme for `key` (module docstring), in the key's unit; SceneError
    where a value of 0 has no scale to take a relative step of."""
    from ..mechanics.scales import length_scale

    if key.key.endswith(".position") or (key.value == 0.0 and key.unit == "m"):
        return step * length_scale(model)
    if key.value == 0.0 and key.unit == "rad":
        return step
    if key.value == 0.0:
        raise SceneError(f"{model.source}: --sensitivity {key.text}: the value is 0, so a "
                         "step relative to it is 0: give it a value to differentiate at")
    return step * abs(key.value)


def central_difference(model: Model, key: Key, base, request: Request,
                       step: float = STEP, *, compiled: bool | None = None,
                       ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(derivatives, error estimates, h, the smallest MAC) of every quantity of `base` with
    respect to `key` by Richardson-extrapolated central differences (module docstring);
    `compiled` the statics' path of the perturbed models' evaluations (`evaluate`)."""
    h = difference_step(model, key, step)
    values, worst = {}, 1.0
    for offset in (-h, -h / 2, h / 2, h):
        other = evaluate(_build(model, key, key.value + offset), request, compiled=compiled)
        values[offset], mac = tracked_values(base, other)
        worst = min(worst, mac)
    coarse = (values[h] - values[-h]) / (2.0 * h)
    fine = (values[h / 2] - values[-h / 2]) / h
    largest = np.max(np.abs(np.stack(list(values.values()))), axis=0)
    error = np.abs(fine - coarse) / 3.0 + ROUND_OFF * largest / h
    return fine + (fine - coarse) / 3.0, error, h, worst


def sensitivities(model_or_scene: Model | Scene | str | Path, keys: list[str], *,
                  modes: int = 6, buckling: int = 0, outputs: bool = True,
                  stress: bool = True, compliance_nodes: tuple[str, ...] = (),
                  dc_gains: bool = True, step: float = STEP,
                  compiled: bool | None = None) -> Sensitivities:
    """The derivatives of a model's quantities with respect to scene keys.

    Parameters
    ----------
    model_or_scene : Model, Scene, str or Path
        A model built from a scene (`load_scene`, `build_model`: it keeps its scene), a
        `Scene`, or a scene file or built-in scene name.
    keys : list of str
        Dotted scene keys the scene gives a number for ("sections.leaf.height", m;
        "nodes.3.mass", kg), or an element of a list ("nodes.3.position[1]", m).
    modes : int
        How many of the lowest natural frequencies (Hz); 0 for none.
    buckling : int
        How many of the smallest buckling load factors; 0 for none.
    outputs : bool
        Whether to include the position outputs at the static equilibrium (m, rad).
    stress : bool
        Whether to include the largest von Mises stress at the equilibrium (Pa).
    compliance_nodes : tuple of str
        The nodes whose compliance matrix entries (m/N, rad/(N m), ...) to include.
    dc_gains : bool
        Whether to include the state space's DC gains (outputs per input).
    step : float
        The difference scheme's relative step h / |p| (module docstring).
    compiled : bool, optional
        The static solves (and after them the linearisations) through the compiled engine
        (True), the numpy `Mechanics` (False), or by the sweep's rule (None, the default:
        `sensitivity_engine.preferred`, else each analysis' own).

    Returns
    -------
    Sensitivities
        Values, derivatives (n_quantities, n_keys), methods and error estimates.

    Raises
    ------
    SceneError
        A key the scene does not give a number for (the message names it).
    ConvergenceError
        An analysis of the model, or of a perturbed one, does not converge.
    """
    model = model_of(model_or_scene)
    if model.kinematic_inputs:  # its analytic slopes are on all of q, the analyses on q_f
        raise SceneError(f"{model.source}: design sensitivities of a model with kinematic "
                         f"inputs ({', '.join(p.name for p in model.kinematic_inputs)}) are "
                         "not supported yet; make them DOFs with force inputs instead")
    resolved = [resolve_key(model, key) for key in keys]  # every key checked before a solve
    request = Request(modes=modes, buckling=buckling, outputs=outputs, stress=stress,
                      compliance_nodes=tuple(compliance_nodes), dc_gains=dc_gains)
    compiled = statics_path(model, sweep_evaluations(len(resolved)), compiled)
    base = evaluate(model, request, compiled=compiled)
    n, m = len(base.names), len(resolved)
    derivatives, errors = np.zeros((n, m)), np.zeros((n, m))
    methods = np.full((n, m), ANALYTIC, dtype=object)
    steps, worst = np.zeros(m), 1.0
    preloaded = bool(np.any(model.loads) or np.any(model.gravity))
    for j, key in enumerate(resolved):
        analytic = np.zeros(n, dtype=bool)
        d = abs(key.value) or 1.0  # any d: the quantities checked are affine in p
        stepped = _linearity_models(model, key, d)
        if stepped and not nonlinearity((model, *stepped)):
            derivatives[:, j], analytic = analytic_derivatives(base, stepped[0], d,
                                                               preloaded=preloaded)
        steps[j] = difference_step(model, key, step) if not analytic.all() else 0.0
        if not analytic.all():
            slope, error, _, mac = central_difference(model, key, base, request, step,
                                                      compiled=compiled)
            derivatives[~analytic, j] = slope[~analytic]
            errors[~analytic, j] = error[~analytic]
            methods[~analytic, j] = DIFFERENCE
            worst = min(worst, mac)
    return Sensitivities(quantities=base.names, units=base.units, values=base.values,
                         keys=[k.text for k in resolved], key_units=[k.unit for k in resolved],
                         derivatives=derivatives, methods=methods, errors=errors,
                         steps=steps, worst_mac=worst)


def model_of(model_or_scene):
    """A Model with its scene dictionary from what `sensitivities` accepts."""
    from ..model import Model
    from ..scene.api import Scene
    from ..scene.building import load_scene

    if isinstance(model_or_scene, Model):
        model = model_or_scene
    elif isinstance(model_or_scene, Scene):
        model = model_or_scene.build()
    elif isinstance(model_or_scene, str | Path):
        model = load_scene(model_or_scene)
    else:
        raise TypeError(f"sensitivities: expected a Model, a Scene or a scene name or path, "
                        f"got {type(model_or_scene).__name__}")
    if model.scene is None:
        raise SceneError(f"{model.source}: sensitivities: model {model.name!r} keeps no scene "
                         "to rebuild with a changed value (build it from a scene)")
    return model
