"""The load stiffness of gravity on element masses, one element at a time: the term of the
tangent K_x = ... - df/dx that gravity's force f = Dp(x)^T Mp g_p adds where inertia points
hang on rotations.

With w = Mp g_p (P,; N: kg times m/s^2, gravity g_p on the position points, zero on the
tangent points) constant, df/dx = sum_p w_p D2p_p (m, m), the inertia points' second
derivatives weighted by w: numpy's `Inertia.gravity_stiffness`. It is not zero where a
consistent mass couples position points, where gravity acts, to tangent points, which
depend on the orientation (a BEAM's, a PLBEAM's). Units: N/m on translations, N on a
translation and a rotation coordinate, N m/rad (N m per unit Euler parameter squared) on
rotations.

An element's inertia entry gives D2p only as the quadratic form acc = (D2p v) v, so the
symmetric G = sum_p w_p D2p_p comes by polarisation, exactly (no step, no truncation):
G_aa = w . acc(e_a) and G_ab = (w . acc(e_a + e_b) - G_aa - G_bb) / 2, one entry call per
pair of coordinates that may couple. A group whose points are the BEAM's (group field
point_blocks: each point moves with its block of coordinates alone, its position points
linearly in x_p, x_q and its tangent points with lambda_p or lambda_q) couples only within
lambda_p's and lambda_q's blocks: 20 calls an element instead of 105.
"""

from ..numerics.jit import kernel
from ..numerics.native import call_inertia
from . import data as ed
from . import slots as slot
from .point_masses import point_forces
from .slots import float_array as _f
from .slots import group, group_inertia, inertia_scratch
from .slots import int_array as _i


@kernel
def scratch_base(table):
    """The first entry of slot local past what the tangent's callers keep there (an
    element's K_e, C_e and two rows: 2 max_m^2 + 2 max_m), the scratch of
    `subtract_gravity_stiffness` from there (2 max_m + 3 max_p + max_p max_m + max_m)."""
    max_m = _i(table, slot.DIMS)[ed.MAX_M]
    return 2 * max_m * max_m + 2 * max_m


@kernel
def has_gravity(table, g):
    """Whether element group g has inertia points with gravity on some of them."""
    gravity = group_inertia(table, g)[8]
    for p in range(gravity.size):
        if gravity[p] != 0.0:
            return True
    return False


@kernel
def subtract_gravity_stiffness(table, g, i, x, H, base):
    """H (m * m, row by row) -= sum_p w_p D2p_p of element i of group g at the coordinates x
    (NX,; m, rad): -df/dx of its gravity force (module docstring; N/m, N, N m/rad), with
    slot local from entry `base` as scratch (`scratch_base`'s size). Whether anything was
    subtracted (False for a massless element or one without gravity)."""
    inertia = group_inertia(table, g)
    n, m, P, width, function, coords, refs, masses, gravity, pattern = inertia
    if n == 0:
        return False
    xl, vl, point, acc, w, Dp, o = inertia_scratch(table, base, P, m)
    diagonal = _f(table, slot.LOCAL)[o: o + m]
    point_forces(masses[i * P * P: (i + 1) * P * P], pattern, P, gravity, w)
    loaded = False
    for pp in range(P):
        loaded = loaded or w[pp] != 0.0
    if not loaded:
        return False
    ref = refs + 8 * i * width
    for a in range(m):
        xl[a] = x[coords[i * m + a]]
        vl[a] = 0.0
    beam = group(table, g)[ed.G_POINT_BLOCKS] == 1
    for a in range(m):
        diagonal[a] = 0.0
        if beam and not _same_block(a, a):
            continue
        vl[a] = 1.0
        diagonal[a] = _weighted_curvature(function, xl, vl, ref, point, Dp, acc, w, m, P, width)
        vl[a] = 0.0
        H[a * m + a] -= diagonal[a]
    for a in range(m):
        for b in range(a + 1, m):
            if beam and not _same_block(a, b):
                continue
            vl[a] = vl[b] = 1.0
            both = _weighted_curvature(function, xl, vl, ref, point, Dp, acc, w, m, P, width)
            vl[a] = vl[b] = 0.0
            gab = 0.5 * (both - diagonal[a] - diagonal[b])
            H[a * m + b] -= gab
            H[b * m + a] -= gab
    return True


@kernel(inline="always")
def _weighted_curvature(function, xl, vl, ref, point, Dp, acc, w, m, P, width):
    """w . (D2p v) v of one element at its local coordinates xl for its local v (vl)."""
    call_inertia(function, xl.ctypes.data, vl.ctypes.data, ref, 2, point.ctypes.data,
                 Dp.ctypes.data, acc.ctypes.data, m, P, width)
    s = 0.0
    for pp in range(P):
        s += w[pp] * acc[pp]
    return s


@kernel(inline="always")
def _same_block(a, b):
    """Whether BEAM coordinates a and b lie in one of its rotation blocks
    (`elements.beam_mass`: lambda_p at 3 ... 6, lambda_q at 10 ... 13)."""
    return (3 <= a < 7 and 3 <= b < 7) or (10 <= a < 14 and 10 <= b < 14)
