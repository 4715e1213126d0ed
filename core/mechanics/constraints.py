"""The exact-constraint check: DOF count and the rank of the constraint Jacobian.

A model is exactly constrained when its declared DOFs number NDOF = NX - NXO - NEO and the
constraint Jacobian J (free coordinates x free coordinates: rigid deformations, DOF
deformations, DOF coordinates) is regular. Otherwise, following the exact-constraint-design
check of the seed chapter:

- over-constrained: the rows of the rigid deformations are linearly dependent; the redundant
  constraints are named (each could be released to remove one over-constraint);
- under-constrained: some motion of the free coordinates changes no rigid deformation and no
  DOF; the coordinates of that motion are named (a mechanism, or a missing DOF).

Rank decisions use an SVD with the rotation columns divided by the model's length scale L (a
rotation theta moves a point at L by L theta: the column per metre of that motion), so that
every column is in m/m and the decisions do not depend on the model's size, and a relative
threshold of 1e-9 on the singular values.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConstraintError
from ..model import DOF
from ..numerics.blas import blas_threads
from ..numerics.conditioning import reciprocal_condition
from ..numerics.ties import independent_rows
from . import assembly
from .kinematics import Kinematics
from .nullspace import rank_and_null_space

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

RANK_TOLERANCE = 1e-9
# A constraint Jacobian whose reciprocal condition number (1-norm: exact, or LAPACK's gecon
# estimate for large ones) is above CLEAR_RCOND is regular without an SVD; below it the SVD
# decides. Measured on meshed spatial stages of 56 to 1 750 free coordinates, the estimate
# stays within a factor of 1.6 of the SVD's sigma_min / sigma_max, and the exact number is at
# most the estimate, so 1e-7 keeps a margin of about 60 over RANK_TOLERANCE
CLEAR_RCOND = 1e-7


@blas_threads()
def check_exact_constraint(model: Model, x: np.ndarray | None = None) -> dict[str, int]:
    """Raise ConstraintError unless `model` is exactly constrained at coordinates x.

    Parameters
    ----------
    model : Model
    x : ndarray (NX,), optional
        The coordinates to check at, m and rad (default: the initial ones).

    Returns
    -------
    dict of str to int
        The model's `dof_count()`: "nx", "nxo", "neo", "ndof".

    Raises
    ------
    ConstraintError
        The model is over- or under-constrained, or its DOF count is wrong; the message
        names the DOF counts, the redundant constraints (element deformations) and the free
        coordinates, as far as they apply.
    """
    kin, scaled_De = scaled_jacobian(model, x)
    problems = []
    if model.declared_dof_count != model.ndof:
        count = model.dof_count()  # the course notes' count (3 per 3-D rotational node)
        # a kinematic input has the status DOF (it is in q) but is no DOF of the motion
        declared = ", ".join(model.free_dof_names) or "none"
        nki = ("NKI ", f" - {count['nki']}") if "nki" in count else ("", "")
        problems.append(
            f"NDOF = NX - NXO - NEO {'- ' + nki[0] if nki[0] else ''}= {count['nx']} - "
            f"{count['nxo']} - {count['neo']}{nki[1]} = {count['ndof']}, "
            f"but the scene declares {model.declared_dof_count - count.get('nki', 0)} DOF(s): "
            f"{declared}"
        )
    rows = scaled_De[np.ix_(kin.constraint_rows, kin.free)]
    dof_rows = np.zeros((kin.dof_positions.size, kin.free.size))
    dof_rows[np.arange(kin.dof_positions.size), kin.dof_positions] = 1.0
    full = np.vstack([rows, dof_rows])
    if not problems and clearly_regular(full):
        # a regular J has independent rigid rows and no free motion: nothing to name
        return model.dof_count()
    rigid_rows = scaled_De[np.ix_(model.rigid_deformations, kin.free)]
    # Several null-space vectors may involve the same rows: one line per set, with its count.
    dependencies = _counted(_dependent_row_sets(rigid_rows))
    for dependency, count in dependencies:
        names = [model.deformation_names[model.rigid_deformations[i]] for i in dependency]
        redundant = "one of them is" if count == 1 else f"{count} of them are"
        release = "one of them" if count == 1 else f"{count} of them"
        problems.append(
            "over-constrained: the prescribed deformations "
            + ", ".join(names)
            + f" are mutually dependent, so {redundant} redundant; release {release} "
            "(or remove a support)"
        )
    releases = []
    if dependencies:
        kept, releases = _independent_rows(rigid_rows, _release_preference(model))
        problems.append(_redundancies(model, rigid_rows, kept, releases))
    if releases:
        names = [model.deformation_names[model.rigid_deformations[i]] for i in releases]
        problems.append(
            f"a release that removes the over-constraint: {', '.join(names)} (released instead of "
            f"prescribed zero: each needs its stiffness in the section, and the model gains "
            f"{len(names)} DOF(s); flexure chooses them when the scene lists none)"
        )
    free_motions, row_dependencies = _null_spaces(full)  # one SVD for both sides
    motions = [tuple(np.flatnonzero(np.abs(motion) > 1e-6 * np.abs(motion).max()))
               for motion in free_motions]
    problems += _fixed_dofs(model, kin, row_dependencies, rows.shape[0], motions)
    for moving, count in _counted(motions):
        names = ", ".join(model.coordinate_names[kin.free[i]] for i in moving)
        ways = "" if count == 1 else f" in {count} independent ways"
        problems.append(
            f"under-constrained: the coordinates {names} can move{ways} without changing any "
            "prescribed deformation or DOF; prescribe a released deformation zero, fix a "
            "coordinate or declare a DOF"
        )
    if problems:
        raise ConstraintError(
            f"{model.source}: model {model.name!r} is not exactly constrained:\n  - "
            + "\n  - ".join(problems)
        )
    return model.dof_count()


@blas_threads()
def choose_dofs(model: Model, x: np.ndarray | None = None,
                ) -> tuple[np.ndarray, np.ndarray, list[str]] | None:
    """A valid set of DOFs for a model whose scene lists none.

    The DOFs must complete the rigid rows R of the constraint Jacobian (prescribed
    deformations x free coordinates, at x, default the initial coordinates) to a regular
    matrix: their rows, projected on the null space N of R (the motions the constraints
    allow), must span it. Coordinates are preferred, as a designer names them (a planar node's
    x, y or phi; in space the translations, since a 3-D rotational node's Euler parameters
    cannot be DOFs); where they cannot span the motions (a free rotation in space), released
    deformations become DOF deformations. Among the candidates the choice is a QR
    factorisation with column pivoting of their projections: the ones that move most along
    the allowed motions first. Candidates that move equally (within `ties.TIE_RTOL`, as the
    two leaves of a symmetric guide) are taken in the scene's order, so that round-off, which
    differs from one CPU to the next, never decides. Rotations are in metres through the model's
    length scale, as in the check.

    Parameters
    ----------
    model : Model
    x : ndarray (NX,), optional
        The coordinates to choose at, m and rad (default: the initial ones).

    Returns
    -------
    (ndarray, ndarray, list of str) or None
        The new coordinate statuses (NX,), deformation statuses (NE,) and the names of the
        chosen DOFs; None when the prescribed deformations alone are dependent
        (over-constrained) or no DOFs can take the allowed motions:
        `check_exact_constraint` then names the problem.
    """
    kin, scaled_De = scaled_jacobian(model, x)
    if not np.all(np.isfinite(scaled_De)):
        return None  # a degenerate configuration: the check reports it
    scale = column_scale(model, kin.length_scale)
    free = model.free_coordinates
    rigid = scaled_De[np.ix_(model.rigid_deformations, free)]
    # the rank and null space of the SVD of `rigid`, from its independent blocks (`nullspace`)
    rank, _, motions = rank_and_null_space(rigid, RANK_TOLERANCE)  # motions (free, NDOF)
    if rank < rigid.shape[0]:
        return None
    ndof = motions.shape[1]
    if ndof == 0:
        return None
    translations = set(model.translations.tolist())
    coordinates = [i for i, c in enumerate(free) if model.dimension == 2 or c in translations]
    # a coordinate's row is the unit row of its column (times its scale)
    coordinate_rows = np.zeros((len(coordinates), free.size))
    for k, i in enumerate(coordinates):
        coordinate_rows[k, i] = scale[free[i]]
    released = model.released_deformations
    deformation_rows = scaled_De[np.ix_(released, free)]

    def pick(rows, basis, count):
        """Indices of up to `count` rows whose projections on `basis` are independent."""
        if rows.shape[0] == 0 or count == 0:
            return []
        # projections at the round-off of the rows themselves are zero: when no candidate
        # takes a motion (the torsion of a beam whose end node starts rotated), the largest
        # projection is that round-off, and 1e-6 of it would make a DOF of noise
        floor = 1e-12 * np.linalg.norm(rows, axis=1).max()
        return independent_rows(rows @ basis, count, floor=floor, relative=1e-6)

    # The kinematic inputs (status DOF already) take their motions first; the DOFs are
    # chosen among the other coordinates and deformations for the motions they leave free.
    prescribed = np.zeros((0, free.size))
    for port in model.kinematic_inputs:
        if port.deformation is None:
            row = np.zeros((1, free.size))
            row[0, np.searchsorted(free, port.coordinate)] = scale[port.coordinate]
        else:
            row = scaled_De[np.ix_([port.deformation], free)]
        prescribed = np.vstack([prescribed, row])
    candidates = [k for k, i in enumerate(coordinates) if model.coordinate_status[free[i]] != DOF]
    coordinate_rows = coordinate_rows[candidates]
    remaining = motions
    if prescribed.shape[0]:
        remaining = motions @ np.array(_null_space(prescribed @ motions)).reshape(-1, ndof).T
        # (ndof, ndof - NKI) when the inputs' motions are independent; the check says if not
    wanted = ndof - prescribed.shape[0]
    chosen_coordinates = pick(coordinate_rows, remaining, wanted)
    if chosen_coordinates:  # the motions the chosen coordinates leave free
        # `taken` falls apart into blocks as the motions do (each motion lives on one
        # block of the prescribed rows): its null space block by block, as one SVD's
        taken = coordinate_rows[chosen_coordinates] @ remaining
        remaining = remaining @ rank_and_null_space(taken, RANK_TOLERANCE)[2]
    chosen_deformations = pick(deformation_rows, remaining, wanted - len(chosen_coordinates))
    if len(chosen_coordinates) + len(chosen_deformations) < wanted:
        return None  # the check names the motion no DOF can take
    chosen_coordinates = [candidates[k] for k in chosen_coordinates]
    coordinate_status = model.coordinate_status.copy()
    deformation_status = model.deformation_status.copy()
    names = []
    for k in chosen_coordinates:
        c = free[coordinates[k]]
        coordinate_status[c] = DOF
        names.append(model.coordinate_names[c])
    for k in chosen_deformations:
        deformation_status[released[k]] = DOF
        names.append(model.deformation_names[released[k]])
    return coordinate_status, deformation_status, names


def _fixed_dofs(model, kin, row_dependencies, n_constraints, motions):
    """The lines naming DOFs that the prescribed deformations fix already (to first order at
    the configuration checked): the other side of a right DOF count with a singular choice,
    where some coordinates can move and some declared DOF cannot. `row_dependencies` are the
    left null-space vectors of the constraint rows followed by one unit row per DOF;
    `motions` the free motions' coordinates."""
    lines = []
    moving = sorted({kin.free[i] for motion in motions for i in motion})
    labels = list(model.dof_names)  # a kinematic input is a DOF row too: say which it is
    for port, j in zip(model.kinematic_inputs, model.prescribed_dofs, strict=True):
        labels[j] += f" (kinematic input {port.name})"
    for dependency in _involved(row_dependencies):
        dofs = [labels[i - n_constraints] for i in dependency if i >= n_constraints]
        if not dofs:
            continue  # among the prescribed deformations alone: the over-constraint above
        fixing = [model.deformation_names[kin.constraint_rows[i]] for i in dependency
                  if i < n_constraints]
        instead = (f"; declare a DOF among the coordinates that can move "
                   f"({', '.join(model.coordinate_names[c] for c in moving)}) instead"
                   if moving else "")
        lines.append(f"the DOF{'s' * (len(dofs) > 1)} {', '.join(dofs)} cannot move without "
                     f"changing the prescribed deformations {', '.join(fixing) or '(none)'} "
                     f"(to first order, where the model starts): no DOF here{instead}")
    return lines


def clearly_regular(matrix: np.ndarray) -> bool:
    """Whether the square `matrix` is regular by a margin: its reciprocal condition number
    in the 1-norm (`conditioning.reciprocal_condition`) above CLEAR_RCOND. An O(n^3) test
    at most (an LU and its estimate beyond a few hundred unknowns) where the SVD costs
    about ten times more (1.5 s on a 1 700-coordinate model); whatever it does not
    clear goes to the SVD, which decides with RANK_TOLERANCE and names what is wrong.

    Parameters
    ----------
    matrix : ndarray (n, m)
        A constraint Jacobian with its columns in metres (`column_scale`).

    Returns
    -------
    bool
        False for a matrix that is not square (unless empty) or not clearly regular.
    """
    if matrix.shape[0] != matrix.shape[1] or matrix.shape[0] == 0:
        return matrix.shape == (0, 0)
    return reciprocal_condition(matrix) > CLEAR_RCOND


def proposed_releases(model: Model, x: np.ndarray | None = None) -> list[str]:
    """The prescribed deformations whose release removes every over-constraint of `model`
    (names; empty when the prescribed deformations are independent), as SPACAR Light's
    automatic releases would choose them, but proposed, not applied.

    The rows of the prescribed deformations (at x, default the initial coordinates) are taken
    one by one, those that cannot be released first (their section has no stiffness for
    them), then the others in the scene's order; a row that adds nothing to the span of the
    rows kept before it is redundant and proposed for release. The rows kept are independent,
    so the proposal releases exactly as many deformations as there are over-constraints.

    Parameters
    ----------
    model : Model
    x : ndarray (NX,), optional
        The coordinates to check at, m and rad (default: the initial ones).

    Returns
    -------
    list of str
        The deformation names ("leaf.e2") to release; empty when the prescribed
        deformations are independent.
    """
    kin, scaled_De = scaled_jacobian(model, x)
    rows = scaled_De[np.ix_(model.rigid_deformations, kin.free)]
    redundant = _independent_rows(rows, _release_preference(model))[1]
    return [model.deformation_names[model.rigid_deformations[i]] for i in redundant]


def scaled_jacobian(model, x):
    """(kin, scaled_De): the model's Kinematics and its deformation Jacobian de/dx at
    coordinates x (m, rad; default the initial ones), (NE, NX), with each rotation column
    divided by the length scale (`column_scale`) so that every column is in m/m: the matrix whose
    rows every rank decision of this module takes, on the free coordinates `kin.free`."""
    kin = Kinematics(model)
    x = model.initial_coordinates if x is None else x
    _, De = assembly.deformation_jacobian(model, x)
    return kin, De * column_scale(model, kin.length_scale)


def _redundancies(model, rows, kept, redundant, shown=10):
    """The line that names each redundancy: a redundant prescribed deformation (the one
    proposed for release) with the releasable ones it depends on, and the elements that cannot
    be released (rigid links) the dependency runs through. `rows` are the prescribed rows,
    `kept` the independent ones, `redundant` the others."""
    releasable = _releasable(model)
    name = [model.deformation_names[d] for d in model.rigid_deformations]
    weights = np.linalg.lstsq(rows[kept].T, rows[redundant].T, rcond=None)[0]
    parts = []
    for column, r in enumerate(redundant[:shown]):
        w = np.abs(weights[:, column])
        involved = [kept[i] for i in np.flatnonzero(w > 1e-6 * w.max(initial=0.0))]
        partners = [name[i] for i in involved if releasable[i]]
        links = list(dict.fromkeys(name[i].rsplit(".", 1)[0] for i in involved
                                   if not releasable[i]))
        parts.append(f"{name[r]} with {', '.join(partners) or 'supports only'}"
                     + (f" (through {', '.join(links)})" if links else ""))
    more = f"; and {len(redundant) - shown} more" if len(redundant) > shown else ""
    return "each redundancy: " + "; ".join(parts) + more


def _releasable(model):
    """For each prescribed deformation (position in `model.rigid_deformations`), whether its
    section has a stiffness for it, so that it could be released."""
    releasable = np.zeros(model.rigid_deformations.size, dtype=bool)
    position = {d: k for k, d in enumerate(model.rigid_deformations)}
    for group in model.groups:
        stiffness = getattr(group.kind, "deformation_stiffness", {})
        for i, indices in enumerate(group.deformation_index):
            for name, d in zip(group.kind.deformation_names, indices, strict=True):
                values = group.properties.get(stiffness.get(name))
                if d in position and values is not None and float(values[i]) > 0.0:
                    releasable[position[d]] = True
    return releasable


def _release_preference(model):
    """The prescribed deformations' positions in `model.rigid_deformations`, those that can
    be released (a stiffness for them in their section) last, so that they are the ones left
    over."""
    releasable = _releasable(model)
    return sorted(range(releasable.size), key=lambda k: (releasable[k], k))


def _independent_rows(rows, order):
    """(kept, redundant): the positions of `rows`, taken in `order`, that add to the span of
    the rows kept before them, and those that do not (relative tolerance RANK_TOLERANCE,
    Gram-Schmidt twice)."""
    basis, kept, redundant = [], [], []
    top = max(np.abs(rows).max(initial=0.0), 1e-300)
    for k in order:
        row = rows[k].astype(float)
        norm = np.linalg.norm(row)
        for _ in range(2):
            for b in basis:
                row = row - (b @ row) * b
        residual = np.linalg.norm(row)
        if norm > 0.0 and residual > max(1e-6 * norm, RANK_TOLERANCE * top):
            basis.append(row / residual)
            kept.append(k)
        else:
            redundant.append(k)
    return sorted(kept), sorted(redundant)


def _counted(index_sets):
    """(index set, how many times it occurs) in order of first occurrence."""
    counts = {}
    for indices in index_sets:
        key = tuple(int(i) for i in indices)
        counts[key] = counts.get(key, 0) + 1
    return list(counts.items())


def column_scale(model: Model, length_scale: float) -> np.ndarray:
    """The factors that put a Jacobian's columns in metres: a rotation theta (rad, or an Euler
    parameter) moves a point at the length scale L by u = L theta, so its column per metre of
    u is its column per radian divided by L. Under a change of the model's size every column
    then keeps its value (a deformation's derivative by a rotation grows with the size).

    Parameters
    ----------
    model : Model
    length_scale : float
        m per rad, the model's length scale (`Kinematics.length_scale`).

    Returns
    -------
    ndarray (NX,)
        1 for a translational coordinate, 1 / `length_scale` (rad/m) for a rotational one.
    """
    scale = np.full(model.nx, 1.0 / float(length_scale))
    scale[model.translations] = 1.0
    return scale


def _dependent_row_sets(rows):
    """For each left null-space vector of `rows`, the indices of the rows taking part."""
    return _involved(_null_space(rows.T))


def _involved(vectors):
    """For each vector, the indices of its entries beyond 1e-6 of its largest."""
    return [list(np.flatnonzero(np.abs(v) > 1e-6 * np.abs(v).max())) for v in vectors]


def _null_space(matrix):
    """An orthonormal basis (list of vectors) of the null space of `matrix`, by SVD with the
    relative rank threshold RANK_TOLERANCE."""
    return _null_spaces(matrix)[0]


def _null_spaces(matrix):
    """(right, left): orthonormal bases (lists of vectors) of the null spaces of `matrix` and
    of its transpose, from one SVD with the relative rank threshold RANK_TOLERANCE."""
    m, n = matrix.shape
    if m == 0 or n == 0:
        return list(np.eye(n)), list(np.eye(m))
    u, s, vt = np.linalg.svd(matrix)
    top = max(s.max(initial=0.0), 1e-300)
    rank = int(np.sum(s > RANK_TOLERANCE * top))
    return list(vt[rank:]), list(u[:, rank:].T)
