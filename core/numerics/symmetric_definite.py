"""The symmetric-definite eigenproblem K phi = w M phi in numpy, as LAPACK's sygv solves it.

With the Cholesky factor M = L L^T the problem becomes the standard symmetric one C y = w y,
C = L^-1 K L^-T, phi = L^-T y (LAPACK's potrf, sygst, syev and a triangular solve, which
scipy.linalg.eigh calls). Here in numpy, because `flexure analyze` would otherwise import
scipy.linalg for it: 0.12 to 0.15 s of CPU of a 0.5 s process. The triangular solves go through
numpy's general solver (LU with partial pivoting of a triangular matrix: backward stable). The
eigenvalues carry the symmetric eigenproblem's error, of order eps |K| |M^-1|; the vectors are
M-orthonormal, phi^T M phi = I to about eps cond(M) (tests/test_symmetric_definite.py checks
both against scipy.linalg.eigh).
"""

import numpy as np


def symmetric_definite_eigh(K: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and M-orthonormal eigenvectors of K phi = w M phi.

    Parameters
    ----------
    K : ndarray (n, n)
        Symmetric (a stiffness, N/m in the DOF units).
    M : ndarray (n, n)
        Symmetric positive definite (a mass, kg in the DOF units).

    Returns
    -------
    w : ndarray (n,)
        The eigenvalues, ascending (omega^2 in 1/s^2 for a stiffness and a mass).
    phi : ndarray (n, n)
        The eigenvectors as columns, phi^T M phi = I (unit modal mass).

    Raises
    ------
    numpy.linalg.LinAlgError
        M is not positive definite.
    """
    L = np.linalg.cholesky(M)
    C = np.linalg.solve(L, np.linalg.solve(L, K).T)  # L^-1 K L^-T, K symmetric
    w, y = np.linalg.eigh(0.5 * (C + C.T))
    return w, np.linalg.solve(L.T, y)
