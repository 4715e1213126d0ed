"""Dense LU of small matrices, row-major and in place: the reduced mass M_bar (NDOF, NDOF)
and the integrators' Newton matrices (2 NDOF, 2 NDOF).

`lu_factor` is Gaussian elimination with partial pivoting, blocked for the cache (A = P^T L
U, unit L below the diagonal and U on and above it, in the one array), and returns the ratio
of the smallest to the largest pivot magnitude, which callers compare with a threshold to
call a matrix singular; `lu_solve` solves with those factors, `lu_solve_rows` for many
right-hand sides at once (the Jacobian's M_bar^-1 K and M_bar^-1 C). The banded matrices (J,
the augmented system) have their own LU in `core/numerics/banded.py`. `add_row_products` and
`add_row_groups` are the tangent's C += A^T B over the rows of two tall matrices (DF^T (K_x
DF)). `copy` is how compiled code copies one array into another.
"""

import numpy as np

from .jit import kernel

BLOCK = 32  # pivot steps `lu_factor` takes on a panel before it updates the rest


@kernel
def lu_factor(a, n, piv):
    """LU with partial pivoting of the (n, n) row-major a, in place; returns the ratio of the
    smallest to the largest pivot magnitude (0 for an exactly singular matrix).

    Blocked: BLOCK pivot steps on a panel of BLOCK columns (the pivots chosen, whole rows
    swapped, the panel eliminated), then the panel's rows of U and the trailing rows each
    updated once by the BLOCK steps (four rows at a time, which read each row of U once),
    where the textbook loop (tests/test_dense.py's reference) runs over the whole trailing matrix at
    every step: the matrix goes through the cache n / BLOCK times instead of n. Every entry
    gets the same operations in the same order (a_ij -= l_ik u_kj for k ascending, the
    multipliers as a_ik times 1 / u_kk, the same pivots), so the factors are those of the
    textbook loop to the bit."""
    smallest, largest = np.inf, 0.0
    for k0 in range(0, n, BLOCK):
        k1 = min(k0 + BLOCK, n)
        for k in range(k0, k1):  # the panel: columns k0 .. k1 - 1, eliminated step by step
            p, big = k, abs(a[k * n + k])
            for i in range(k + 1, n):
                value = abs(a[i * n + k])
                if value > big:
                    p, big = i, value
            piv[k] = p
            if p != k:
                for j in range(n):
                    a[k * n + j], a[p * n + j] = a[p * n + j], a[k * n + j]
            smallest, largest = min(smallest, big), max(largest, big)
            if big == 0.0:
                continue
            inverse = 1.0 / a[k * n + k]
            for i in range(k + 1, n):
                factor = a[i * n + k] * inverse
                a[i * n + k] = factor
                if factor != 0.0:
                    for j in range(k + 1, k1):
                        a[i * n + j] -= factor * a[k * n + j]
        if k1 == n:
            break
        # the panel's steps on columns k1 .. n - 1: its own rows first (they become U's rows,
        # each final before the next uses it), then the rows below, four at a time
        for i in range(k0 + 1, k1):
            _eliminate_row(a, n, i, k0, i, k1)
        quads = (n - k1) // 4
        for q in range(quads):
            _eliminate_rows(a, n, k1 + 4 * q, k0, k1)
        for i in range(k1 + 4 * quads, n):
            _eliminate_row(a, n, i, k0, k1, k1)
    return smallest / largest if largest > 0.0 else 0.0


@kernel(inline="always")
def _eliminate_row(a, n, i, k0, k_end, k1):
    """Row i of a from column k1 on: a_ij -= a_ik a_kj for k = k0 .. k_end - 1 in turn (a zero
    multiplier skipped, as the textbook loop skips it)."""
    target = a[i * n + k1: (i + 1) * n]
    for k in range(k0, k_end):
        factor = a[i * n + k]
        if factor != 0.0:
            source = a[k * n + k1: (k + 1) * n]
            for j in range(n - k1):
                target[j] -= factor * source[j]


@kernel(inline="always")
def _eliminate_rows(a, n, i, k0, k1):
    """`_eliminate_row` on rows i .. i + 3 with k = k0 .. k1 - 1: each row of U read once for
    the four (the operations on each entry as `_eliminate_row`'s; a step with a zero
    multiplier goes row by row, which skips it)."""
    w = n - k1
    t0, t1 = a[i * n + k1: (i + 1) * n], a[(i + 1) * n + k1: (i + 2) * n]
    t2, t3 = a[(i + 2) * n + k1: (i + 3) * n], a[(i + 3) * n + k1: (i + 4) * n]
    for k in range(k0, k1):
        f0, f1, f2, f3 = a[i * n + k], a[(i + 1) * n + k], a[(i + 2) * n + k], a[(i + 3) * n + k]
        source = a[k * n + k1: (k + 1) * n]
        if f0 != 0.0 and f1 != 0.0 and f2 != 0.0 and f3 != 0.0:
            for j in range(w):
                s = source[j]
                t0[j] -= f0 * s
                t1[j] -= f1 * s
                t2[j] -= f2 * s
                t3[j] -= f3 * s
        else:
            for target, factor in ((t0, f0), (t1, f1), (t2, f2), (t3, f3)):
                if factor != 0.0:
                    for j in range(w):
                        target[j] -= factor * source[j]


@kernel
def lu_solve(a, n, piv, b):
    """Solve A z = b in place (b (n,)) with the factors of `lu_factor`."""
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i * n + j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i * n + j] * b[j]
        b[i] = s / a[i * n + i]


@kernel
def lu_solve_rows(a, n, piv, B, start, stride, width):
    """Solve A Z = B in place for the `width` columns of B with the factors of `lu_factor`:
    row i of B is B[start + i stride: start + i stride + width] (flat; stride >= width), so a
    block of a larger row-major matrix is solved where it lies.

    Every column gets the same operations in the same order as `lu_solve` gives it (each
    row's sum over j ascending), but row by row: the inner loops run along B's rows, which
    the compiler vectorises, where a column at a time reads B with a stride. A zero factor
    entry is skipped (0 times a finite number changes no sum)."""
    for k in range(n):
        p = piv[k]
        if p != k:
            rk, rp = start + k * stride, start + p * stride
            for c in range(width):
                B[rk + c], B[rp + c] = B[rp + c], B[rk + c]
    for i in range(n):
        target = B[start + i * stride: start + i * stride + width]
        for j in range(i):
            factor = a[i * n + j]
            if factor != 0.0:
                source = B[start + j * stride: start + j * stride + width]
                for c in range(width):
                    target[c] -= factor * source[c]
    for i in range(n - 1, -1, -1):
        target = B[start + i * stride: start + i * stride + width]
        for j in range(i + 1, n):
            factor = a[i * n + j]
            if factor != 0.0:
                source = B[start + j * stride: start + j * stride + width]
                for c in range(width):
                    target[c] -= factor * source[c]
        pivot = a[i * n + i]
        for c in range(width):
            target[c] = target[c] / pivot


@kernel
def add_row_products(A, B, n, rows, count, ranges, symmetric, C):
    """C += sum_r A[r, :]^T B[r, :] over the rows r = rows[0 .. count - 1] of the row-major
    (nrows, n) A and B, into the row-major (n, n) C: the tangent's DF^T (K_x DF).

    Each row's entries lie in column ranges: A[r] in [ranges[nrows + r], ranges[2 nrows + r])
    and B[r] in [ranges[3 nrows + r], ranges[4 nrows + r]) (nrows = ranges.size / 5; outside
    them the rows are zero and are not read). `symmetric`: the sum is symmetric (B = X A with
    a symmetric X, and C symmetric before), so only C_ij with j >= i is formed and the lower
    triangle copied from it, half the products. Each entry of C gets its products one by one
    in the order of the rows, C_ij += a_ri b_rj, as the plain loop
    (tests/test_row_products.py's reference) adds them, a zero a_ri skipped (0 times a
    finite number changes no sum). `add_row_groups` is the same sum, faster on large
    matrices and longer to compile."""
    nrows = ranges.size // 5
    lo, hi = ranges[nrows: 2 * nrows], ranges[2 * nrows: 3 * nrows]
    blo, bhi = ranges[3 * nrows: 4 * nrows], ranges[4 * nrows: 5 * nrows]
    for t in range(count):
        _add_one_row(A, B, n, rows[t], lo, hi, blo, bhi, symmetric, C)
    if symmetric:
        _mirror(C, n)


@kernel(inline="always")
def _add_one_row(A, B, n, r0, lo, hi, blo, bhi, symmetric, C):
    """C_ij += a_ri b_rj for the one row r = r0 of A and B (row-major (n, n)), over its
    ranges, a zero a_ri skipped (only the upper triangle where `symmetric`)."""
    for i in range(lo[r0], hi[r0]):
        f = A[r0 * n + i]
        if f != 0.0:
            b0 = max(blo[r0], i) if symmetric else blo[r0]
            source = B[r0 * n + b0: r0 * n + bhi[r0]]
            target = C[i * n + b0: i * n + bhi[r0]]
            for j in range(source.size):
                target[j] += f * source[j]


@kernel(inline="always")
def _mirror(C, n):
    """C's lower triangle from its upper one (row-major (n, n))."""
    for i in range(n):
        for j in range(i):
            C[i * n + j] = C[j * n + i]


@kernel
def add_row_groups(A, B, n, rows, count, ranges, symmetric, C):
    """`add_row_products`' sum (its arguments), for large matrices: the rows are taken four
    at a time where their ranges agree (a node's coordinates share their DOFs), so that each
    row of C is read and written once for the four (2.5 times as fast on the 507-DOF
    manipulator_reduced, and a second longer to compile). Each entry of C gets its products
    one by one in the order of the rows, as there, a zero a_ri skipped only where the group's
    four are zero (elsewhere it adds 0 b_rj: the same sum for finite b_rj)."""
    nrows = ranges.size // 5
    lo, hi = ranges[nrows: 2 * nrows], ranges[2 * nrows: 3 * nrows]
    blo, bhi = ranges[3 * nrows: 4 * nrows], ranges[4 * nrows: 5 * nrows]
    t = 0
    while t < count:
        r0 = rows[t]
        if (t + 3 < count and lo[rows[t + 1]] == lo[r0] and lo[rows[t + 2]] == lo[r0]
                and lo[rows[t + 3]] == lo[r0] and hi[rows[t + 1]] == hi[r0]
                and hi[rows[t + 2]] == hi[r0] and hi[rows[t + 3]] == hi[r0]
                and blo[rows[t + 1]] == blo[r0] and blo[rows[t + 2]] == blo[r0]
                and blo[rows[t + 3]] == blo[r0] and bhi[rows[t + 1]] == bhi[r0]
                and bhi[rows[t + 2]] == bhi[r0] and bhi[rows[t + 3]] == bhi[r0]):
            _add_four_rows(A, B, n, rows[t], rows[t + 1], rows[t + 2], rows[t + 3], lo[r0],
                           hi[r0], blo[r0], bhi[r0], symmetric, C)
            t += 4
            continue
        _add_one_row(A, B, n, r0, lo, hi, blo, bhi, symmetric, C)
        t += 1
    if symmetric:
        _mirror(C, n)


@kernel(inline="always")
def _add_four_rows(A, B, n, r0, r1, r2, r3, lo, hi, b0, b1, symmetric, C):
    """`add_row_groups` on the rows r0 .. r3, whose ranges are alike: C's row i read and
    written once for the four (each C_ij gets the four products one by one in the rows'
    order)."""
    for i in range(lo, hi):
        f0, f1, f2, f3 = A[r0 * n + i], A[r1 * n + i], A[r2 * n + i], A[r3 * n + i]
        if f0 == 0.0 and f1 == 0.0 and f2 == 0.0 and f3 == 0.0:
            continue
        c0 = max(b0, i) if symmetric else b0
        s0, s1 = B[r0 * n + c0: r0 * n + b1], B[r1 * n + c0: r1 * n + b1]
        s2, s3 = B[r2 * n + c0: r2 * n + b1], B[r3 * n + c0: r3 * n + b1]
        target = C[i * n + c0: i * n + b1]
        for j in range(target.size):
            c = target[j] + f0 * s0[j]
            c += f1 * s1[j]
            c += f2 * s2[j]
            target[j] = c + f3 * s3[j]


@kernel
def put(J, N, i, j, value, column_major):
    """J[i, j] = value in the flat (N, N) J, column-major (SUNDIALS' dense matrix) or
    row-major."""
    if column_major:
        J[j * N + i] = value
    else:
        J[i * N + j] = value


@kernel
def copy(destination, source):
    """destination[i] = source[i] for each i < source.size (destination at least as long).

    A loop rather than `destination[:] = source`: numba compiles that slice assignment's
    shape check with a formatted error message into every function that has one, which cost
    the first compilation several seconds, and a mismatch is a bug that tests catch."""
    for i in range(source.size):
        destination[i] = source[i]


@kernel
def all_finite(v):
    """Whether every entry of the vector v is finite (a loop: numba's np.all would make every
    process that loads the compiled code import numba's array maths, and through it
    scipy.linalg)."""
    for value in v:
        if not np.isfinite(value):
            return False
    return True
