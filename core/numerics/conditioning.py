"""Is a square matrix regular by a margin? Its reciprocal condition number in the 1-norm.

The exact-constraint check clears a Jacobian with it, the compliance refuses a nearly singular
tangent stiffness with it, each against its own bound. For up to EXACT_UP_TO unknowns the
number is exact, 1 / (|A|_1 |A^-1|_1) with numpy's inverse (about n^3 flops: 1 ms at 100,
25 ms at 300 on the development machine), which spares a short command scipy.linalg's import
(0.15 s of CPU); above, LAPACK's gecon estimates it from an LU in O(n^2) after the
O(n^3 / 3) factorisation (the estimate is a lower bound of |A^-1|_1 within a small factor, so
it is at least the exact reciprocal: a bound placed between two decades decides the same).
"""

import warnings

import numpy as np

EXACT_UP_TO = 300  # unknowns


def reciprocal_condition(matrix) -> float:
    """1 / cond_1 of a square `matrix` (exact up to EXACT_UP_TO unknowns, LAPACK's estimate
    above); 0.0 for a non-finite or singular one."""
    if matrix.shape[0] > EXACT_UP_TO:
        return lu_and_rcond(matrix)[1]
    if not np.all(np.isfinite(matrix)):
        return 0.0
    try:
        inverse = np.linalg.inv(matrix)
    except np.linalg.LinAlgError:  # exactly singular
        return 0.0
    norms = np.linalg.norm(matrix, 1) * np.linalg.norm(inverse, 1)
    return float(1.0 / norms) if np.isfinite(norms) and norms > 0.0 else 0.0


def lu_and_rcond(matrix):
    """(the LU factors (lu, piv) of scipy.linalg.lu_factor, the reciprocal condition estimate
    in the 1-norm) of a square `matrix`; rcond is 0.0 for a non-finite or singular one."""
    import scipy.linalg

    if not np.all(np.isfinite(matrix)):
        return None, 0.0
    with warnings.catch_warnings():  # an exactly singular matrix is an answer here
        warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
        factors = scipy.linalg.lu_factor(matrix, check_finite=False)
    rcond, info = scipy.linalg.lapack.dgecon(factors[0], np.linalg.norm(matrix, 1), norm="1")
    return factors, float(rcond) if info == 0 else 0.0
