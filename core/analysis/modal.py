"""Natural frequencies, mode shapes and linear buckling load factors.

Frequencies solve (K0 + G0) phi = omega^2 M0 phi (symmetric-definite, `symmetric_definite_eigh`);
mode shapes are normalised to unit modal mass and given on the DOFs and on all coordinates
(DF phi). A negative frequency marks an unstable (divergent) mode, omega^2 < 0. They are the
mechanical frequencies: voice-coil actuators count as open coils (no current, no back-EMF
force); their damping and the coils' poles are in the state space (`statespace`).

Buckling load factors solve K0 phi + lambda G0 phi = 0 with G0 the geometric stiffness of the
reference load at its equilibrium, as SPACAR's eig(-K0, G0); computed as the symmetric
problem -G0 phi = (1 / lambda) K0 phi so that a singular G0 (DOFs the load does not soften)
causes no trouble. Positive factors only, smallest first.

K0 and G0 come from the compiled engine where the statics solved the equilibrium through it
with the dense step, which packs its reduced form (`linear_engine.preferred`: from 300 free
coordinates up to 240 DOFs, `static_engine`): K0 = DeF_s^T S DeF_s with DeF = De DF (the
solution's De, the engine's DF), G0 = (K0 + G0 of OP_TANGENT at the equilibrium, qddot = 0) - K0,
with the stress resultants of the reference load (`linear_engine.engine_matrices`, which
holds the solution by its own De^T sigma). Elsewhere (smaller and larger models, kinematic
inputs with actuators, gravity on element masses that hang on rotations) they come from the
numpy `Mechanics`, the plain reference; `compiled` chooses. The two agree within 1e-8 relative in
the load factors on every built-in scene with a reference load (measured 2.4e-9 and below:
tests/test_buckling_engine.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError
from ..mechanics.mechanics import Mechanics
from ..mechanics.motions import held
from ..numerics.blas import blas_threads
from ..numerics.symmetric_definite import symmetric_definite_eigh
from . import linear_engine
from .linearization import LinearModel, linearize
from .statics import static_equilibrium

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model


@dataclass
class Modes:
    """Natural frequencies (Hz) and mass-normalised mode shapes."""

    frequencies_hz: np.ndarray  # (n,)
    shapes: np.ndarray  # (NDOF, n) on the DOFs
    coordinate_shapes: np.ndarray  # (NX, n) on all coordinates
    linear_model: LinearModel


@blas_threads()
def natural_frequencies(model: Model, count: int | None = None, *,
                        linear_model: LinearModel | None = None) -> Modes:
    """The lowest natural frequencies and mass-normalised mode shapes of `model`.

    Parameters
    ----------
    model : Model
    count : int, optional
        How many, lowest first (default: all NDOF).
    linear_model : LinearModel, optional
        The linearisation to use (default: at the static equilibrium under the scene's
        loads).

    Returns
    -------
    Modes
        Frequencies in Hz (negative for an unstable mode, omega^2 < 0), shapes on the DOFs
        and on all coordinates, normalised to unit modal mass (kg).

    Raises
    ------
    ConvergenceError
        The model has no DOFs, its reduced mass matrix is not positive definite, or its
        static equilibrium does not converge.
    """
    lin = linear_model or linearize(model)
    if lin.M0.size == 0:
        raise ConvergenceError(f"{model.name!r} has no DOFs: no natural frequencies")
    try:
        eigenvalues, shapes = symmetric_definite_eigh(lin.K, lin.M0, count)
    except np.linalg.LinAlgError:
        raise ConvergenceError(
            f"{model.source}: the reduced mass matrix of {model.name!r} is not positive "
            "definite: give every DOF some mass (node mass, inertia or rho_A)"
        ) from None
    count = eigenvalues.size if count is None else min(count, eigenvalues.size)
    omega = np.sign(eigenvalues) * np.sqrt(np.abs(eigenvalues))
    return Modes(
        frequencies_hz=omega[:count] / (2 * np.pi),
        shapes=shapes[:, :count],
        coordinate_shapes=lin.DF @ shapes[:, :count],
        linear_model=lin,
    )


@blas_threads()
def buckling_load_factors(model: Model, count: int | None = None, *,
                          loads: np.ndarray | None = None,
                          compiled: bool | None = None) -> np.ndarray:
    """Load factors lambda (smallest first) at which the reference load buckles `model`.

    Parameters
    ----------
    model : Model
    count : int, optional
        How many, smallest first (default: all positive ones).
    loads : ndarray (NX,), optional
        The reference load on the coordinates, N (N m on rotations); default the scene's
        [buckling] forces, else its loads.
    compiled : bool, optional
        Solve the equilibrium and form K0 and G0 through the compiled engine (True, where it
        takes the model: `linear_engine.supports`) or through the numpy `Mechanics` (False).
        Default: the engine where the statics solve through it (module docstring).

    Returns
    -------
    ndarray
        The positive load factors (unitless multiples of the reference load), ascending.

    Raises
    ------
    ConvergenceError
        The structural stiffness K0 is singular, or the equilibrium under the reference load
        does not converge.
    """
    if loads is None:
        loads = model.buckling_loads if model.buckling_loads is not None else model.loads
    mech = Mechanics(model)
    forced = compiled and linear_engine.supports(model, mech)
    solution = static_equilibrium(model, loads=loads, mechanics=mech,
                                  compiled=True if forced else compiled)
    engine = linear_engine.preferred(model, mech) if compiled is None else forced
    if engine and solution.load_factor == 1.0:
        _, _, K0, G0 = linear_engine.engine_matrices(model, solution, mech)
    else:
        config = solution.config
        K0 = mech.structural_stiffness(config)
        G0 = mech.geometric_stiffness(config, solution.stress_resultants)
    K0, G0 = held(model, K0), held(model, G0)  # with the kinematic inputs held
    import scipy.linalg  # here: a buckling analysis is rare, and the import 0.12 s of CPU

    try:
        inverse = scipy.linalg.eigh(-G0, K0, eigvals_only=True)
    except np.linalg.LinAlgError:
        raise ConvergenceError(
            f"{model.source}: the structural stiffness K0 of {model.name!r} is singular: "
            "no buckling analysis without stiffness on every DOF"
        ) from None
    scale = np.max(np.abs(inverse), initial=0.0)
    positive = inverse[inverse > 1e-12 * scale] if scale > 0 else inverse[:0]
    factors = np.sort(1.0 / positive)
    return factors if count is None else factors[:count]


# components of a mode's vector within this fraction of the largest are a tie (a node moving
# at 45 degrees): the eigensolver's round-off, which differs between CPUs (its BLAS kernels,
# FMA), must not pick the axis named
AXIS_TIE = 1e-9


def _dominant(vector):
    """The index of the largest |component| of `vector`; of ties (within AXIS_TIE of it,
    relatively), the first: x before y before z."""
    size = np.abs(np.asarray(vector, dtype=float))
    return int(np.flatnonzero(size >= (1.0 - AXIS_TIE) * size.max())[0])


def describe_mode(model: Model, coordinate_shape: np.ndarray,
                  x: np.ndarray | None = None) -> str:
    """Which nodes move how in a mode (the coordinate shape (NX,) of `Modes`), in words: the
    translational nodes that move most (within 10 % of the largest) and the axis they move
    along, and the rotational nodes that turn most and about which axis (x', y', z': in
    space the body frame of the node at the configuration x, default the initial one).
    A rotation is named beside a translation only when it moves a point at the model's length
    scale by at least a tenth as much, and the other way round, so that "3 and 5 along x"
    describes a sideways mode and "4 and 6 turn about z" a tilting one."""
    from ..mechanics.kinematics import length_scale
    from ..numerics.rotations import body_rates_matrix

    shape = np.asarray(coordinate_shape, dtype=float)
    x = model.initial_coordinates if x is None else np.asarray(x, dtype=float)
    # Euler parameters: the body-frame rotation 2 G(lambda) d lambda (rad), every such node
    # at once (a node at a time cost 0.1 s of the 816-DOF manipulator's ten modes)
    spatial = [node for node in model.nodes
               if node.kind != "translational" and node.axes != ("phi",)]
    rotation = {}
    if spatial:
        index = np.array([list(node.coordinates) for node in spatial], dtype=np.int64)
        rotations = 2.0 * np.matmul(body_rates_matrix(x[index]), shape[index][..., None])
        rotation = {node.name: r for node, r in zip(spatial, rotations[..., 0], strict=True)}
    moves, turns = [], []
    for node in model.nodes:
        index = list(node.coordinates)
        if node.kind == "translational":
            vector = shape[index]
            moves.append((float(np.linalg.norm(vector)), node.name,
                          node.axes[_dominant(vector)]))
        elif node.axes == ("phi",):
            turns.append((abs(float(shape[index[0]])), node.name, "z"))
        else:
            turns.append((float(np.linalg.norm(rotation[node.name])), node.name,
                          "xyz"[_dominant(rotation[node.name])] + "'"))
    scale = length_scale(model)
    largest_move = max((m[0] for m in moves), default=0.0)
    largest_turn = max((t[0] for t in turns), default=0.0) * scale
    parts = []
    for group, largest, verb in ((moves, largest_move, "along"), (turns, largest_turn, "turn")):
        top = max(largest_move, largest_turn)
        if largest <= 0.0 or largest < 0.1 * top:
            continue
        factor = 1.0 if verb == "along" else scale
        leaders = [g for g in group if g[0] * factor >= 0.9 * largest]
        leaders.sort(key=lambda g: -float(f"{g[0]:.4g}"))  # near-ties in the scene's order
        axes = sorted({g[2] for g in leaders[:3]})
        names = " and ".join(g[1] for g in leaders[:3]) + (" ..." if len(leaders) > 3 else "")
        if verb == "along":
            parts.append(f"{names} along {'/'.join(axes)}")
        else:
            parts.append(f"{names} turn about {'/'.join(axes)}")
    return "; ".join(parts) or "no motion"
