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

Where only the mass times an acceleration is needed (a residual in mass form,
`engine.inertia_product`), `beam_point_product` gives Dp^T Mp (f - Dp a) through the same
blocks without forming Me (about 250 multiplications), guarded by `beam_blocks_only`, the
block check read off Dp itself, or decided once for a group whose points are the BEAM's own
(`blocks_by_construction`: its kernel zeroes Dp and fills the blocks alone).
"""

import numpy as np

from ..numerics.jit import kernel
from . import beam_kernels

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


def blocks_by_construction(kind):
    """Whether every Dp that the element module `kind`'s inertia entry forms has the BEAM's
    block structure, whatever the state: its entry is the BEAM's (`beam_kernels.inertia_kernel`
    sets all of Dp to zero and then writes each point's block of coordinates alone), so
    `beam_blocks_only` holds for each of its elements and the engine may decide it once per
    group when it packs the model (`engine.packing`, group field point_blocks)."""
    return getattr(kind, "inertia_entry", None) is beam_kernels.inertia_entry


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


# -- the product Dp^T Mp (f - Dp a) without the element mass ------------------------------------
@kernel(inline="always")
def _blocks_only(Dp, u, su, wu):
    """Whether rows 3u ... 3u + 2 of Dp (24, 14) are zero outside columns su ... su + wu - 1
    (constants at each call: the loops unroll)."""
    nonzero = False
    for c in range(3):
        p = 3 * u + c
        for j in range(su):
            nonzero |= Dp[p, j] != 0.0
        for j in range(su + wu, M):
            nonzero |= Dp[p, j] != 0.0
    return not nonzero


@kernel
def beam_blocks_only(Dp):
    """Whether every non-zero of Dp (24, 14) lies in its point's block of coordinates (as
    `beam_structured`, read off Dp itself: no list of its non-zero columns is needed)."""
    return (_blocks_only(Dp, 0, 0, 3) and _blocks_only(Dp, 1, 3, 4)
            and _blocks_only(Dp, 2, 7, 3) and _blocks_only(Dp, 3, 10, 4)
            and _blocks_only(Dp, 4, 3, 4) and _blocks_only(Dp, 5, 3, 4)
            and _blocks_only(Dp, 6, 10, 4) and _blocks_only(Dp, 7, 10, 4))


@kernel(inline="always")
def _less_block_product(Dp, a, point, u, su, wu):
    """point[3u + c] -= Dp[3u + c, su:su + wu] a[su:su + wu] for c = 0, 1, 2."""
    for c in range(3):
        p = 3 * u + c
        s = 0.0
        for j in range(wu):
            s += Dp[p, su + j] * a[su + j]
        point[p] -= s


@kernel(inline="always")
def _add_block_transposed(Dp, w, out, u, su, wu):
    """out[su:su + wu] += Dp[3u + c, su:su + wu] w[3u + c] for c = 0, 1, 2."""
    for c in range(3):
        p = 3 * u + c
        for j in range(wu):
            out[su + j] += Dp[p, su + j] * w[p]


@kernel(inline="always")
def _less_points_product(Dp, a, point):
    """point (24,) -= Dp a, block by block of Dp's structure (`beam_blocks_only`)."""
    _less_block_product(Dp, a, point, 0, 0, 3)
    _less_block_product(Dp, a, point, 1, 3, 4)
    _less_block_product(Dp, a, point, 2, 7, 3)
    _less_block_product(Dp, a, point, 3, 10, 4)
    _less_block_product(Dp, a, point, 4, 3, 4)
    _less_block_product(Dp, a, point, 5, 3, 4)
    _less_block_product(Dp, a, point, 6, 10, 4)
    _less_block_product(Dp, a, point, 7, 10, 4)


@kernel(inline="always")
def _mass_product(Mp, point, w):
    """w = Mp point (24,) on the BEAM's pattern."""
    for c in range(3):  # Mp couples component c of the vectors with component c only
        for u in range(4):  # the Hermite vectors with each other
            p = 3 * u + c
            s = 0.0
            for v in range(4):
                s += Mp[p * P + 3 * v + c] * point[3 * v + c]
            w[p] = s
        for u in range(4, 8):  # n_y'^p with n_y'^q (4, 6), n_z'^p with n_z'^q (5, 7)
            p, first = 3 * u + c, 4 + u % 2
            w[p] = Mp[p * P + 3 * first + c] * point[3 * first + c] \
                + Mp[p * P + 3 * (first + 2) + c] * point[3 * (first + 2) + c]


@kernel
def beam_point_product(Mp, Dp, a, point, w, out):
    """One BEAM's point forces less the inertia of the accelerations a (14,; m/s^2, 1/s^2):
    point (24,) -= Dp a, w = Mp point (N per the points' unit), out (14,; N, N m) = Dp^T w,
    for Mp (24 * 24, flat; kg, kg m^2) on the BEAM's pattern and Dp (24, 14) of the structure
    `beam_blocks_only` checks: about 250 multiplications in loops of 3 and 4 that the
    compiler unrolls, against about 970 to form Dp^T Mp Dp (`beam_element_mass`)."""
    _less_points_product(Dp, a, point)
    _mass_product(Mp, point, w)
    for j in range(M):
        out[j] = 0.0
    _add_block_transposed(Dp, w, out, 0, 0, 3)
    _add_block_transposed(Dp, w, out, 1, 3, 4)
    _add_block_transposed(Dp, w, out, 2, 7, 3)
    _add_block_transposed(Dp, w, out, 3, 10, 4)
    _add_block_transposed(Dp, w, out, 4, 3, 4)
    _add_block_transposed(Dp, w, out, 5, 3, 4)
    _add_block_transposed(Dp, w, out, 6, 10, 4)
    _add_block_transposed(Dp, w, out, 7, 10, 4)


@kernel(inline="always")
def _add_blocks_transposed(Dp, w, out, w0, out0, u, su, wu):
    """`_add_block_transposed` of w into out and of w0 into out0, each Dp entry read once."""
    for c in range(3):
        p = 3 * u + c
        for j in range(wu):
            d = Dp[p, su + j]
            out[su + j] += d * w[p]
            out0[su + j] += d * w0[p]


@kernel(inline="always")
def _mass_products(Mp, point, w, point0, w0):
    """w = Mp point and w0 = Mp point0 (24,) on the BEAM's pattern, each Mp entry read once
    for both, each sum in `beam_point_product`'s order."""
    for c in range(3):
        for u in range(4):
            p = 3 * u + c
            s = s0 = 0.0
            for v in range(4):
                mass = Mp[p * P + 3 * v + c]
                s += mass * point[3 * v + c]
                s0 += mass * point0[3 * v + c]
            w[p] = s
            w0[p] = s0
        for u in range(4, 8):
            p, first = 3 * u + c, 4 + u % 2
            m1, m2 = Mp[p * P + 3 * first + c], Mp[p * P + 3 * (first + 2) + c]
            w[p] = m1 * point[3 * first + c] + m2 * point[3 * (first + 2) + c]
            w0[p] = m1 * point0[3 * first + c] + m2 * point0[3 * (first + 2) + c]


@kernel
def beam_point_products(Mp, Dp, a, point, w, out, point0, w0):
    """`beam_point_product` at the accelerations a (14,) and at a = 0 in one pass over Mp and
    Dp, for point0 (24,) = point on entry: point -= Dp a, w = Mp point, out (14,) = Dp^T w,
    and w0 = Mp point0, a (14,) = Dp^T w0 (a is read first, then overwritten). Each result
    is summed as its own `beam_point_product` call sums it, so the same bits, but for a
    zero's sign (a = 0's Dp a, which the call subtracts, is not formed). Units as there."""
    _less_points_product(Dp, a, point)
    _mass_products(Mp, point, w, point0, w0)
    for j in range(M):
        out[j] = 0.0
        a[j] = 0.0
    _add_blocks_transposed(Dp, w, out, w0, a, 0, 0, 3)
    _add_blocks_transposed(Dp, w, out, w0, a, 1, 3, 4)
    _add_blocks_transposed(Dp, w, out, w0, a, 2, 7, 3)
    _add_blocks_transposed(Dp, w, out, w0, a, 3, 10, 4)
    _add_blocks_transposed(Dp, w, out, w0, a, 4, 3, 4)
    _add_blocks_transposed(Dp, w, out, w0, a, 5, 3, 4)
    _add_blocks_transposed(Dp, w, out, w0, a, 6, 10, 4)
    _add_blocks_transposed(Dp, w, out, w0, a, 7, 10, 4)


# -- the same from a BEAM's kept points (`beam_directional.points_kernel`'s layout) -------------
# Dp's entry (3u + c, su + i) of a kept element: the translations' rows (vectors 0 and 2) are
# the unit rows, the others the kept blocks (vector 1, 3, 4, 5, 6, 7 -> block 0, 1, 2, 3, 4, 5)
@kernel(inline="always")
def _kept(points, u, c, i):
    """Dp[3u + c, su + i] of a vector u but the translations' from the kept points (u, c, i
    constants at each call)."""
    block = 0 if u == 1 else (1 if u == 3 else u - 2)
    return points[12 * block + 3 * i + c]


# On the translations' unit rows the products by Dp's zeros are left out: a sum that starts
# at +0.0 is never -0.0, so adding 0.0 * y (+-0 for a finite y) leaves it as it is, and the
# unit entry's sum is 0.0 + y. The same bits as the dense kernels' for finite a and w (a
# non-finite one makes those NaN where it meets a zero of Dp).
@kernel(inline="always")
def _kept_less_block_product(points, a, point, u, su, wu):
    """`_less_block_product` with Dp's entries from the kept points."""
    for c in range(3):
        p = 3 * u + c
        if u == 0 or u == 2:
            point[p] -= 0.0 + a[su + c]
            continue
        s = 0.0
        for j in range(wu):
            s += _kept(points, u, c, j) * a[su + j]
        point[p] -= s


@kernel(inline="always")
def _kept_add_blocks_transposed(points, w, out, w0, out0, u, su, wu):
    """`_add_blocks_transposed` with Dp's entries from the kept points (out, out0 zero on
    the translations' columns before their block)."""
    for c in range(3):
        p = 3 * u + c
        if u == 0 or u == 2:
            out[su + c] += w[p]
            out0[su + c] += w0[p]
            continue
        for j in range(wu):
            d = _kept(points, u, c, j)
            out[su + j] += d * w[p]
            out0[su + j] += d * w0[p]


@kernel
def kept_point_products(Mp, points, a, point, w, out, point0, w0):
    """`beam_point_products` with Dp read from one element's kept points (POINTS_WIDTH,;
    `beam_directional.points_kernel`'s layout) rather than from a (24, 14) array: the same
    products in the same order but those by the zeros of the translations' rows, so the
    same bits for finite a and w (above). Units as there."""
    _kept_less_block_product(points, a, point, 0, 0, 3)
    _kept_less_block_product(points, a, point, 1, 3, 4)
    _kept_less_block_product(points, a, point, 2, 7, 3)
    _kept_less_block_product(points, a, point, 3, 10, 4)
    _kept_less_block_product(points, a, point, 4, 3, 4)
    _kept_less_block_product(points, a, point, 5, 3, 4)
    _kept_less_block_product(points, a, point, 6, 10, 4)
    _kept_less_block_product(points, a, point, 7, 10, 4)
    _mass_products(Mp, point, w, point0, w0)
    for j in range(M):
        out[j] = 0.0
        a[j] = 0.0
    _kept_add_blocks_transposed(points, w, out, w0, a, 0, 0, 3)
    _kept_add_blocks_transposed(points, w, out, w0, a, 1, 3, 4)
    _kept_add_blocks_transposed(points, w, out, w0, a, 2, 7, 3)
    _kept_add_blocks_transposed(points, w, out, w0, a, 3, 10, 4)
    _kept_add_blocks_transposed(points, w, out, w0, a, 4, 3, 4)
    _kept_add_blocks_transposed(points, w, out, w0, a, 5, 3, 4)
    _kept_add_blocks_transposed(points, w, out, w0, a, 6, 10, 4)
    _kept_add_blocks_transposed(points, w, out, w0, a, 7, 10, 4)


@kernel
def kept_point_product(Mp, points, a, point, w, out):
    """`beam_point_product` with Dp read from one element's kept points (as
    `kept_point_products`): the same bits for finite a and w. Units as there."""
    _kept_less_block_product(points, a, point, 0, 0, 3)
    _kept_less_block_product(points, a, point, 1, 3, 4)
    _kept_less_block_product(points, a, point, 2, 7, 3)
    _kept_less_block_product(points, a, point, 3, 10, 4)
    _kept_less_block_product(points, a, point, 4, 3, 4)
    _kept_less_block_product(points, a, point, 5, 3, 4)
    _kept_less_block_product(points, a, point, 6, 10, 4)
    _kept_less_block_product(points, a, point, 7, 10, 4)
    _mass_product(Mp, point, w)
    for j in range(M):
        out[j] = 0.0
    _kept_add_block_transposed(points, w, out, 0, 0, 3)
    _kept_add_block_transposed(points, w, out, 1, 3, 4)
    _kept_add_block_transposed(points, w, out, 2, 7, 3)
    _kept_add_block_transposed(points, w, out, 3, 10, 4)
    _kept_add_block_transposed(points, w, out, 4, 3, 4)
    _kept_add_block_transposed(points, w, out, 5, 3, 4)
    _kept_add_block_transposed(points, w, out, 6, 10, 4)
    _kept_add_block_transposed(points, w, out, 7, 10, 4)


@kernel(inline="always")
def _kept_add_block_transposed(points, w, out, u, su, wu):
    """`_add_block_transposed` with Dp's entries from the kept points (as
    `_kept_add_blocks_transposed`)."""
    for c in range(3):
        p = 3 * u + c
        if u == 0 or u == 2:
            out[su + c] += w[p]
            continue
        for j in range(wu):
            out[su + j] += _kept(points, u, c, j) * w[p]
