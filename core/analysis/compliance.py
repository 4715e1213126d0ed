"""Compliance and support stiffness at a node (SPACAR Light's CMglob).

In a configuration (the static equilibrium under the scene's loads, or a given one) the
linearised statics on the DOFs are K dq = DF^T df, with K = K0 + G0 the tangent stiffness and
DF = dx/dq. A small force (and moment) df on the coordinates c of one node moves them by

    dx_c = C df_c,      C = DF_c K^-1 DF_c^T                                  (compliance)

with DF_c the rows of DF of those coordinates. Its units are m/N on translations, rad/(N m)
on the planar angle and m/(N m) = rad/N across. C is symmetric where the loads are
conservative; a moment held about a fixed global axis in 3-D is not, and under one K and C are
unsymmetric and given as they are. Where C is regular its
inverse is the support stiffness (N/m, N/rad, N m/m, N m/rad): the force that holds the node
displaced by a unit step of one coordinate with the others held.

The coordinates of a node are its translations and, in the plane, the angle of the rotational
node the elements join to it (a PLBEAM's p or q pair); a planar rotational node named alone
gives its angle. A spatial rotational node gives its small rotations about the global axes
(rx, ry, rz, rad) under moments about them (N m): its orientation is carried by four Euler
parameters lambda, whose change turns the node by d theta = 2 E(lambda) d lambda, and a moment
M acts on them as the generalised force 2 E(lambda)^T M (`numerics.rotations`), so that

    C = H DF K^-1 DF^T H^T,      H = the unit rows of the translations, 2 E(lambda) of a rotation

stays symmetric in any orientation (a spatial translational node gives its translations; name
its rotational node for the rotations). A coordinate the DOFs cannot move (fixed, or held by a
prescribed deformation, such as the vertical of a leaf-spring stage whose leaves do not
stretch) has zero compliance: C is then singular and there is no support stiffness, which the
result says rather than inverting it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import FlexureError, SceneError
from ..mechanics.kinematics import length_scale
from ..numerics.blas import blas_threads
from ..numerics.conditioning import lu_and_rcond
from ..numerics.rotations import global_rates_matrix

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model
    from .linearization import LinearModel
    from .statics import StaticSolution

# A coordinate whose compliance is below this fraction of the largest in the model is
# unreachable: its DF row is then about 1e-10 of the largest, the
# round-off of a row that is zero in exact arithmetic (C goes with the square of DF).
UNREACHABLE = 1e-20
# C restricted to the reachable coordinates, scaled to a unit diagonal (unit-free), is
# singular beyond this condition number: coordinates that the DOFs move only together.
SINGULAR = 1e10


@dataclass
class Compliance:
    """The compliance of one node and, where regular, its support stiffness.

    matrix (n, n): displacement per unit load (m/N, m/(N m), rad/N, rad/(N m): `units`);
    stiffness (n, n) its inverse (N/m, ...: `stiffness_units`), or None where the matrix is
    singular; coordinates: the names ("3.x", "4.phi"); unreachable: those the DOFs cannot
    move (zero rows and columns); note: why there is no stiffness, or "".
    """

    node: str
    coordinates: list
    matrix: np.ndarray
    stiffness: np.ndarray | None
    units: list
    stiffness_units: list
    unreachable: list
    note: str = ""

    def as_dict(self) -> dict[str, object]:
        """The result as plain lists and strings (the `--json` entry).

        Returns
        -------
        dict
            "coordinates", "matrix" (m/N, ...), "units", "stiffness" (N/m, ..., or None),
            "stiffness_units", "unreachable" and "note", JSON-ready.
        """
        return {"coordinates": self.coordinates, "matrix": self.matrix.tolist(),
                "units": self.units,
                "stiffness": None if self.stiffness is None else self.stiffness.tolist(),
                "stiffness_units": self.stiffness_units, "unreachable": self.unreachable,
                "note": self.note}


def node_coordinates(model: Model, node: str) -> list[int]:
    """The coordinate indices a compliance of `node` covers: its translations, then in the
    plane the angle of the rotational node joined to it; a rotational node's own coordinates
    (a spatial one's four Euler parameters, which `measure_rows` turns into three rotations).
    SceneError names an unknown node."""
    nodes = {n.name: n for n in model.nodes}
    if node not in nodes:
        listed = ", ".join(list(nodes)[:12]) + (", ..." if len(nodes) > 12 else "")
        raise SceneError(f"{model.source}: compliance: model {model.name!r} has no node "
                         f"{node!r}; expected one of {listed}")
    found = nodes[node]
    index = list(found.coordinates)
    if found.kind == "translational" and model.dimension == 2:
        partners = joined_rotational_nodes(model, node)
        if len(partners) == 1:
            index += list(nodes[partners[0]].coordinates)
    return index


def measure_rows(model: Model, node: str, x) -> tuple[np.ndarray, list[str], list[bool]]:
    """(H (n, NX), names, translational flags) of the displacements a compliance of `node`
    reports at coordinates x: a unit row per coordinate of `node_coordinates`, or for a
    spatial rotational node the rows 2 E(lambda) of its rotations about the global axes
    ("<node>.rx", ...)."""
    index = node_coordinates(model, node)
    found = next(n for n in model.nodes if n.name == node)
    if found.kind == "rotational" and model.dimension == 3:
        H = np.zeros((3, model.nx))
        H[:, index] = 2.0 * global_rates_matrix(np.asarray(x, float)[index])
        return H, [f"{node}.r{axis}" for axis in "xyz"], [False] * 3
    H = np.zeros((len(index), model.nx))
    H[np.arange(len(index)), index] = 1.0
    translational = np.isin(model.coordinate_axis[index].astype(str), ("x", "y", "z"))
    return H, [model.coordinate_names[i] for i in index], [bool(t) for t in translational]


def joined_rotational_nodes(model: Model, node: str) -> list[str]:
    """The rotational nodes the elements pair with translational `node` (same end p or q)."""
    found = []
    for group in model.groups:
        kinds = group.kind.node_kinds
        roles = getattr(group.kind, "node_roles", None)
        if roles is None or "rotational" not in kinds:
            continue
        for row in group.coordinate_index:
            names = list(dict.fromkeys(model.coordinate_node[row].tolist()))
            for name, kind, role in zip(names, kinds, roles, strict=True):
                if name != node or kind != "translational":
                    continue
                found += [other for other, k, r in zip(names, kinds, roles, strict=True)
                          if k == "rotational" and r == role and other not in found]
    return found


@blas_threads()
def compliance(model: Model, node: str, *, solution: StaticSolution | None = None,
               linear_model: LinearModel | None = None) -> Compliance:
    """The compliance matrix of `node` and its support stiffness, from K = K0 + G0.

    Parameters
    ----------
    model : Model
    node : str
        The node's name: a translational node (with, in the plane, the angle of the
        rotational node joined to it) or a rotational node (module docstring).
    solution : StaticSolution, optional
        The configuration (default: the static equilibrium under the scene's loads).
    linear_model : LinearModel, optional
        The linearisation to use instead; it is reused, as `flexure analyze` does for
        several nodes.

    Returns
    -------
    Compliance
        The matrix (m/N, rad/(N m), m/(N m), rad/N) and, where it is regular, the support
        stiffness (N/m, N m/rad, ...).

    Raises
    ------
    SceneError
        `node` is not a node of the model.
    FlexureError
        The tangent stiffness is singular (at a buckling load, a mechanism, or DOFs without
        stiffness).
    """
    from .linearization import linearize

    node_coordinates(model, node)  # an unknown node is named before any solve
    lin = linear_model or linearize(model, solution)
    DF = lin.DF
    H, names, translational = measure_rows(model, node, lin.solution.x)
    translational = np.array(translational, dtype=bool)
    HDF = H @ DF
    singular = FlexureError(f"{model.source}: compliance of node {node!r}: the tangent "
                            f"stiffness K0 + G0 of {model.name!r} is singular in this "
                            "configuration (at a buckling load, a mechanism, or DOFs without "
                            "stiffness as in a kinematic model)")
    solved = _solve_regular(lin.K, DF.T)  # K^-1 DF^T (NDOF, NX), None where K is singular
    if solved is None:
        raise singular
    C = HDF @ solved @ H.T
    symmetric = _is_symmetric(lin.K)
    if symmetric:
        C = 0.5 * (C + C.T)  # symmetric in exact arithmetic
    if np.any(np.diag(C) < 0.0):  # a stable equilibrium's compliance is positive semidefinite
        raise singular
    # "Zero" is measured against the largest compliance in the model, a rotation's taken as
    # the motion it gives a point at the model's length scale L (rad/(N m) times L^2 is m/N)
    L = length_scale(model)
    every = np.einsum("ij,ji->i", DF, solved)
    every[~np.isin(model.coordinate_axis.astype(str), ("x", "y", "z"))] *= L**2
    as_lengths = np.abs(np.diag(C)) * np.where(translational, 1.0, L**2)
    zero = as_lengths <= UNREACHABLE * np.max(np.abs(every), initial=0.0)
    C[zero, :] = 0.0
    C[:, zero] = 0.0
    coordinate_units = ["m" if t else "rad" for t in translational]
    load_units = ["N" if t else "N m" for t in translational]
    units = [[f"{c}/{_group(f)}" for f in load_units] for c in coordinate_units]
    stiffness_units = [[f"{f}/{c}" for c in coordinate_units] for f in load_units]
    unreachable = [name for name, z in zip(names, zero, strict=True) if z]
    notes = []
    if unreachable:
        notes.append(f"{', '.join(unreachable)} cannot move through the DOFs (fixed or held "
                     "by a prescribed deformation): their compliance is zero")
    reachable = [k for k, z in enumerate(zero) if not z]
    if reachable:
        d = 1.0 / np.sqrt(np.diag(C)[reachable])
        scaled = d[:, None] * C[np.ix_(reachable, reachable)] * d[None, :]  # unit diagonal
        singular_values = np.linalg.svd(scaled, compute_uv=False)
        rank = int(np.sum(singular_values > singular_values[0] / SINGULAR))
        if rank < len(reachable):
            notes.append(f"the DOFs move {', '.join(names[k] for k in reachable)} only "
                         f"together (rank {rank} of {len(reachable)})")
    stiffness = None
    if not notes:
        stiffness = np.linalg.inv(C)
        if symmetric:
            stiffness = 0.5 * (stiffness + stiffness.T)
    note = "; ".join(notes) + (": the matrix is singular" if notes else "")
    return Compliance(node, names, C, stiffness, units, stiffness_units, unreachable, note)


# A tangent stiffness whose reciprocal condition estimate (LU, LAPACK's gecon, 1-norm) is below
# this is singular for the compliance: its solution would carry no significant digit.
SINGULAR_RCOND = 1e-13


def _solve_regular(K, rhs):
    """K^-1 rhs, or None when K is singular or nearly so (its condition estimate)."""
    import scipy.linalg

    factors, rcond = lu_and_rcond(K)
    if not rcond > SINGULAR_RCOND:
        return None
    solved = scipy.linalg.lu_solve(factors, rhs)
    return solved if np.all(np.isfinite(solved)) else None


# K is symmetric when the loads are conservative; moments held about fixed global axes (moment
# inputs with a value, in 3-D) are not, and their load stiffness makes K, and C, unsymmetric
SYMMETRIC = 1e-10


def _is_symmetric(K):
    return np.max(np.abs(K - K.T), initial=0.0) <= SYMMETRIC * np.max(np.abs(K), initial=0.0)


def _group(unit):
    """A unit as a denominator: "N m" -> "(N m)"."""
    return f"({unit})" if " " in unit else unit
