"""Is a square matrix regular by a margin? Its LU and reciprocal condition estimate.

LAPACK's gecon estimates 1 / cond_1 from an LU in O(n^2), after the O(n^3 / 3) factorisation
the caller usually wants anyway: the exact-constraint check clears a Jacobian with it, the
compliance refuses a nearly singular tangent stiffness with it, each against its own bound.
"""

import warnings

import numpy as np
import scipy.linalg


def lu_and_rcond(matrix):
    """(the LU factors (lu, piv) of scipy.linalg.lu_factor, the reciprocal condition estimate
    in the 1-norm) of a square `matrix`; rcond is 0.0 for a non-finite or singular one."""
    if not np.all(np.isfinite(matrix)):
        return None, 0.0
    with warnings.catch_warnings():  # an exactly singular matrix is an answer here
        warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
        factors = scipy.linalg.lu_factor(matrix, check_finite=False)
    rcond, info = scipy.linalg.lapack.dgecon(factors[0], np.linalg.norm(matrix, 1), norm="1")
    return factors, float(rcond) if info == 0 else 0.0
