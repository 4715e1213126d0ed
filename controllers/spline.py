"""The interpolating cubic spline of a sampled frequency response, as polynomial pieces.

The margins of a sampled loop (robustness.siso_margins) are refined between the grid's
frequencies on the not-a-knot cubic spline through the response's samples: the interpolant
of python-control's 'frd' margins (FITPACK's interpolating splprep) and of scipy's
CubicSpline. On the interval [w_i, w_i+1] the spline is the cubic

    L(w_i + t) = c_0 t^3 + c_1 t^2 + c_2 t + c_3,     0 <= t <= w_i+1 - w_i,

so a crossing or an extremum of any polynomial in its real and imaginary parts (|L|^2 - 1,
Im L, |1 + L|^2) is a root of a polynomial in t, found exactly, with no iteration and no
scipy.interpolate or scipy.optimize to import (a tenth of a second of the loop's start-up).
"""

from __future__ import annotations

import numpy as np


def cubic_pieces(x, y) -> np.ndarray:
    """The not-a-knot cubic spline through (x, y) as its pieces' coefficients.

    Parameters
    ----------
    x : array_like (n,)
        Increasing abscissae (rad/s), n >= 4.
    y : array_like (n,)
        The samples, real or complex (the response, in its units).

    Returns
    -------
    ndarray (n - 1, 4)
        Row i: c_0..c_3 of the cubic in t = x - x_i on [x_i, x_i+1], highest power first.
        The slopes s_i at the knots solve the tridiagonal system of continuous second
        derivatives, the first and last rows taking the not-a-knot condition (a continuous
        third derivative at x_1 and x_n-2), as scipy's CubicSpline does.
    """
    from scipy.linalg import solve_banded  # loaded with flexure.core's models already

    x = np.asarray(x, float)
    y = np.asarray(y)
    dx = np.diff(x)
    slope = np.diff(y) / dx
    n = x.size
    bands = np.zeros((3, n))  # upper, main and lower diagonals in solve_banded's layout
    rhs = np.empty(n, dtype=np.result_type(y, float))
    bands[1, 1:-1] = 2.0 * (dx[:-1] + dx[1:])
    bands[0, 2:] = dx[:-1]
    bands[2, :-2] = dx[1:]
    rhs[1:-1] = 3.0 * (dx[1:] * slope[:-1] + dx[:-1] * slope[1:])
    first, last = x[2] - x[0], x[-1] - x[-3]
    bands[1, 0], bands[0, 1] = dx[1], first
    rhs[0] = ((dx[0] + 2.0 * first) * dx[1] * slope[0] + dx[0] ** 2 * slope[1]) / first
    bands[1, -1], bands[2, -2] = dx[-2], last
    rhs[-1] = (dx[-1] ** 2 * slope[-2] + (2.0 * last + dx[-1]) * dx[-2] * slope[-1]) / last
    s = solve_banded((1, 1), bands, rhs, check_finite=False)
    # the Hermite cubic of each interval from its end values and slopes
    curvature = (s[:-1] + s[1:] - 2.0 * slope) / dx
    return np.column_stack([curvature / dx, (slope - s[:-1]) / dx - curvature, s[:-1],
                            y[:-1]])


def roots_within(polynomial, length: float) -> np.ndarray:
    """The real roots t of a real polynomial (highest power first) in [0, length], sorted.

    A root that round-off puts just outside the interval or just off the real axis (within
    1e-9 of its length) is taken and clipped onto it: the callers look where the polynomial's
    values at the interval's ends change sign, so a root is there.
    """
    polynomial = np.trim_zeros(np.asarray(polynomial, float), "f")
    if polynomial.size < 2:
        return np.zeros(0)
    roots = np.roots(polynomial)
    slack = 1e-9 * length
    real = roots[np.abs(roots.imag) <= slack].real
    real = real[(real >= -slack) & (real <= length + slack)]
    return np.sort(np.clip(real, 0.0, length))
