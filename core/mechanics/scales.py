"""The units of a model's unknowns and equations: tolerances that respect them.

Every Newton iteration of flexure (the kinematics, in the numpy reference and in the compiled
engine; the statics; inverse statics) tests each row of its residual and each of its unknowns
in its own unit, never one number against all of them:

    converged on the residual   |g_i|  <= max(tol u_i, ROUND_OFF m_i)      every row i
    converged on the step       |dx_j| <= max(tol u_j, ROUND_OFF m_j)      every unknown j

with `tol` the Newton's relative tolerance and

- u, the unit of the row or unknown: the model's length scale L (m, `length_scale`) for a
  length (a translational coordinate; every element deformation is a length, a bending or
  torsion one an angle times l0), 1 for a rotation (a planar angle in rad, an Euler
  parameter) and for a dimensionless row (a 3-D node's normalisation (lambda.lambda - 1)/2);
- m, its round-off magnitude, the size of the numbers it is computed from: for a length the
  larger of L and the largest |translational coordinate| of the initial configuration (a
  deformation is a difference of positions: a 6 mm beam at 0.1 m from the origin carries the
  round-off of 0.1 m), for a rotation 1 (|lambda_i| <= 1; a planar angle's own |x_j| is added
  on the step by the callers, as a pendulum's angle grows);
- ROUND_OFF = 8 eps (1.8e-16): a few ulps above the round-off of a residual evaluated from a
  handful of products, so that a Newton at round-off stops instead of wandering there.

Why: a single tolerance `tol L` for every row put the Euler parameters' normalisation rows
and steps, numbers of order 1 whose round-off is 1.1e-16, below their own round-off as soon as
the longest element was shorter than 11 mm (tol = 1e-14): a 0.1 m strip in 16 spatial BEAMs
could not be simulated. With units, the same scene at any size (lengths times s, masses and
stiffnesses scaled to keep its frequencies) takes the same iterations (tests/
test_scale_invariance.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

ROUND_OFF = 8.0 * np.finfo(float).eps  # the floor of every test, relative to the magnitude


def length_scale(model: Model) -> float:
    """A characteristic length of the model (m): its largest element reference length;
    without elements that have one (springs alone), the largest distance of a translational
    coordinate from the origin; 1 m for a model without either. No absolute floor: the
    same scene scaled in size scales its length scale."""
    lengths = [float(group.reference["l0"].max()) for group in model.groups
               if "l0" in group.reference and group.reference["l0"].size]
    if lengths and max(lengths) > 0.0:
        return max(lengths)
    extent = position_magnitude(model, 0.0)
    return extent if extent > 0.0 else 1.0


def position_magnitude(model: Model, scale: float) -> float:
    """The round-off magnitude of a length (m): the larger of `scale` and the largest
    |translational coordinate| of the initial configuration."""
    x0 = np.asarray(model.initial_coordinates, float)[model.translations]
    return max(float(scale), float(np.max(np.abs(x0), initial=0.0)))


def coordinate_units(model: Model, scale: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The unit u and round-off magnitude m of every coordinate (module docstring).

    Parameters
    ----------
    model : Model
    scale : float, optional
        The length scale L (m); default `length_scale(model)`.

    Returns
    -------
    units, magnitudes : ndarray (NX,)
        L (m) for a translational coordinate, 1 (rad or unitless) for a rotational one;
        the magnitudes likewise (m, or 1).
    """
    L = length_scale(model) if scale is None else scale
    units, magnitudes = np.ones(model.nx), np.ones(model.nx)
    units[model.translations] = L
    magnitudes[model.translations] = position_magnitude(model, L)
    return units, magnitudes


def deformation_units(model: Model, scale: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The unit u and round-off magnitude m of every deformation: an element declares the
    units of its deformations in `deformation_units` ("m", or "1" for a dimensionless one
    such as EULER's normalisation); "m" when it does not.

    Parameters
    ----------
    model : Model
    scale : float, optional
        The length scale L (m); default `length_scale(model)`.

    Returns
    -------
    units, magnitudes : ndarray (NE,)
        L (m) for a length, 1 for a dimensionless deformation; the magnitudes likewise.
    """
    L = length_scale(model) if scale is None else scale
    dimensionless = np.array(deformation_unit_names(model)) == "1"
    units = np.where(dimensionless, 1.0, L)
    magnitudes = np.where(dimensionless, 1.0, position_magnitude(model, L))
    return units, magnitudes


def deformation_unit_names(model: Model) -> list[str]:
    """The unit of every deformation, as its element declares it in `deformation_units` ("m",
    or "1" for a dimensionless one); "m" where the element declares none."""
    names = ["m"] * len(model.deformation_names)
    for group in model.groups:
        declared = getattr(group.kind, "deformation_units", None)
        for row in group.deformation_index if declared is not None else ():
            for unit, index in zip(declared, row, strict=True):
                names[int(index)] = unit
    return names


def kinematic_tolerances(model: Model, tolerance: float, *, rows: np.ndarray,
                         free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The absolute tolerances of the kinematics' Newton: per row of its residual g = [the
    deformations `rows`; the DOF coordinates minus their DOFs] and per unknown (the free
    coordinates `free`), max(tolerance u, ROUND_OFF m) (module docstring).

    Parameters
    ----------
    model : Model
    tolerance : float
        Relative to each row's and unknown's unit (e.g. 1e-14).
    rows : ndarray of int
        The deformation indices of g's deformation rows, in g's order.
    free : ndarray of int
        The coordinate indices of the unknowns, in their order.

    Returns
    -------
    row_tolerance : ndarray (rows.size + n_dof_coordinates,)
        m on the length rows, unitless on the normalisation rows, rad on a planar angle DOF.
    step_tolerance : ndarray (free.size,)
        m, rad or unitless, as the unknowns.
    """
    L = length_scale(model)
    e_units, e_magnitudes = deformation_units(model, L)
    x_units, x_magnitudes = coordinate_units(model, L)
    dofs = model.dof_coordinates
    row_units = np.concatenate([e_units[rows], x_units[dofs]])
    row_magnitudes = np.concatenate([e_magnitudes[rows], x_magnitudes[dofs]])
    return (np.maximum(tolerance * row_units, ROUND_OFF * row_magnitudes),
            np.maximum(tolerance * x_units[free], ROUND_OFF * x_magnitudes[free]))


def dof_tolerances(model: Model, tolerance: float) -> np.ndarray:
    """The absolute tolerances of a Newton on the DOFs (statics): max(tolerance u,
    ROUND_OFF m) per DOF, the DOF coordinates first, then the DOF deformations.

    Parameters
    ----------
    model : Model
    tolerance : float
        Relative to each DOF's unit.

    Returns
    -------
    ndarray (NDOF,)
        m on a length DOF, rad on an angle DOF.
    """
    L = length_scale(model)
    x_units, x_magnitudes = coordinate_units(model, L)
    e_units, e_magnitudes = deformation_units(model, L)
    x, e = model.dof_coordinates, model.dof_deformations
    units = np.concatenate([x_units[x], e_units[e]])
    magnitudes = np.concatenate([x_magnitudes[x], e_magnitudes[e]])
    return np.maximum(tolerance * units, ROUND_OFF * magnitudes)


def within(values: np.ndarray, tolerances: np.ndarray, *, magnitudes=None) -> bool:
    """Whether every |values_i| <= its tolerance (and, given `magnitudes`, <= ROUND_OFF
    |magnitudes_i| at least: a step that changes its unknown by less than a few ulps of its
    current value); False for a non-finite value.

    Parameters
    ----------
    values, tolerances : ndarray (n,)
        In the same units, row by row.
    magnitudes : ndarray (n,), optional
        The current values of the unknowns a step changes.

    Returns
    -------
    bool
    """
    bound = tolerances if magnitudes is None else np.maximum(
        tolerances, ROUND_OFF * np.abs(magnitudes))
    with np.errstate(invalid="ignore"):
        return bool(np.all(np.abs(values) <= bound))


__all__ = ["ROUND_OFF", "coordinate_units", "deformation_unit_names", "deformation_units",
           "dof_tolerances", "kinematic_tolerances", "length_scale", "position_magnitude",
           "within"]
