"""J's factors kept from an earlier kinematic solution, and the solves refined against J.

At every kinematic solution `kinematics.store_solution` factors the constraint Jacobian J for
the solves the evaluation makes with it (xdot = J^-1 [0; qdot], the stage force's xddot_c
and J^-T w, DF) and for the next solution's warm start. On a model whose J is factored
sparse (dims J_SPARSE), a solution may instead keep the factors of an earlier one, J_f =
J(x_f), while every free coordinate has moved at most settings[J_KEPT_MOVE] of its step
tolerances (slot step_tolerance) since x_f (`keeps_factors`); 0 there (the default) factors J
at every solution. The solves with "J at the solution" (`factors.j_solve`) then take

    y_0 = J_f^-1 b,   y_{i+1} = y_i + J_f^-1 (b - J y_i)       (i < settings[J_REFINEMENTS])

with J's values at the solution (written by `sparse_factors.factor`, SPARSE_J_VALUES): each
refinement multiplies the error by ||J_f^-1 (J - J_f)||, of the order of the move over the
elements' lengths. With no refinement the solves are J_f's own, off J's by that first-order
term. The chord steps and the first-order prediction take J_f's factors as they are
(`factors.j_solve_kept`): they converge on the residual, not on J.

The singular-configuration check (`store_solution`: SINGULAR_CONSTRAINTS when the pivot ratio
of J's LU is at most settings[SINGULAR_RATIO]) runs at every factorisation; the factors are
kept only while their ratio exceeds KEPT_MARGIN times that limit, so that within the small
moves that keep them (J's entries changing by a relative order of the move) J cannot reach
the limit unchecked. A full Newton (no warm start) always factors at its solution.

dims[J_KEPT] says which solution the factors are of: KEPT_NONE (none recorded: a
factorisation at another point, `factors.j_factor`), KEPT_EXACT (slot x's, recorded in slot
j_factored with their pivot ratio), KEPT_EARLIER (an earlier solution's, slot j_factored).
"""

from ..numerics import sparse_lu
from ..numerics.dense import copy
from ..numerics.jit import kernel
from ..numerics.sparse_lu import unsigned_index as _u
from . import data as ed
from . import slots as slot
from .slots import float_array as _f
from .slots import int_array as _i

KEPT_NONE, KEPT_EXACT, KEPT_EARLIER = range(3)
# the factors are kept only while their pivot ratio is this many times the singular ratio
KEPT_MARGIN = 100.0


@kernel
def keeps_factors(table, x):
    """Whether the kinematic solution x (NX,: m, 1) keeps J's factors of the earlier solution
    recorded in slot j_factored: sparse factors, recorded with a pivot ratio over KEPT_MARGIN
    times the singular ratio, every free coordinate within settings[J_KEPT_MOVE] of its step
    tolerances of them (the module docstring)."""
    dims, settings = _i(table, slot.DIMS), _f(table, slot.SETTINGS)
    limit = settings[ed.J_KEPT_MOVE]
    if not (limit > 0.0 and dims[ed.J_KEPT] != KEPT_NONE
            and dims[ed.J_FACTORS] == ed.SPARSE_FACTORS):
        return False
    nf = dims[ed.NFREE]
    at = _f(table, slot.J_FACTORED)
    if not at[nf] > KEPT_MARGIN * settings[ed.SINGULAR_RATIO]:
        return False
    free, tolerance = _i(table, slot.FREE), _f(table, slot.STEP_TOLERANCE)
    for a in range(nf):
        if not abs(x[free[a]] - at[a]) <= limit * tolerance[a]:  # a NaN: not kept
            return False
    return True


@kernel
def record_factors(table, x, ratio):
    """J's factors, just made at the solution x (NX,), recorded as of it (slot j_factored:
    its free coordinates, then the pivot ratio)."""
    dims = _i(table, slot.DIMS)
    nf = dims[ed.NFREE]
    at, free = _f(table, slot.J_FACTORED), _i(table, slot.FREE)
    for a in range(nf):
        at[a] = x[free[a]]
    at[nf] = ratio
    dims[ed.J_KEPT] = KEPT_EXACT


@kernel
def residual(ints, floats, y, b, r, transposed):
    """r = b - A y (or with transposed b - A^T y), all (n,) in A's own order, with A the
    sparse LU's matrix values (`sparse_lu.matrix_values`: compressed columns, column j
    A's column pcol[j], the rows A's own)."""
    n, Ap, Ai, _, _, _, _, _, _, pcol, _, _, _, _, Ax, _, _, _ = sparse_lu.packed_parts(
        ints, floats)
    if transposed:
        for j in range(n):
            c = _u(pcol[j])
            s = b[c]
            for p in range(Ap[j], Ap[j + 1]):
                s -= Ax[p] * y[_u(Ai[p])]
            r[c] = s
        return
    copy(r, b)
    for j in range(n):
        yj = y[_u(pcol[j])]
        if yj != 0.0:
            for p in range(Ap[j], Ap[j + 1]):
                r[_u(Ai[p])] -= Ax[p] * yj


@kernel
def refined_solve(table, ints, floats, b, transposed):
    """b <- J^-1 b (or J^-T b), (n_free,) in place, with the kept factors of J_f and
    settings[J_REFINEMENTS] refinements against J's values at the solution (the module
    docstring); slot j_refinement is scratch."""
    nf = b.size
    work = _f(table, slot.J_REFINEMENT)
    rhs, r = work[:nf], work[nf: 2 * nf]
    copy(rhs, b)
    sparse_lu.solve(ints, floats, b, transposed)
    for _ in range(int(_f(table, slot.SETTINGS)[ed.J_REFINEMENTS])):
        residual(ints, floats, b, rhs, r, transposed)
        sparse_lu.solve(ints, floats, r, transposed)
        for a in range(nf):
            b[a] += r[a]
