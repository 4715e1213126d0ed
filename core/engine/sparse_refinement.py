"""The augmented system solved with kept sparse factors and iterative refinement.

Successive evaluations of one integration step differ by O(h) in the state, and so do their
augmented matrices A (the masses move with the rotations, J_o with the coordinates). The
sparse LU of `numerics.sparse_lu` keeps A's values apart from its factors L U, so the
factors of an earlier A still serve the current one through iterative refinement (Wilkinson;
Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed., ch. 12):

    x_0 = (L U)^-1 b,   r_k = b - A x_k,   x_{k+1} = x_k + (L U)^-1 r_k

which contracts at the rate of ||I - (L U)^-1 A||. It stops on the sparse componentwise
backward error (Arioli, Demmel & Duff 1989; `backward_error`) at TOLERANCE = 16 eps, the
level a fresh factorisation's solve reaches: x_k is then the exact solution of a system
within 16 eps of A and b entry by entry (normwise on the rows whose terms nearly vanish), so
the answers differ from a fresh factorisation's by round-off.

The caller refactors when omega_0 exceeds FIRST_LIMIT, a correction does not shrink omega by
CONTRACTION, or MAX_CORRECTIONS are spent. Each correction costs one product with A and a
pair of triangular solves: on the six-DOF manipulator's augmented system (233 unknowns,
nnz 5160) a residual 7.7 us and a solve 6.1 us against the refactor's 49 us.

Measured, not kept (docs/benchmarks.md, session 29): at the loop's states the corrections
contract by only 1e-2 to 1e-3 each, two to three are needed, and with the refinements that
give up the loop spends more than the refactors it saves.

Compiled into the sparse operations only (`sparse_factors`), as the sparse LU is.
"""

import numpy as np

from ..numerics import sparse_lu
from ..numerics.jit import kernel

EPS = np.finfo(np.float64).eps
TOLERANCE = 16.0 * EPS  # the componentwise backward error at which the solution is accepted
FIRST_LIMIT = 0.1  # omega_0 above it: refactor
CONTRACTION = 0.1  # a correction must shrink omega at least this much, else refactor
MAX_CORRECTIONS = 3  # beyond these a refactor is cheaper
SPARSE_ROW = 1000.0  # a row's componentwise bound gives way below this times n eps
NOT_CONVERGED = -1.0  # `refined_solve`'s answer when the caller should refactor
# OP_SPARSE_FACTOR's s for the refined solve of the augmented system (`sparse_factors.factor`),
# beside the three of `operations`
REFINED_AUGMENTED = 3


@kernel
def backward_error(ints, floats, x, b, r, scale, row_max):
    """r = b - A x (n,) with A the current values of the packed sparse matrix
    (`sparse_lu.matrix_values`), and the sparse componentwise backward error of x (Arioli,
    Demmel & Duff, SIAM J. Matrix Anal. Appl. 10, 1989): max_i |r_i| / d_i with d_i = (|A|
    |x| + |b|)_i, or, on a row where d_i <= SPARSE_ROW n eps (||A_i|| ||x|| + |b_i|) (a row
    whose terms nearly vanish, as a single entry times an unknown that is zero but for
    round-off, where no componentwise bound can hold), d_i + ||A_i||_inf ||x||_inf. scale and
    row_max (n,) scratch; inf when r or x is not finite."""
    n, Ap, Ai, _, _, _, _, _, _, pcol, _, _, _, _, Ax, _, _, _ = sparse_lu._parts(ints, floats)
    for i in range(n):
        r[i] = b[i]
        scale[i] = abs(b[i])
        row_max[i] = 0.0
    largest = 0.0
    for j in range(n):  # column j of the packed A Q is A's column pcol[j]
        xj = x[pcol[j]]
        axj = abs(xj)
        if not axj <= largest:
            largest = axj if axj == axj else np.inf
        for p in range(Ap[j], Ap[j + 1]):
            i = Ai[p]
            a = abs(Ax[p])
            row_max[i] = max(row_max[i], a)
            if xj != 0.0:
                r[i] -= Ax[p] * xj
                scale[i] += a * axj
    worst = 0.0
    tau = SPARSE_ROW * n * EPS
    for i in range(n):
        if r[i] == 0.0:
            continue
        d = scale[i]
        normwise = row_max[i] * largest
        if d <= tau * (normwise + abs(b[i])):
            d += normwise
        w = abs(r[i]) / d  # inf or nan where r or x is not finite
        if not w <= worst:
            worst = w if w == w else np.inf
    return worst


@kernel
def refined_solve(ints, floats, b, x, r, scale, row_max):
    """x (n,) = A^-1 b with the kept factors of the packed sparse LU refined against A's
    current values (the module's docstring); b is left as it was, r and scale (n,) scratch.
    Returns the backward error reached (<= TOLERANCE), or NOT_CONVERGED when the caller
    should refactor (no kept factors, too far from A, slow contraction)."""
    if ints[sparse_lu.H_VALID] != 1:
        return NOT_CONVERGED
    n = ints[sparse_lu.H_N]
    for i in range(n):
        x[i] = b[i]
    sparse_lu.solve(ints, floats, x, False)
    previous = FIRST_LIMIT / CONTRACTION  # omega_0 must be at most FIRST_LIMIT
    for k in range(MAX_CORRECTIONS + 1):
        omega = backward_error(ints, floats, x, b, r, scale, row_max)
        if omega <= TOLERANCE:
            return omega
        if k == MAX_CORRECTIONS or not omega <= CONTRACTION * previous:
            return NOT_CONVERGED
        previous = omega
        sparse_lu.solve(ints, floats, r, False)
        for i in range(n):
            x[i] += r[i]
    return NOT_CONVERGED
