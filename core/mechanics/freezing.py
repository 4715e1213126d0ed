"""Which deformations can be prescribed zero together: the over-constraint test, incrementally.

A model reduction (`flexure.core.analysis.reduction`) freezes released deformations in an
order of its choosing and must know that every prefix of what it freezes still builds: the
rows of the deformation Jacobian De (rotation columns scaled to lengths,
`constraints.scaled_jacobian`) of the prescribed deformations and of the frozen groups must
stay independent. A group of rows is independent of the span S of the rows taken before it
when its part orthogonal to S has full rank; `freezable` decides that through an orthonormal
basis N of the complement of S (N^T r is the part of r outside S), which shrinks as groups
are taken: each group costs O(n m k) for n free coordinates, m = dim of the complement and k
rows, where projecting against a basis of S costs O(n dim(S) k). In a model with many
prescribed deformations (the six-DOF manipulator's models: about 810 prescribed rows on 1042
free coordinates), the complement is the small side.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..numerics.blas import blas_threads
from .constraints import RANK_TOLERANCE, scaled_jacobian

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

    A group of k rows r is taken when, with N an orthonormal basis of the complement of that
    span and N^T r^T = Q R, every |R_ii| exceeds max(GROUP_TOLERANCE |r_i|, RANK_TOLERANCE
    max|De|) (|R_ii| is the size of row i's part outside the span and the rows before it);
    then N becomes N Q without its first k columns (the complement of the span grown by r),
    applied as Q's k Householder reflections.
    """
    kin, scaled_De = scaled_jacobian(model, x)
    columns = kin.free
    prescribed = scaled_De[np.ix_(model.rigid_deformations, columns)]
    top = max(np.abs(scaled_De[:, columns]).max(initial=0.0), 1e-300)
    complement = _initial_complement(prescribed, RANK_TOLERANCE * top)
    taken = []
    for position, group in enumerate(groups):
        rows = scaled_De[np.ix_(np.asarray(group, dtype=np.int64), columns)]
        k = rows.shape[0]
        norms = np.linalg.norm(rows, axis=1)
        if k == 0 or k > complement.shape[1] or not np.all(norms > 0):
            continue
        reflectors, tau = np.linalg.qr(complement.T @ rows.T, mode="raw")  # transposed
        diagonal = np.abs(np.diagonal(reflectors)[:k])
        if np.all(diagonal > np.maximum(GROUP_TOLERANCE * norms, RANK_TOLERANCE * top)):
            complement = _without_leading(complement, reflectors, tau)
            taken.append(position)
    return taken


def _initial_complement(prescribed, threshold):
    """An orthonormal basis (n, m) of the complement of the span of the prescribed rows
    (p, n): the columns of the complete Q of prescribed^T = Q R but those of the rows kept
    (|R_ii| > threshold; all of them in a model that passed the exact-constraint check)."""
    p, n = prescribed.shape
    q, r = np.linalg.qr(prescribed.T, mode="complete")
    kept = np.zeros(n, dtype=bool)
    kept[:min(p, n)] = np.abs(np.diagonal(r)) > threshold
    return np.ascontiguousarray(q[:, ~kept])


def _without_leading(complement, reflectors, tau):
    """N Q without its first k columns, Q = H_1 ... H_k the reflections of numpy's raw QR
    (`reflectors` transposed: row i holds v_i below its implicit 1 at i)."""
    m = complement.shape[1]
    for i in range(tau.size):
        v = np.zeros(m)
        v[i] = 1.0
        v[i + 1:] = reflectors[i, i + 1:]
        complement = complement - np.outer(tau[i] * (complement @ v), v)
    return np.ascontiguousarray(complement[:, tau.size:])


__all__ = ["GROUP_TOLERANCE", "freezable"]
