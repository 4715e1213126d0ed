"""The BEAM's element mass Me = Dp^T Mp Dp in closed form, from its blocks.

The BEAM's 24 inertia points are 8 vectors of 3 components (`beam.inertia_points`): r^p,
l0 n_x'^p, r^q, l0 n_x'^q (the Hermite points) and n_y'^p, n_z'^p, n_y'^q, n_z'^q (the section
axes). Each vector moves with one block of the 14 coordinates (x_p at 0, lambda_p at 3, x_q
at 7, lambda_q at 10; 3 or 4 wide), and Mp couples component c of vector u with component c
of vector v only (kron(M8, I3), `beam.inertia_matrix`: the Hermite mass on the first four
vectors, the linear-interpolation mass on (n_y'^p, n_y'^q) and on (n_z'^p, n_z'^q)). So

    Me[block_u, block_v] += sum_c Mp[3u + c, 3v + c] Dp[3u + c, block_u]^T Dp[3v + c, block_v]

over the 24 pairs (u, v) of M8's non-zeros: about 970 products in loops of 3 and 4 that the
compiler unrolls, against the generic kernel's walk over Dp's non-zeros with indices read
from memory (`engine.point_masses.element_mass`). `beam_pattern` tells whether a group's
Mp has that pattern and `beam_structured` whether an element's Dp has that structure (the
engine checks both before it uses `beam_element_mass`, so the kernel's answer is Dp^T Mp
Dp, summed in another order, for any element that passes). Units as the coordinates: kg,
kg m, kg m^2.
"""

import numpy as np

from ..numerics.jit import kernel

M, P = 14, 24  # coordinates, inertia points
_STARTS = (0, 3, 7, 10, 3, 3, 10, 10)  # each vector's block of coordinates: its first ...
_WIDTHS = (3, 4, 3, 4, 4, 4, 4, 4)  # ... and its width
# the pairs (u, v) of vectors that Mp couples: the Hermite vectors 0 ... 3 with each other,
# n_y'^p (4) with n_y'^q (6) and n_z'^p (5) with n_z'^q (7), each with itself
_PAIRS = tuple((u, v) for u in range(4) for v in range(4)) + (
    (4, 4), (4, 6), (6, 4), (6, 6), (5, 5), (5, 7), (7, 5), (7, 7))
# the flat entries p P + q of Mp that those pairs fill, ascending (a group's mass pattern)
PATTERN = np.array(sorted((3 * u + c) * P + 3 * v + c for u, v in _PAIRS for c in range(3)),
                   dtype=np.int64)
# per inertia point: the first and the last + 1 of the coordinates it may move with
_POINT_LOW = np.repeat(np.array(_STARTS, dtype=np.int64), 3)
_POINT_HIGH = _POINT_LOW + np.repeat(np.array(_WIDTHS, dtype=np.int64), 3)


@kernel
def beam_pattern(pattern):
    """Whether a group's mass pattern (flat p P + q, ascending) is the BEAM's (`PATTERN`)."""
    if pattern.size != PATTERN.size:
        return False
    for e in range(pattern.size):
        if pattern[e] != PATTERN[e]:
            return False
    return True


@kernel
def beam_structured(Dp, columns):
    """Whether every non-zero of Dp (24, 14) lies in its point's block of coordinates, from
    its rows' non-zero columns and counts `columns` (`point_masses.point_columns`)."""
    counts = columns[P * M:]
    for pp in range(P):
        low, high = _POINT_LOW[pp], _POINT_HIGH[pp]
        for u in range(counts[pp]):
            a = columns[pp * M + u]
            if a < low or a >= high:
                return False
    return True


@kernel(inline="always")
def _pair(Mp, Dp, Me, u, v, su, wu, sv, wv):
    """Me[su:su + wu, sv:sv + wv] += sum_c Mp[3u + c, 3v + c] Dp[3u + c, su:]^T Dp[3v + c, sv:]
    for vectors u, v whose coordinates start at su, sv and are wu, wv wide (constants at each
    call: the loops unroll)."""
    for c in range(3):
        p, q = 3 * u + c, 3 * v + c
        mpq = Mp[p * P + q]
        for i in range(wu):
            d = mpq * Dp[p, su + i]
            row = (su + i) * M + sv
            for j in range(wv):
                Me[row + j] += d * Dp[q, sv + j]


@kernel
def beam_element_mass(Mp, Dp, Me):
    """Me = Dp^T Mp Dp (14 * 14, row by row; kg, kg m, kg m^2) of one BEAM from Mp (24 * 24,
    flat; kg, kg m^2) and Dp (24, 14) of the structure `beam_structured` checks."""
    for a in range(M * M):
        Me[a] = 0.0
    # the Hermite vectors r^p (0), l0 n_x'^p (1), r^q (2), l0 n_x'^q (3): every pair
    _pair(Mp, Dp, Me, 0, 0, 0, 3, 0, 3)
    _pair(Mp, Dp, Me, 0, 1, 0, 3, 3, 4)
    _pair(Mp, Dp, Me, 0, 2, 0, 3, 7, 3)
    _pair(Mp, Dp, Me, 0, 3, 0, 3, 10, 4)
    _pair(Mp, Dp, Me, 1, 0, 3, 4, 0, 3)
    _pair(Mp, Dp, Me, 1, 1, 3, 4, 3, 4)
    _pair(Mp, Dp, Me, 1, 2, 3, 4, 7, 3)
    _pair(Mp, Dp, Me, 1, 3, 3, 4, 10, 4)
    _pair(Mp, Dp, Me, 2, 0, 7, 3, 0, 3)
    _pair(Mp, Dp, Me, 2, 1, 7, 3, 3, 4)
    _pair(Mp, Dp, Me, 2, 2, 7, 3, 7, 3)
    _pair(Mp, Dp, Me, 2, 3, 7, 3, 10, 4)
    _pair(Mp, Dp, Me, 3, 0, 10, 4, 0, 3)
    _pair(Mp, Dp, Me, 3, 1, 10, 4, 3, 4)
    _pair(Mp, Dp, Me, 3, 2, 10, 4, 7, 3)
    _pair(Mp, Dp, Me, 3, 3, 10, 4, 10, 4)
    # the section axes n_y'^p (4) with n_y'^q (6), n_z'^p (5) with n_z'^q (7)
    _pair(Mp, Dp, Me, 4, 4, 3, 4, 3, 4)
    _pair(Mp, Dp, Me, 4, 6, 3, 4, 10, 4)
    _pair(Mp, Dp, Me, 6, 4, 10, 4, 3, 4)
    _pair(Mp, Dp, Me, 6, 6, 10, 4, 10, 4)
    _pair(Mp, Dp, Me, 5, 5, 3, 4, 3, 4)
    _pair(Mp, Dp, Me, 5, 7, 3, 4, 10, 4)
    _pair(Mp, Dp, Me, 7, 5, 10, 4, 3, 4)
    _pair(Mp, Dp, Me, 7, 7, 10, 4, 10, 4)
