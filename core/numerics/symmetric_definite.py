"""The symmetric-definite eigenproblem K phi = w M phi in numpy, as LAPACK's sygv solves it.

With the Cholesky factor M = L L^T the problem becomes the standard symmetric one C y = w y,
C = L^-1 K L^-T, phi = L^-T y (LAPACK's potrf, sygst, syev and a triangular solve, which
scipy.linalg.eigh calls). Here in numpy, because `flexure analyze` would otherwise import
scipy.linalg for it: 0.12 to 0.15 s of CPU of a 0.5 s process. The triangular solves go through
numpy's general solver (LU with partial pivoting of a triangular matrix: backward stable). The
eigenvalues carry the symmetric eigenproblem's error, of order eps |K| |M^-1|; the vectors are
M-orthonormal, phi^T M phi = I to about eps cond(M) (tests/test_symmetric_definite.py checks
both against scipy.linalg.eigh).

Where only the lowest `count` of a large problem are wanted (from SUBSET_FROM unknowns: the
modes of the manipulator's 507 to 816 DOFs, of which an analysis reports 7 to 20), LAPACK's
sygvx (scipy.linalg.eigh with subset_by_index) computes just those: the same Cholesky
reduction, then bisection and inverse iteration for `count` vectors instead of every vector
and all n back-transformations; 16 ms against 65 to 72 ms of CPU on the 507-DOF
manipulator_reduced with count 7, its eigenvalues within 6e-10 of the full solve's (relative
to the largest of them; one BLAS thread against several moves them by 2.4e-10). scipy.linalg
is imported there only: a model that large has imported it for its DOF choice already.
"""

import numpy as np

# from this many unknowns on, a subset of the eigenpairs comes from sygvx (module docstring)
SUBSET_FROM = 200


def symmetric_definite_eigh(K: np.ndarray, M: np.ndarray, count: int | None = None,
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and M-orthonormal eigenvectors of K phi = w M phi.

    Parameters
    ----------
    K : ndarray (n, n)
        Symmetric (a stiffness, N/m in the DOF units).
    M : ndarray (n, n)
        Symmetric positive definite (a mass, kg in the DOF units).
    count : int, optional
        The lowest `count` eigenpairs only (default: all n); from SUBSET_FROM unknowns on
        they are computed alone (module docstring).

    Returns
    -------
    w : ndarray (m,)
        The lowest m = min(count, n) eigenvalues (all n without `count`), ascending
        (omega^2 in 1/s^2 for a stiffness and a mass).
    phi : ndarray (n, m)
        Their eigenvectors as columns, phi^T M phi = I (unit modal mass).

    Raises
    ------
    numpy.linalg.LinAlgError
        M is not positive definite.
    """
    n = K.shape[0]
    if count is not None and 0 < count < n and n >= SUBSET_FROM:
        import scipy.linalg

        # LinAlgError (numpy's class) where M is not positive definite, as below
        return scipy.linalg.eigh(K, M, subset_by_index=[0, count - 1], driver="gvx",
                                 check_finite=False)
    L = np.linalg.cholesky(M)
    C = np.linalg.solve(L, np.linalg.solve(L, K).T)  # L^-1 K L^-T, K symmetric
    w, y = np.linalg.eigh(0.5 * (C + C.T))
    phi = np.linalg.solve(L.T, y)  # every column, as before `count`: the same bits
    return (w, phi) if count is None else (w[:count], phi[:, :count])
