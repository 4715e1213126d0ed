"""The exact-constraint check: DOF count and the rank of the constraint Jacobian.

A model is exactly constrained when its declared DOFs number NDOF = NX - NXO - NEO and the
constraint Jacobian J (free coordinates x free coordinates: rigid deformations, DOF
deformations, DOF coordinates) is regular. Otherwise, following the exact-constraint-design
check of the seed chapter:

- over-constrained: the rows of the rigid deformations are linearly dependent; the redundant
  constraints are named (each could be released to remove one over-constraint);
- under-constrained: some motion of the free coordinates changes no rigid deformation and no
  DOF; the coordinates of that motion are named (a mechanism, or a missing DOF).

Rank decisions use an SVD with the rotation columns scaled by the model's length scale, and a
relative threshold of 1e-9 on the singular values.
"""

import numpy as np

from . import assembly
from .blas import blas_threads
from .errors import ConstraintError
from .kinematics import Kinematics

RANK_TOLERANCE = 1e-9


@blas_threads()
def check_exact_constraint(model, x=None):
    """Raise ConstraintError unless `model` is exactly constrained at coordinates x.

    The message names the DOF counts, the redundant constraints (element deformations) and the
    free coordinates, as far as they apply. Returns the model's dof_count() when it passes.
    """
    kin = Kinematics(model)
    if x is None:
        x = model.initial_coordinates
    problems = []
    if model.declared_dof_count != model.ndof:
        declared = ", ".join(model.dof_names) or "none"
        count = model.dof_count()  # the course notes' count (3 per 3-D rotational node)
        problems.append(
            f"NDOF = NX - NXO - NEO = {count['nx']} - {count['nxo']} - {count['neo']} = "
            f"{count['ndof']}, "
            f"but the scene declares {model.declared_dof_count} DOF(s): {declared}"
        )
    _, De = assembly.deformation_jacobian(model, x)
    scale = _column_scale(model, kin.length_scale)[kin.free]
    rigid_rows = De[np.ix_(model.rigid_deformations, kin.free)] * scale
    # Several null-space vectors may involve the same rows: one line per set, with its count.
    for dependency, count in _counted(_dependent_row_sets(rigid_rows)):
        names = [model.deformation_names[model.rigid_deformations[i]] for i in dependency]
        redundant = "one of them is" if count == 1 else f"{count} of them are"
        release = "one of them" if count == 1 else f"{count} of them"
        problems.append(
            "over-constrained: the prescribed deformations "
            + ", ".join(names)
            + f" are mutually dependent, so {redundant} redundant; release {release} "
            "(or remove a support)"
        )
    rows = De[np.ix_(kin.constraint_rows, kin.free)] * scale
    dof_rows = np.zeros((kin.dof_positions.size, kin.free.size))
    dof_rows[np.arange(kin.dof_positions.size), kin.dof_positions] = 1.0
    full = np.vstack([rows, dof_rows])
    motions = [tuple(np.flatnonzero(np.abs(motion) > 1e-6 * np.abs(motion).max()))
               for motion in _free_motions(full)]
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


def _counted(index_sets):
    """(index set, how many times it occurs) in order of first occurrence."""
    counts = {}
    for indices in index_sets:
        key = tuple(int(i) for i in indices)
        counts[key] = counts.get(key, 0) + 1
    return list(counts.items())


def _column_scale(model, length_scale):
    """Scale rotation coordinates (rad) by a length so every column is in metres."""
    scale = np.ones(model.nx)
    for i, name in enumerate(model.coordinate_names):
        if name.rsplit(".", 1)[1] not in ("x", "y", "z"):
            scale[i] = length_scale
    return scale


def _dependent_row_sets(rows):
    """For each left null-space vector of `rows`, the indices of the rows taking part."""
    return [list(np.flatnonzero(np.abs(v) > 1e-6 * np.abs(v).max()))
            for v in _null_space(rows.T)]


def _free_motions(matrix):
    """Right null-space vectors of `matrix` (rows x free coordinates)."""
    return _null_space(matrix)


def _null_space(matrix):
    """An orthonormal basis (list of vectors) of the null space of `matrix`, by SVD with the
    relative rank threshold RANK_TOLERANCE."""
    if matrix.shape[1] == 0:
        return []
    if matrix.shape[0] == 0:
        return list(np.eye(matrix.shape[1]))
    _, s, vt = np.linalg.svd(matrix)
    top = max(s.max(initial=0.0), 1e-300)
    rank = int(np.sum(s > RANK_TOLERANCE * top))
    return list(vt[rank:])
