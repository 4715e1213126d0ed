"""Which deformations can be prescribed zero together: the over-constraint test, incrementally.

A model reduction (`flexure.core.analysis.reduction`) freezes released deformations in an
order of its choosing and must know that every prefix of what it freezes still builds: the
rows of the deformation Jacobian De (rotation columns scaled to lengths,
`constraints.scaled_jacobian`) of the prescribed deformations and of the frozen groups must
stay independent. A group of rows is independent of the span S of the rows taken before it
when its part orthogonal to S has full rank; `freezable` decides that through an orthonormal
basis of the complement of S (its transpose times r is the part of r outside S), which
shrinks as groups are taken.

The basis is kept as N0 W: N0 (n, m0) an orthonormal basis of the complement of the
prescribed rows alone (their null space, block by block: `nullspace`), computed once, and
W (m0, m) orthonormal, shrunk by each group taken. A group's rows enter through their
coordinates in that complement, N0^T r^T (m0 of them where r has n, the free coordinates;
only the few columns a deformation depends on are read), and W shrinks by the group's
Householder reflections applied in one blocked LAPACK call (dormqr: matrix products, where
k rank-one updates would each pass over the whole matrix). In a model with many prescribed
deformations the complement is the small side (the six-DOF manipulator with its elongations
prescribed: 937 prescribed rows on 1582 free coordinates, m0 = 645): each group taken costs
O(m0 m k) for k rows, where N itself would cost O(n m k) and a basis of S O(n dim(S) k).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

from ..numerics.blas import blas_threads
from .constraints import RANK_TOLERANCE, scaled_jacobian
from .nullspace import apply_reflections, rank_and_null_space

if TYPE_CHECKING:
    from ..model import Model

# a group's rows are independent of what was taken when the diagonal of R of its part
# outside that span exceeds this share of each row's norm (and the rank tolerance)
GROUP_TOLERANCE = 1e-6


@blas_threads()
def freezable(model: Model, groups: list, x: np.ndarray | None = None) -> list[int]:
    """Which `groups` of released (or DOF) deformations, taken in their order, can be
    prescribed zero together, on top of the model's prescribed deformations, without
    over-constraining it: a group is taken when its rows of the deformation Jacobian (at
    coordinates x, m and rad, default the initial ones; rotations scaled to lengths) add fully
    to the span of the prescribed rows and of the groups taken before it. `groups` are arrays
    of deformation indices; returns the positions in `groups` of those taken.

    A group of k rows r is taken when, with N = N0 W an orthonormal basis of the complement
    of that span (module docstring) and N^T r^T = Q R, every |R_ii| exceeds
    max(GROUP_TOLERANCE |r_i|, RANK_TOLERANCE max|De|) (|R_ii| is the size of row i's part
    outside the span and the rows before it); then W becomes W Q without its first k columns
    (the complement of the span grown by r), applied as Q's k Householder reflections.
    """
    kin, scaled_De = scaled_jacobian(model, x)
    columns = kin.free
    prescribed = scaled_De[np.ix_(model.rigid_deformations, columns)]
    top = max(np.abs(scaled_De[:, columns]).max(initial=0.0), 1e-300)
    # N0: the null space of the prescribed rows, block by block (`nullspace`); they are
    # independent in a model that built (the exact-constraint check)
    _, _, basis = rank_and_null_space(prescribed, RANK_TOLERANCE)  # (n, m0)
    complement = np.eye(basis.shape[1], order="F")  # W: the complement is N0 W
    taken = []
    for position, group in enumerate(groups):
        rows = scaled_De[np.ix_(np.asarray(group, dtype=np.int64), columns)]
        k = rows.shape[0]
        norms = np.linalg.norm(rows, axis=1)
        if k == 0 or k > complement.shape[1] or not np.all(norms > 0):
            continue
        # the rows' parts outside the span, W^T N0^T r^T (m, k), from the few columns a
        # deformation depends on (at most 14 coordinates each), and their QR
        touched = np.flatnonzero(np.any(rows != 0.0, axis=0))
        inside = basis[touched].T @ rows[:, touched].T  # (m0, k)
        (reflectors, tau), r = scipy.linalg.qr(complement.T @ inside, mode="raw")
        diagonal = np.abs(np.diagonal(r)[:k])
        if np.all(diagonal > np.maximum(GROUP_TOLERANCE * norms, RANK_TOLERANCE * top)):
            complement = without_leading(complement, reflectors, tau)
            taken.append(position)
    return taken


def without_leading(complement, reflectors, tau):
    """W Q without its first k columns, Q = H_1 ... H_k the reflections of a raw QR
    (`scipy.linalg.qr(..., mode="raw")`: Fortran-ordered, v_i below the diagonal of column
    i), applied by LAPACK's dormqr (`nullspace.apply_reflections`)."""
    product = apply_reflections("R", reflectors, tau, complement)
    return np.asfortranarray(product[:, tau.size:])


__all__ = ["GROUP_TOLERANCE", "freezable"]
