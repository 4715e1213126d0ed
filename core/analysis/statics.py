"""Static equilibrium: load steps and Newton's method on the DOFs.

The load (nodal forces and gravity, and the inputs when given) is applied in `load_steps`
equal increments (one, when there is no load); in each the generalised force
Q(q) = DF^T (f - De^T sigma) is driven to zero by Newton's method with the full tangent
stiffness K0 + G0 (quadratic convergence). A step that does not converge is halved up to four
times; then ConvergenceError names the load step and the load factor.

Each load step after the first starts on the quadratic through the path so far: with q0, q1
the equilibria at the load factors s0 < s1 and dq1 Newton's first step to s2 = s1 + h2 from
q1 (dq1 = h2 q'(s1), the tangent at q1, since Q is affine in the load factor),

    q(s2) ~ q1 + dq1 + (h2 / h1)^2 (q0 - q1 + (h1 / h2) dq1),        h1 = s1 - s0,

the quadratic with q(s0) = q0, q(s1) = q1, q'(s1) = dq1 / h2 (error O(h^3) where the tangent
alone leaves O(h^2)). The statics tangent is exact (tests/test_static_tangent.py), but the
thin flexures' stiff directions make Q strongly nonlinear in q: on the manipulator's 6 mm
workspace poses the tangent predictor left residuals that took up to 15 Newton iterations or
failed, and the curvature term removes about a sixth of those iterations (286 -> 236).

A caller that solves several equilibria along one path of loads (the same loads, inputs and
motions times s) passes those it has as `path`, (s, solution) pairs: the stepping then starts
at the largest s below 1, the unloaded configuration being the path's point at s = 0, and its
first step takes the curvature from the point before (negative s for the opposite loads).
The manipulator's workspace solves each 6 mm pose from its 3 mm pose (the first half of its
load, which the pose had stepped through again), 8 to 24 Newton iterations instead of 17 to
33. A load step short of the full load, only the next one's start, converges to
INTERMEDIATE_TOLERANCE (1e-6 of each DOF's unit); the last one to `tolerance`.

Convergence: every |dq_j| within `tolerance` of its own unit: a length DOF of the model's length
scale L (m), an angle of 1 rad, with a floor 8 eps of its magnitude (`mechanics.scales`).

Held inputs (`inputs`) put their steady values on their ports: a force or moment input its
value (N, N m); an input a voice-coil actuator drives its actuator's force or moment at rest
(`flexure.core.mechanics.actuators.steady_port_values`): Km sat(G u) for a current drive,
Km sat(G u) / R for a voltage drive, whose coil current settles at sat(G u) / R.

Kinematic inputs (`flexure.core.mechanics.motions`) hold their prescribed values (`motions`,
default the scene's), stepped with the load from the scene's configuration; Newton then runs
on the DOFs proper q_f with K_ff dq_f = Q_f - K_fk dq_k, and the solution carries the force
that realises each input, F = -Q_k (`StaticSolution.input_efforts`).

Q and K come from the compiled engine (`static_engine`: its kinematics, forces and tangent
at rest) or from the numpy `Mechanics`, the reference the tests compare it with (equilibria
within 1e-10 of each DOF's unit, tests/test_static_engine.py); `compiled` chooses, by default
the engine where it is the faster (`static_engine.preferred`: from 300 free coordinates; from
240 DOFs its Newton step is the sparse saddle-point system's, `static_engine.sparse_step`,
without DF and the dense K). Either way the solution's configuration (De, DF and J's
factors, which the linear analyses take) and stress resultants are the numpy kinematics' at
the equilibrium's coordinates. On the numpy path of a large model (`Mechanics.sparse`)
Newton's step comes, by default, from the sparse augmented system on the coordinates instead
of K and Q on the DOFs (`static_augmented`: the same step to round-off, without DF and the
dense tangent in the iterations, and without projecting the iterates onto the constraints;
`augmented` chooses).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError
from ..mechanics.actuators import steady_port_values
from ..mechanics.element_outputs import element_output_values
from ..mechanics.mechanics import Mechanics
from ..mechanics.motions import input_effort, motion_values
from ..mechanics.ports import input_values
from ..mechanics.scales import dof_tolerances, within
from ..numerics.blas import blas_threads
from .static_augmented import AugmentedBalance
from .static_engine import EnginePoint, engine_balance, preferred, supports

if TYPE_CHECKING:  # names for the annotations only
    from ..mechanics.kinematics import Configuration
    from ..model import Model


INTERMEDIATE_TOLERANCE = 1e-6  # relative, the load steps short of the full load
# the largest share of non-zero entries of a tangent that `tangent_step` solves sparse
SPARSE_TANGENT = 0.1

@dataclass
class StaticSolution:
    """A static equilibrium: DOFs q, coordinates x, deformations e and stress resultants."""

    model: Model
    config: Configuration
    stress_resultants: np.ndarray  # (NE,) N (truss, elongation), N (bending, as e2, e3 are m)
    load_factor: float
    iterations: int
    # the held inputs (n_inputs,) N, N m, or V for an actuator's drive signal, if any
    inputs: np.ndarray | None = None
    # the values they hold on their ports (n_inputs,) N, N m: the forces and moments, and the
    # actuators' at rest (`actuators.steady_port_values`); what the load stiffness takes
    port_values: np.ndarray | None = None
    # the values the kinematic inputs hold (n_kinematic,) m or rad, and the generalised force
    # that realises each, N or N m (`motions.input_effort`); empty without kinematic inputs
    motions: np.ndarray | None = None
    input_efforts: np.ndarray | None = None

    def element_outputs(self) -> dict[str, float]:
        """The outputs on elements ([outputs.NAME] element, deformation, quantity), by name.

        Returns
        -------
        dict of str to float
            {output name: m for a deformation, N for a stress resultant}.
        """
        values = element_output_values(self.model, self.config.e, self.stress_resultants)
        return dict(zip([port.name for port in self.model.element_outputs], values.tolist(),
                        strict=True))

    def efforts(self) -> dict[str, float]:
        """The force that realises each kinematic input, by name.

        Returns
        -------
        dict of str to float
            {input name: N on a translation or deformation, N m on a planar angle}.
        """
        names = [port.name for port in self.model.kinematic_inputs]
        return dict(zip(names, np.asarray(self.input_efforts).tolist(), strict=True))

    @property
    def q(self) -> np.ndarray:
        """The DOFs (NDOF,) at the equilibrium, m or rad."""
        return self.config.q

    @property
    def x(self) -> np.ndarray:
        """The nodal coordinates (NX,) at the equilibrium, m or rad (Euler parameters
        unitless)."""
        return self.config.x

    def coordinates(self) -> dict[str, float]:
        """The coordinates by name.

        Returns
        -------
        dict of str to float
            {"NODE.COORD": value} in m and rad (Euler parameters unitless).
        """
        return dict(zip(self.model.coordinate_names, self.config.x.tolist(), strict=True))

    def stresses(self) -> dict[str, float]:
        """The stress resultants by deformation name.

        Returns
        -------
        dict of str to float
            {"ELEMENT.eK": stress resultant}, N: every deformation is a length, so a
            bending or torsion resultant is a moment over l0.
        """
        return dict(zip(self.model.deformation_names, self.stress_resultants.tolist(),
                        strict=True))


@blas_threads()
def static_equilibrium(model: Model, *, loads: np.ndarray | None = None, load_steps: int = 10,
                       tolerance: float = 1e-11, max_iterations: int = 30,
                       mechanics: Mechanics | None = None,
                       inputs: dict | np.ndarray | None = None,
                       motions: dict | np.ndarray | None = None,
                       start: StaticSolution | None = None,
                       path: Sequence[tuple[float, StaticSolution]] = (),
                       compiled: bool | None = None,
                       augmented: bool | None = None) -> StaticSolution:
    """Solve the static equilibrium of `model` under its loads, stepped with Newton.

    Parameters
    ----------
    model : Model
    loads : ndarray (NX,), optional
        Nodal forces on the coordinates, N (N m on rotations), instead of the scene's loads
        (gravity is applied either way).
    load_steps : int
        Equal load increments (one when there is no load).
    tolerance : float
        Convergence when every |dq_j| <= tolerance times its unit (relative: m through the
        length scale, rad through 1; `mechanics.scales.dof_tolerances`).
    max_iterations : int
        Newton iterations per load step before the step is halved.
    mechanics : Mechanics, optional
        The model's mechanics to reuse (default: a new one).
    inputs : dict of str to float or ndarray (n_inputs,), optional
        Held inputs, stepped with the loads: N, N m for a force or moment, V for the drive
        signal of an input a voice-coil actuator drives. A force acts on its coordinate, a
        moment about a global axis through its generalised force on the Euler parameters
        (`flexure.core.mechanics.ports`; it depends on the orientation, so it cannot be
        given as `loads`), an actuator by its force or moment at rest (module docstring).
    motions : dict of str to float or ndarray (n_kinematic,), optional
        The values the kinematic inputs hold, m or rad (`motions.motion_values`; default the
        scene's `value`s), stepped with the loads.
    start : StaticSolution, optional
        An equilibrium of the same model under nearby loads and inputs, where Newton starts
        at the full load (a path of equilibria, e.g. inverse statics along a move); if it
        does not converge from there, the load is stepped from the unloaded configuration.
    path : sequence of (float, StaticSolution), optional
        Equilibria on the path of these loads, inputs and motions: (s, the equilibrium under
        s times them), s < 1 and s != 0 (negative: the opposite loads), the same model. The
        stepping starts at the largest s (or the unloaded configuration at s = 0), with the
        curvature of the point before it (module docstring).
    compiled : bool, optional
        Evaluate the balance and its tangent through the compiled engine (True:
        `static_engine`) or through the numpy `Mechanics`, the plain reference (False).
        Default: the engine where it is the faster (`static_engine.preferred`: from 300
        free coordinates). A model the engine does not take
        (`static_engine.supports`), and an unloaded one (one Newton step, module
        docstring), take the numpy path either way.
    augmented : bool, optional
        On the numpy path, Newton's step from the sparse augmented system on the
        coordinates (True: `static_augmented`, a model on the sparse mechanics only) or
        from the reduced tangent on the DOFs (False). Default: augmented where the
        mechanics are sparse (from 300 free coordinates).

    Returns
    -------
    StaticSolution
        The DOFs and coordinates (m, rad), stress resultants (N) and the held inputs.

    Raises
    ------
    ConvergenceError
        A load step does not converge after four halvings (it names the step and the load
        factor).
    SceneError
        `inputs` or `motions` names an unknown input or has the wrong length.
    ValueError
        A `path` point at s >= 1 or s = 0, or of another model.
    """
    held = values = None
    if inputs is not None:
        held = input_values(model, inputs)
        values = steady_port_values(model, held) if model.actuators else held
    mech = mechanics or Mechanics(model)
    steps = dof_tolerances(model, tolerance)  # (NDOF,) m or rad
    # a load step short of the full load is only the next one's start: converged to 1e-6 of
    # each DOF's unit, two or three iterations fewer than to `tolerance`
    loose = dof_tolerances(model, max(tolerance, INTERMEDIATE_TOLERANCE))
    target = motion_values(model, motions)
    prescribed = model.prescribed_dofs
    x0 = model.initial_coordinates
    q0 = mech.kinematics.dofs_of(x0)
    # the prescribed values go from the scene's configuration to `target` with the load
    first = q0[prescribed]
    # Without loads and gravity there is nothing to step: the reference configuration (all
    # deformations zero) balances, and one Newton step at full load confirms it.
    unloaded = (not np.any(mech.external_force(x0, 1.0, loads, values))
                and np.array_equal(first, target))
    # That one step is the numpy path's, as cheap as the engine's there (no packing), and
    # with the numpy tangent: a mechanism's (a kinematic scene such as manipulator_stage)
    # is singular, and the step from its zero force is round-off either way.
    engine = preferred(model) if compiled is None else compiled and supports(model)
    engine = engine and not unloaded
    if augmented is None:
        augmented = mech.sparse
    if engine:
        balance = engine_balance(model)
    elif augmented:
        balance = AugmentedBalance(mech)
    else:
        balance = _PlainBalance(mech)

    def solution(point, iterations):
        # the configuration and stress resultants reported: the numpy kinematics' first order
        # (De, DF, J's factors, which the linear analyses take) at the engine's coordinates,
        # or where the augmented steps left DF out
        config = point
        if isinstance(point, EnginePoint) or point.DF is None:
            config = mech.kinematics.configuration(point.q, point.x)
        Q, _, sigma = mech.static_balance(config, 1.0, loads, values)
        return StaticSolution(model, config, sigma, 1.0, iterations, held, values,
                              target, input_effort(model, Q))

    if start is not None:
        try:
            config, iterations = _newton(balance, start.config, 1.0, loads, values, target,
                                         steps, max_iterations)
        except ConvergenceError:
            pass
        else:
            return solution(config, iterations)
    # (the shared one: Newton's steps make new configurations, none is changed in place)
    config = EnginePoint(q0, x0.copy()) if engine else mech.initial_configuration(shared=True)
    total_iterations = 0
    factor, step = 0.0, 1.0 if unloaded else 1.0 / load_steps
    # the path's points by load factor, the unloaded configuration at 0; the stepping starts
    # at the last, the one before it (DOFs, load factor) gives the curvature
    points = sorted([(0.0, config), *_path_points(model, path)], key=lambda point: point[0])
    behind = (points[-2][1].q, points[-2][0]) if len(points) > 1 else None
    factor, config = points[-1]
    halvings = 0
    step_number = 0
    while factor < 1.0 - 1e-12:
        target_factor = min(1.0, factor + step)
        predictor = None
        if behind is not None:  # (q0, h2 / h1): module docstring
            predictor = (behind[0], (target_factor - factor) / (factor - behind[1]))
        try:
            reached, iterations = _newton(balance, config, target_factor, loads, values,
                                          first + target_factor * (target - first),
                                          steps if target_factor > 1.0 - 1e-12 else loose,
                                          max_iterations, curvature=predictor)
        except ConvergenceError as error:
            if halvings == 4:
                raise ConvergenceError(
                    f"{model.source}: static equilibrium of {model.name!r} did not converge in "
                    f"load step {step_number + 1} (load factor {factor:.4g} -> "
                    f"{target_factor:.4g}, "
                    f"after {halvings} step halvings): {error}"
                ) from None
            # half the increment tried: from a path point the nominal step may reach past
            # the full load, and halving it alone would try the same target again
            step = 0.5 * (target_factor - factor)
            halvings += 1
            continue
        total_iterations += iterations
        behind = (config.q, factor)
        config, factor = reached, target_factor
        step_number += 1
    return solution(config, total_iterations)


def _path_points(model, path):
    """[(s, Configuration)] of `path` (static_equilibrium's parameter), checked."""
    points = []
    for s, solution in path:
        if not (s < 1.0 and s != 0.0) or solution.model is not model:
            raise ValueError(f"a path point of {model.name!r} needs 0 != s < 1 and the same "
                             f"model, got s = {s} and model {solution.model.name!r}")
        points.append((float(s), solution.config))
    return points


def curvature_step(before: np.ndarray, q: np.ndarray, step: np.ndarray,
                   ratio: float) -> np.ndarray:
    """Newton's first step of a load step, with the curvature of the path added.

    Parameters
    ----------
    before, q : ndarray (n,)
        The equilibria at the load factors s0 and s1 (m or rad).
    step : ndarray (n,)
        Newton's first step from q to the load factor s2 = s1 + h2 (m or rad): the tangent
        predictor h2 q'(s1).
    ratio : float
        h2 / h1, with h1 = s1 - s0 (unitless, positive).

    Returns
    -------
    ndarray (n,)
        The step to the quadratic through (s0, before) and (s1, q) with the slope step / h2
        at s1, evaluated at s2 (module docstring), m or rad.
    """
    return step + ratio**2 * (before - q + step / ratio)


def _newton(balance, config, load_factor, loads, values, prescribed_values, step_tolerance,
            max_iterations, *, curvature=None):
    """Newton's method at one load factor from config (a solved configuration: its q and
    x); balance: the engine's (`static_engine.EngineBalance`; its own step on the free DOFs
    where it steps sparse), the numpy `_PlainBalance` or the augmented
    `static_augmented.AugmentedBalance` (its own step on the free DOFs);
    values: the inputs' port values (N, N m); prescribed_values (n_kinematic,) the kinematic
    inputs' (m, rad), reached in the first step; step_tolerance (NDOF,) the largest
    converged |dq_j| (m or rad); curvature, if given, (q0 (NDOF,), h2 / h1): the equilibrium
    before config's and the ratio of the load steps, whose quadratic term is added to the
    first step on the DOFs proper (module docstring). Returns (the solved configuration,
    iterations)."""
    model = balance.model
    free, prescribed = model.free_dofs, model.prescribed_dofs
    balance.set_load(load_factor, loads, values)
    for iteration in range(1, max_iterations + 1):
        # Q - K dq = 0 on the DOFs proper, dq_k the move of the prescribed values
        dq = np.zeros(model.ndof)
        dq[prescribed] = prescribed_values - config.q[prescribed]
        if isinstance(balance, AugmentedBalance) or getattr(balance, "sparse", False):
            dq[free] = balance.free_step(config, dq)
        else:
            Q, K = balance.residual_and_tangent(config)
            if prescribed.size:
                dq[free] = tangent_step(K[np.ix_(free, free)], Q[free]
                                        - K[np.ix_(free, prescribed)] @ dq[prescribed])
            else:  # (no copy of a large K)
                dq = tangent_step(K, Q)
        if not np.all(np.isfinite(dq)):
            raise ConvergenceError("the tangent stiffness is singular")
        as_stepped = True  # dq is the balance's own step, unchanged
        if iteration == 1 and curvature is not None:
            before, ratio = curvature
            dq[free] = curvature_step(before[free], config.q[free], dq[free], ratio)
            as_stepped = False
        config = balance.moved(config, config.q + dq, as_stepped=as_stepped)
        if within(dq, step_tolerance, magnitudes=config.q):
            return balance.solved(config), iteration
    raise ConvergenceError(f"Newton did not converge in {max_iterations} iterations "
                           f"(last |dq| = {np.max(np.abs(dq)):.3e})")


def tangent_step(K: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """The solution dq of K dq = rhs: by a sparse LU where at most SPARSE_TANGENT of K's
    entries are not zero (a model whose DOFs are mostly its elements' deformations: 3.6 % on
    the 816-DOF manipulator, whose dense solve cost more than the engine's evaluation and
    tangent together), else by the dense LU.

    Parameters
    ----------
    K : ndarray (n, n)
        The tangent stiffness on the DOFs proper, N/m (N m/rad on an angle DOF).
    rhs : ndarray (n,)
        N or N m.

    Returns
    -------
    ndarray (n,)
        m or rad.

    Raises
    ------
    ConvergenceError
        K is singular.
    """
    try:
        if np.count_nonzero(K) <= SPARSE_TANGENT * K.size:
            from scipy.sparse import csc_matrix
            from scipy.sparse.linalg import splu

            return splu(csc_matrix(K)).solve(rhs)
        return np.linalg.solve(K, rhs)
    except (np.linalg.LinAlgError, RuntimeError):  # splu: "Factor is exactly singular"
        raise ConvergenceError("the tangent stiffness is singular") from None


class _PlainBalance:
    """The static balance and its tangent through the numpy `Mechanics`, the reference of
    the engine's (`static_engine.EngineBalance`, the same methods): configurations are the
    numpy kinematics' `Configuration`s, solved as soon as they are moved."""

    def __init__(self, mech):
        self.mech, self.model = mech, mech.model
        self._load = (1.0, None, None)

    def set_load(self, load_factor, loads=None, values=None):
        """The load factor (unitless), nodal loads (NX,) N and port values (n_inputs,) N,
        N m of the next balances."""
        self._load = (load_factor, loads, values)

    def residual_and_tangent(self, config):
        """Q (NDOF,) N or N m and K = -dQ/dq (NDOF, NDOF) at config."""
        load_factor, loads, values = self._load
        Q, _, sigma = self.mech.static_balance(config, load_factor, loads, values)
        return Q, self.mech.tangent_stiffness(config, sigma, load_factor, inputs=values)

    def moved(self, config, q, *, as_stepped=False):
        """The configuration at DOFs q (m, rad), solved from config's coordinates (every
        iterate is projected, whatever step made it: as_stepped is not needed here)."""
        return self.mech.kinematics.solve(q, config.x)

    def solved(self, config):
        return config
