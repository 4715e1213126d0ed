"""Natural frequencies, mode shapes and linear buckling load factors.

Frequencies solve (K0 + G0) phi = omega^2 M0 phi (scipy.linalg.eigh, symmetric-definite);
mode shapes are normalised to unit modal mass and given on the DOFs and on all coordinates
(DF phi). A negative frequency marks an unstable (divergent) mode, omega^2 < 0.

Buckling load factors solve K0 phi + lambda G0 phi = 0 with G0 the geometric stiffness of the
reference load at its equilibrium, as SPACAR's eig(-K0, G0); computed as the symmetric
problem -G0 phi = (1 / lambda) K0 phi so that a singular G0 (DOFs the load does not soften)
causes no trouble. Positive factors only, smallest first.
"""

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .blas import blas_threads
from .errors import ConvergenceError
from .linearization import LinearModel, linearize
from .mechanics import Mechanics
from .statics import static_equilibrium


@dataclass
class Modes:
    """Natural frequencies (Hz) and mass-normalised mode shapes."""

    frequencies_hz: np.ndarray  # (n,)
    shapes: np.ndarray  # (NDOF, n) on the DOFs
    coordinate_shapes: np.ndarray  # (NX, n) on all coordinates
    linear_model: LinearModel


@blas_threads()
def natural_frequencies(model, count=None, *, linear_model=None):
    """The lowest `count` (default: all) natural frequencies and mode shapes of `model`."""
    lin = linear_model or linearize(model)
    if lin.M0.size == 0:
        raise ConvergenceError(f"{model.name!r} has no DOFs: no natural frequencies")
    try:
        eigenvalues, shapes = scipy.linalg.eigh(lin.K, lin.M0)
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
def buckling_load_factors(model, count=None, *, loads=None):
    """Load factors lambda (smallest first) at which the reference load buckles `model`.

    The reference load is `loads` (NX,), else the scene's [buckling] forces, else its loads.
    """
    if loads is None:
        loads = model.buckling_loads if model.buckling_loads is not None else model.loads
    mech = Mechanics(model)
    solution = static_equilibrium(model, loads=loads, mechanics=mech)
    config = solution.config
    K0 = mech.structural_stiffness(config)
    G0 = mech.geometric_stiffness(config, solution.stress_resultants)
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
