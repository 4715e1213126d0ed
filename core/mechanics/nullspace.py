"""The null space of a sparse constraint matrix, block by block.

The prescribed deformations' rows R (n_rigid x n_free, rotations scaled to lengths) of a
large model are almost empty: a deformation depends on at most 14 coordinates. Rows and
columns that share no entry, directly or through a chain of others, form independent blocks
(after a permutation R is block-diagonal), and the singular values of R are those of its
blocks together, its null space the blocks' null spaces side by side (each on its own
columns, zero elsewhere), plus a unit vector for every column no row touches. On the
816-DOF manipulator R has 863 blocks of at most 36 x 42: the SVDs of the blocks take
milliseconds where the one of R took 0.5 s (one BLAS thread), twice (its rank, then its null
space). A model with one large block (the manipulator with its elongations prescribed:
810 x 1042 of 937 x 1582) still saves the columns outside it and the second SVD.

The basis differs from the full SVD's by an orthogonal transformation within the null
space (up to round-off): `choose_dofs` uses it only through projections, rows @ N, whose
norms and inner products do not depend on the basis chosen.
"""

from __future__ import annotations

import numpy as np

from ..numerics.sparse_blocks import blocks

SVD_UP_TO = 64  # columns: a block this small takes its SVD (a millisecond); a larger a QR
ESTIMATE_SLACK = 10.0  # how far LAPACK's 1-norm rcond estimate may exceed the true value


def rank_and_null_space(matrix: np.ndarray, rtol: float) -> tuple[int, float, np.ndarray]:
    """The singular values' verdicts on `matrix` (m, n) and an orthonormal basis of its null
    space, from its independent blocks (module docstring).

    A block of more than SVD_UP_TO columns is first tried by a QR factorisation of its
    transpose, B^T = Q [T; 0] (0.07 s for the manipulator_e1's 810 x 1042 block, against
    0.6 s for its SVD): when T is clearly regular its null space is the last columns of Q
    and it has full row rank by both thresholds. "Clearly": sigma_min(B) >= sigma_max(B) /
    kappa_2(T) and kappa_2 <= r kappa_1 for r rows, kappa_1 from LAPACK's trcon estimate
    allowed to be ESTIMATE_SLACK times optimistic, and sigma_max(B) at least B's largest row
    norm; that bound on sigma_min must clear `rtol` times an upper bound of the largest
    singular value of the whole matrix (each QR block's Frobenius norm). Where it does not,
    or where a small block's singular value lies between `rtol` times the lower and the upper
    bound of that largest value, every block takes its SVD: the verdicts are then exactly
    those of the whole matrix's SVD.

    Parameters
    ----------
    matrix : ndarray (m, n)
        Any units; the thresholds are relative.
    rtol : float
        A singular value counts for the null space when above `rtol` times the largest
        (as `numpy.linalg.svd` would be read on the whole matrix).

    Returns
    -------
    rank_by_entries : int
        The singular values above `rtol` times the largest entry magnitude (the count of
        `numpy.linalg.matrix_rank(matrix, tol=rtol * max|matrix|)`).
    top : float
        The largest singular value (units of `matrix`); a lower bound of it where a block
        was cleared by its QR.
    null_space : ndarray (n, n - rank)
        Orthonormal columns spanning the vectors the matrix maps to zero, rank counted
        with the threshold `rtol` times the largest singular value.
    """
    found = by_blocks(matrix, rtol, SVD_UP_TO)
    if found is None:  # not clear from the QRs: the SVD of every block decides
        found = by_blocks(matrix, rtol, None)
    return found


def by_blocks(matrix, rtol, svd_up_to):
    """`rank_and_null_space` with blocks above `svd_up_to` columns (None: none) tried by
    QR; None where that does not settle the verdicts."""
    m, n = matrix.shape
    parts = []  # (columns, singular values or None, null-space rows (k, columns))
    low = high = 0.0  # bounds of the largest singular value of the QR blocks
    cleared = []  # (sigma_min bound) of each QR block
    for rows, columns in blocks(matrix):
        if columns.size == 0:  # an empty row: a singular value zero
            parts.append((columns, np.zeros(1), np.zeros((0, 0))))
            continue
        block = matrix[np.ix_(rows, columns)]
        if svd_up_to is not None and columns.size > svd_up_to and rows.size <= columns.size:
            bound = _qr_clear(block)
            if bound is None:
                return None
            null, sigma_min, row_norm, frobenius = bound
            low, high = max(low, row_norm), max(high, frobenius)
            cleared.append((rows.size, sigma_min))
            parts.append((columns, None, null.T))
            continue
        _, s, vt = np.linalg.svd(block)
        parts.append((columns, s, vt))
    values = [s for _, s, _ in parts if s is not None]
    values = np.concatenate(values) if values else np.zeros(0)
    known = float(values.max(initial=0.0))
    low, high = max(low, known), max(high, known)
    ambiguous = (values > rtol * low) & (values <= rtol * high)
    if ambiguous.any() or any(sigma_min <= rtol * high for _, sigma_min in cleared):
        return None
    entries = float(np.abs(matrix).max(initial=0.0))
    rank_by_entries = int(np.sum(values > rtol * max(entries, 1e-300)))
    rank_by_entries += sum(size for size, _ in cleared)  # full row rank: sigma > rtol top
    threshold = rtol * max(high, 1e-300)  # decides as rtol * top would: no value between
    vectors = []
    touched = np.zeros(n, dtype=bool)
    for columns, s, vt in parts:
        touched[columns] = True
        null_rows = vt if s is None else vt[int(np.sum(s > threshold)):]
        if null_rows.shape[0]:
            full = np.zeros((null_rows.shape[0], n))
            full[:, columns] = null_rows
            vectors.append(full)
    free = np.flatnonzero(~touched)
    if free.size:
        vectors.append(np.eye(n)[free])
    basis = np.vstack(vectors).T if vectors else np.zeros((n, 0))
    return rank_by_entries, low, basis


def _qr_clear(block):
    """(the last c - r columns of Q of B^T = Q [T; 0], a lower bound of sigma_min(B), B's
    largest row norm, its Frobenius norm) for a block B (r, c), r <= c, whose T is regular;
    None when T is not clearly so (`rank_and_null_space`).

    Q's last columns are its reflections applied to [0; I] (LAPACK's dormqr): about half
    the work of forming the complete Q (dorgqr) whose first r columns would go unused
    (0.05 against 0.10 s on manipulator_e1's 810 x 1042 block)."""
    import scipy.linalg
    from scipy.linalg.lapack import dtrcon
    from threadpoolctl import threadpool_limits

    from ..numerics.blas import default_threads

    # scipy's own OpenBLAS may load just now, inside the caller's `blas_threads`, which
    # limits the libraries loaded when it opened (`numerics.blas`): unlimited, its two
    # threads cost manipulator_control's load 0.3 to 1 s of CPU on the loaded 2-core machine
    with threadpool_limits(limits=default_threads(), user_api="blas"):
        r, c = block.shape
        (reflectors, tau), t = scipy.linalg.qr(block.T, mode="raw")
        rcond, info = dtrcon(t[:r], norm="1", uplo="U", diag="N")
        row_norm = float(np.linalg.norm(block, axis=1).max())
        if info != 0 or not rcond > 0.0:
            return None
        trailing = np.zeros((c, c - r), order="F")
        trailing[r:] = np.eye(c - r)
        null = apply_reflections("L", reflectors, tau, trailing)
    sigma_min = row_norm * rcond / (ESTIMATE_SLACK * r)
    return null, sigma_min, row_norm, float(np.linalg.norm(block))


def apply_reflections(side, reflectors, tau, matrix):
    """Q C (side "L") or C Q (side "R"), C = `matrix` (Fortran-ordered float64, overwritten)
    and Q = H_1 ... H_k the reflections of a raw QR (`scipy.linalg.qr(..., mode="raw")`:
    v_i below the diagonal of column i of `reflectors`), by LAPACK's dormqr: blocked, matrix
    products where k rank-one updates would each pass over the whole of C."""
    from scipy.linalg.lapack import dormqr

    # LAPACK's optimal workspace (its block size at most 64 and the block's triangle T of
    # 65 x 64); less makes dormqr fall back to its unblocked rank-one updates
    width = matrix.shape[1] if side == "L" else matrix.shape[0]
    product, _, info = dormqr(side, "N", reflectors, tau, matrix, max(1, width) * 64 + 65 * 64,
                              overwrite_c=1)
    if info != 0:
        raise RuntimeError(f"dormqr failed (info {info})")
    return product
