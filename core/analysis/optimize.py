"""Design optimisation: scene keys varied within bounds for an objective under constraints.

    from flexure.core import optimize
    found = optimize("stage_planar_3dof",
                     {"sections.leaf.height": (0.3e-3, 2e-3), "sections.leaf.width": (0.01, 0.03)},
                     "max:frequency[2]", ["frequency[1]=30+-1"])
    found.x              # the optimum, one value per key (SI units)
    found.scene          # the scene dictionary with those values (scene_toml writes it)
    found.history        # one Iteration per iteration of the optimiser

The objective and constraints follow the grammar of `optimize_goals` ("max:frequency[2]",
"buckling[1]>=3", "von_mises<=0.5*yield"). Each design point is one call of `sensitivities`:
the quantities and their derivatives with respect to every varied key, analytic where the
model's matrices are linear in the key and by Richardson-extrapolated central differences
otherwise (`sensitivity`); scipy.optimize (SLSQP, or trust-constr) takes them as the exact
gradients.

Scaling, because the keys mix metres, kilograms and pascals and the quantities hertz and
pascals: the optimiser works on u in [0, 1]^n, p = lower + u (upper - lower), on the objective
divided by its magnitude at the start, and on each constraint divided by its bound's magnitude
(g = (upper - q) / |upper| >= 0, g = (q - lower) / |lower| >= 0; a bound of 0 by the
quantity's magnitude at the start). Its tolerances are then relative: `tolerance` 1e-9 stops
SLSQP when the scaled objective changes by less than that.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError, FlexureError, UsageError
from .optimize_goals import (
    Constraint,
    Objective,
    parse_constraint,
    parse_objective,
    scene_yield_stress,
)

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model
    from ..scene.api import Scene

__all__ = ["Iteration", "Optimum", "optimize"]

METHODS = ("SLSQP", "trust-constr")
TOLERANCE = 1e-9  # relative, on the scaled objective (module docstring)
MAX_ITERATIONS = 100


@dataclass(frozen=True)
class Iteration:
    """One iteration of the optimiser: its `number` (0: the start), the design point `x`
    (one value per key, SI), the `objective` quantity there (its unit), the constrained
    quantities `constraints` (one per constraint, their units), `violation` the largest
    violation of a bound relative to the bound (0 where feasible), and `evaluations` the
    design points analysed so far."""

    number: int
    x: np.ndarray
    objective: float
    constraints: np.ndarray
    violation: float
    evaluations: int


@dataclass
class Optimum:
    """The result of `optimize`: `keys`, `key_units`, `lower`, `upper`, `start` and the
    optimum `x` (SI, one per key); `objective` and `constraints` (parsed goals) with their
    `objective_value` and `constraint_values` at x, `violation` (relative, 0 where
    feasible), `success` and the optimiser's `message`, `history` (one Iteration each),
    `evaluations` (design points analysed), `method`, and `scene`: the scene dictionary with
    the keys set to x."""

    keys: list
    key_units: list
    lower: np.ndarray
    upper: np.ndarray
    start: np.ndarray
    x: np.ndarray
    objective: Objective
    constraints: list
    objective_value: float
    constraint_values: np.ndarray
    violation: float
    success: bool
    message: str
    method: str
    evaluations: int
    scene: dict
    history: list = field(default_factory=list)


def parse_variable(text: str) -> tuple[str, float, float]:
    """(KEY, lower, upper) of "KEY=LO:HI" (--vary); UsageError naming --vary otherwise."""
    key, sep, spec = "".join(text.split()).partition("=")
    low, colon, high = spec.partition(":")
    expected = (f"--vary {text!r}: expected KEY=LO:HI with a dotted scene key and two finite "
                "numbers LO < HI, e.g. sections.leaf.height=0.3e-3:2e-3")
    if not (sep and key and colon):
        raise UsageError(expected)
    try:
        lower, upper = float(low), float(high)
    except ValueError:
        raise UsageError(expected) from None
    if not (np.isfinite(lower) and np.isfinite(upper)) or lower >= upper:
        raise UsageError(expected)
    return key, lower, upper


class _Problem:
    """The scaled problem of the module docstring: one `sensitivities` call per design
    point, kept so that the objective, the constraints and their gradients at one point
    cost one analysis."""

    def __init__(self, model, keys, lower, upper, objective, constraints):
        from .sensitivity import resolve_key

        self.model, self.lower, self.upper = model, lower, upper
        self.keys = [resolve_key(model, key, option="--vary") for key in keys]
        self.objective, self.constraints = objective, constraints
        goals = [objective.quantity] + [c.quantity for c in constraints]
        self.request = {
            "modes": max([q.index for q in goals if q.kind == "frequency"], default=0),
            "buckling": max([q.index for q in goals if q.kind == "buckling"], default=0),
            "outputs": any(q.kind == "output" for q in goals),
            "stress": any(q.kind == "von_mises" for q in goals),
            "dc_gains": any(q.kind == "dc_gain" for q in goals)}
        self.cache, self.evaluations = {}, 0

    def point(self, u):
        """p of u (SI)."""
        return self.lower + np.clip(u, 0.0, 1.0) * (self.upper - self.lower)

    def overrides(self, p):
        """{scene key: value} that set the keys to p (a whole list where indexed)."""
        overrides, scene = {}, self.model.scene
        for key, value in zip(self.keys, p, strict=True):
            if key.index is None:
                overrides[key.key] = float(value)
            else:  # two indices into one list (x and y of a node) both land in it
                values = list(overrides.get(key.key, key.value_for(scene, float(value))))
                values[key.index] = float(value)
                overrides[key.key] = values
        return overrides

    def evaluate(self, u):
        """(values (1 + n_constraints,), derivatives (1 + n_constraints, n_keys)) at u: the
        objective's and the constrained quantities', SI, per key."""
        u = np.asarray(u, dtype=float)
        cached = self.cache.get(u.tobytes())
        if cached is not None:
            return cached
        from ..scene.building import build_model
        from .sensitivity import sensitivities

        p = self.point(u)
        where = ", ".join(f"{k.text}={v:.6g}" for k, v in zip(self.keys, p, strict=True))
        try:
            model = build_model(self.model.scene, overrides=self.overrides(p),
                                source=self.model.source, default_name=self.model.name)
            found = sensitivities(model, [k.text for k in self.keys], **self.request)
        except FlexureError as error:
            raise type(error)(f"{error} (at the design point {where})") from None
        goals = [self.objective] + list(self.constraints)
        rows = [goal.quantity.name_in(found.quantities) for goal in goals]
        for goal, row in zip(goals, rows, strict=True):
            if row is None:
                option = "--objective" if goal is self.objective else "--constraint"
                raise UsageError(f"{option} {goal.text!r}: the model has no "
                                 f"{goal.quantity.text} at {where}; it has "
                                 f"{', '.join(found.quantities) or 'no quantity'}")
        values, slopes = found.values[rows], found.derivatives[rows]
        if not (np.all(np.isfinite(values)) and np.all(np.isfinite(slopes))):
            raise ConvergenceError(f"a quantity or its derivative is not finite at {where}")
        self.evaluations += 1
        self.cache[u.tobytes()] = (values, slopes)
        return values, slopes


def _scales(problem, values):
    """The magnitudes that divide the objective and each constraint's bounds (docstring)."""
    def scale(bound, value):
        return abs(bound) if bound else (abs(value) or 1.0)

    objective = abs(values[0]) or 1.0
    bounds = [(scale(c.lower, v) if c.lower is not None else None,
               scale(c.upper, v) if c.upper is not None else None)
              for c, v in zip(problem.constraints, values[1:], strict=True)]
    return objective, bounds


def violation(constraints: Sequence[Constraint], values: np.ndarray) -> float:
    """The largest violation of a bound, relative to the bound (its magnitude, or 1 for a
    bound of 0); 0 when every constraint holds."""
    worst = 0.0
    for constraint, value in zip(constraints, values, strict=True):
        if constraint.lower is not None and value < constraint.lower:
            worst = max(worst, (constraint.lower - value) / (abs(constraint.lower) or 1.0))
        if constraint.upper is not None and value > constraint.upper:
            worst = max(worst, (value - constraint.upper) / (abs(constraint.upper) or 1.0))
    return float(worst)


def optimize(model_or_scene: Model | Scene | str | Path,
             vary: Mapping[str, tuple[float, float]], objective: str | Objective,
             constraints: Sequence[str | Constraint] = (), *,
             yield_stress: float | None = None, method: str = "SLSQP",
             tolerance: float = TOLERANCE, max_iterations: int = MAX_ITERATIONS,
             on_iteration: Callable[[Iteration], None] | None = None) -> Optimum:
    """Vary scene keys within bounds to maximise or minimise a quantity under constraints.

    Parameters
    ----------
    model_or_scene : Model, Scene, str or Path
        A model built from a scene, a `Scene`, or a scene file or built-in scene name.
    vary : mapping of str to (float, float)
        {scene key: (lower, upper)} in the key's SI unit, lower < upper; each a key
        `sensitivities` takes ("sections.leaf.height", "nodes.3.position[1]"). The start is
        the scene's value, moved into the bounds where outside.
    objective : str or Objective
        "max:QUANTITY" or "min:QUANTITY" (`optimize_goals`).
    constraints : sequence of str or Constraint
        "QUANTITY<=BOUND", "QUANTITY>=BOUND", "QUANTITY=TARGET+-TOL".
    yield_stress : float, optional
        The yield stress (Pa) a bound's "yield" stands for (default: the one the scene's
        sections give as yield_stress).
    method : str
        "SLSQP" or "trust-constr" (scipy.optimize.minimize).
    tolerance : float
        The optimiser's relative tolerance on the scaled objective (SLSQP's ftol,
        trust-constr's gtol and xtol).
    max_iterations : int
        The most iterations.
    on_iteration : callable, optional
        Called with each Iteration as the optimiser reports it (the start first).

    Returns
    -------
    Optimum
        The optimum, its quantities, the history and the scene with its values. An optimiser
        that stops without success (the iteration limit, an infeasible problem) still
        returns, with `success` False and its message.

    Raises
    ------
    UsageError
        A bad bound, method or goal, a quantity the model does not have.
    SceneError
        A key the scene does not give a number for.
    FlexureError
        An analysis that fails at a design point (the message names the point).
    """
    import scipy.optimize

    from ..scene.overrides import apply_overrides
    from .sensitivity import model_of

    if method not in METHODS:
        raise UsageError(f"--method {method!r}: expected one of {', '.join(METHODS)}")
    if not vary:
        raise UsageError("--vary: expected at least one KEY=LO:HI")
    model = model_of(model_or_scene)
    if yield_stress is None and any(isinstance(c, str) for c in constraints):
        yield_stress = scene_yield_stress(model.scene)
    goal = objective if isinstance(objective, Objective) else parse_objective(objective)
    limits = [c if isinstance(c, Constraint) else parse_constraint(c, yield_stress=yield_stress)
              for c in constraints]
    keys = list(vary)
    lower = np.array([float(vary[k][0]) for k in keys])
    upper = np.array([float(vary[k][1]) for k in keys])
    for key, low, high in zip(keys, lower, upper, strict=True):
        if not (np.isfinite(low) and np.isfinite(high)) or low >= high:
            raise UsageError(f"--vary {key}: expected finite bounds LO < HI, got {low}:{high}")
    problem = _Problem(model, keys, lower, upper, goal, limits)
    start = np.clip([k.value for k in problem.keys], lower, upper)
    u0 = (start - lower) / (upper - lower)
    values0, _ = problem.evaluate(u0)
    objective_scale, bound_scales = _scales(problem, values0)
    sign = -1.0 if goal.sense == "max" else 1.0
    span = upper - lower
    history = []

    def report(u):
        if history and np.array_equal(problem.point(u), history[-1].x):
            return  # SLSQP's last call when its step changed nothing
        values, _ = problem.evaluate(u)
        step = Iteration(len(history), problem.point(u), float(values[0]), values[1:].copy(),
                         float(violation(limits, values[1:])), problem.evaluations)
        history.append(step)
        if on_iteration is not None:
            on_iteration(step)

    def f(u):
        return sign * problem.evaluate(u)[0][0] / objective_scale

    def df(u):
        return sign * problem.evaluate(u)[1][0] * span / objective_scale

    def g(u):  # every bound as g >= 0, scaled
        values = problem.evaluate(u)[0][1:]
        parts = []
        for c, (low, high), v in zip(limits, bound_scales, values, strict=True):
            if c.lower is not None:
                parts.append((v - c.lower) / low)
            if c.upper is not None:
                parts.append((c.upper - v) / high)
        return np.array(parts)

    def dg(u):
        slopes = problem.evaluate(u)[1][1:] * span
        rows = []
        for c, (low, high), row in zip(limits, bound_scales, slopes, strict=True):
            if c.lower is not None:
                rows.append(row / low)
            if c.upper is not None:
                rows.append(-row / high)
        return np.array(rows).reshape(-1, len(keys))

    report(u0)
    bounds = scipy.optimize.Bounds(np.zeros(len(keys)), np.ones(len(keys)))
    if method == "SLSQP":
        options = {"ftol": tolerance, "maxiter": max_iterations}
        conditions = [{"type": "ineq", "fun": g, "jac": dg}] if limits else []
        result = scipy.optimize.minimize(f, u0, jac=df, method="SLSQP", bounds=bounds,
                                         constraints=conditions, options=options,
                                         callback=report)
    else:
        # the interior point method stops inside the feasible set; its default first barrier
        # parameter (0.1) left an active bound 3e-4 relative away, 1e-3 leaves 4e-6
        # (measured on tests/test_optimize.py's buckling bound); SLSQP meets it to round-off
        options = {"gtol": tolerance, "xtol": tolerance, "barrier_tol": tolerance,
                   "initial_barrier_parameter": 1e-3, "maxiter": max_iterations}
        conditions = ([scipy.optimize.NonlinearConstraint(g, 0.0, np.inf, jac=dg)]
                      if limits else [])
        result = scipy.optimize.minimize(f, u0, jac=df, method="trust-constr", bounds=bounds,
                                         constraints=conditions, options=options,
                                         callback=lambda u, state: report(u))
    report(result.x)  # the optimiser's answer, where it differs from its last report
    best = history[-1]
    scene = apply_overrides(model.scene, problem.overrides(best.x), source=model.source)
    return Optimum(keys=[k.text for k in problem.keys], key_units=[k.unit for k in problem.keys],
                   lower=lower, upper=upper, start=start, x=best.x, objective=goal,
                   constraints=limits, objective_value=best.objective,
                   constraint_values=best.constraints, violation=best.violation,
                   success=bool(result.success), message=str(result.message), method=method,
                   evaluations=problem.evaluations, scene=scene, history=history)
