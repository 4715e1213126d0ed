"""The force less the inertia of given accelerations, rhs_f - M_ff w_f, without assembling M.

`motion.evaluate` solves the augmented system [M_ff J_o^T; J_o 0] whose first rows carry
rhs_f, the coordinate force r = f - De^T sigma_c with the element masses' point forces
(gravity, -g_conv) on the free coordinates (with rigid clusters: on z, T^T (r - M c)), and
the mass block M_ff (`motion.inertia_forces`: lumped masses, element masses Dp^T Mp Dp, the
touching elements' Dp_z^T Mp Dp_z, the folded clusters' rigid bodies). A residual in mass
form needs only rhs_f - M_ff w_f for an acceleration w_f (m/s^2, 1/s^2 on the Euler
parameters). Since M_ff = T^T M T on z and the slaves' accelerations are T w + c,

    rhs_f - M_ff w_f = T^T (r + sum_p Dp^T Mp (g_p - (D2p v) v - Dp a) - diag(lumped) a)
                       + the folded clusters' forces - M_z a_z,     a = [w_f; T w_f + c]

on x: every element's points once (Dp, (D2p v) v), one product Dp a_e, Mp and Dp^T per
element (a BEAM in closed form, `beam_mass.beam_point_product`: about 250 multiplications
against about 7000 to form a touching BEAM's T_e^T Dp^T Mp Dp T_e and its assembly), and T^T
once for the whole model (`rigid_kernels.condense`). The same sums as the assembled path in
another order: equal to round-off (tests/test_inertia_product.py). The rigid clusters' maps
and the folded clusters' rigid bodies are reached through their operations, so a model
without them compiles none of theirs here. Units as the coordinates: N, N m; kg, kg m, kg m^2.
"""

import numpy as np

from ..elements.beam_directional import ACC_AT, POINTS_WIDTH
from ..elements.beam_mass import (
    beam_point_product,
    beam_point_products,
    kept_point_product,
    kept_point_products,
)
from ..numerics.dense import copy
from ..numerics.jit import kernel
from ..numerics.native import call_engine
from . import data as ed
from . import slots as slot
from .node_inertia_product import node_point_products
from .operations import OP_RIGID_BODIES, OP_RIGID_CONDENSE, OP_RIGID_EXPAND, run
from .point_masses import element_points, point_forces
from .rigid_inertia_kernels import PRODUCT_AT_REST, PRODUCT_MOVING, visits_element
from .slots import float_array as _f
from .slots import group, group_inertia, inertia_scratch
from .slots import int_array as _i


@kernel
def force_minus_mass(table, x, xdot, moving, r, w_f, a, total, out_f):
    """out_f (n_free,; N, N m) = rhs_f - M_ff w_f, the augmented system's first n_free rows
    of `motion.evaluate` less its mass block times w_f, without forming that block; a status
    (ed.NONFINITE_RESULT when out_f is not finite, else ed.OK).

    x, xdot (NX,; m, Euler parameters, and their rates): the coordinates and velocities with
    the slaves' filled and, with rigid clusters, their c in slot rigid_c (as `evaluate`
    leaves them before its inertia); moving: whether xdot is not zero (at rest neither
    (D2p v) v nor c is formed); r (NX,; N, N m): f - De^T sigma_c, the force before the
    inertia (read only); w_f (n_free,): the accelerations of the free coordinates in their
    order (slot free). a and total (NX,) are scratch: on return a holds the accelerations
    on x (w_f, the slaves' T w_f + c, zero on the fixed coordinates) and total the force on
    x before T^T. With folded clusters x and xdot must be slots x and xdot (their operation
    reads those); T's weights are those of the last kinematic solution. Works in slot
    local's inertia scratch (as `inertia_forces`) and, with folded clusters, slot
    rigid_local."""
    dims = _i(table, slot.DIMS)
    nf = dims[ed.NFREE]
    free = _i(table, slot.FREE)
    rigid = dims[ed.NSLAVES] > 0
    copy(total, r)
    spread_accelerations(table, w_f, moving, a, total)  # the slaves' T w + c
    element_products(table, x, xdot, moving, True, a, total)
    if rigid and _i(table, slot.RIGID_BODIES).size:  # through their operation, which only
        # a model with a folded cluster compiles (`rigid_inertia_kernels`)
        call_engine(dims[ed.ENGINE], OP_RIGID_BODIES, table, 0.0, a.ctypes.data,
                    total.ctypes.data, 0, PRODUCT_MOVING if moving else PRODUCT_AT_REST)
    if rigid:  # T^T total on z
        run(table, OP_RIGID_CONDENSE, total.ctypes.data, out_f.ctypes.data, 0.0)
    else:
        for k in range(nf):
            out_f[k] = total[free[k]]
    for k in range(nf):
        if not np.isfinite(out_f[k]):
            return ed.NONFINITE_RESULT
    return ed.OK


@kernel
def minus_mass_product(table, w_f, a, total, out_f):
    """out_f (n_free,; N, N m) = -M_ff w_f, the augmented system's mass block (kg, kg m,
    kg m^2 on z with rigid clusters: T^T M T) times the accelerations w_f (n_free,; m/s^2,
    1/s^2 on the Euler parameters), negated, at the coordinates in slot x and T's weights of
    the last kinematic solution, without forming the block: `force_minus_mass` without r,
    gravity and the convective terms. a and total (NX,) are scratch as there. The folded
    clusters' operation adds gravity with its product; it is called at w_f / 2 and at
    -w_f / 2 and the two differenced (halving and negating are exact), so their gravity
    cancels to its round-off."""
    dims = _i(table, slot.DIMS)
    nf = dims[ed.NFREE]
    free = _i(table, slot.FREE)
    rigid = dims[ed.NSLAVES] > 0
    total[:] = 0.0
    spread_accelerations(table, w_f, False, a, total)  # the slaves' T w, without c
    x, xdot = _f(table, slot.X), _f(table, slot.XDOT)
    element_products(table, x, xdot, False, False, a, total)
    if rigid and _i(table, slot.RIGID_BODIES).size:  # -(-(total + G - M a/2) + G + M a/2)
        for c in range(a.size):
            a[c] *= 0.5
        _folded_product(table, a, total)
        for c in range(a.size):
            a[c] = -a[c]
            total[c] = -total[c]
        _folded_product(table, a, total)
        for c in range(a.size):
            total[c] = -total[c]
    if rigid:  # T^T total on z
        run(table, OP_RIGID_CONDENSE, total.ctypes.data, out_f.ctypes.data, 0.0)
    else:
        for k in range(nf):
            out_f[k] = total[free[k]]


@kernel(inline="always")  # into the two products above
def spread_accelerations(table, w_f, convective, a, total):
    """a (NX,; m/s^2, 1/s^2) = the free coordinates' accelerations w_f (n_free,) on x: w_f
    on the free coordinates, the slaves' T w_f (plus their c in slot rigid_c where
    `convective`), zero on the fixed ones; then total (NX,; N, N m) -= the lumped masses
    times a where the augmented system has them, on the free coordinates."""
    dims = _i(table, slot.DIMS)
    free, lumped = _i(table, slot.FREE), _f(table, slot.LUMPED)
    a[:] = 0.0
    # the lumped masses on the free coordinates alone (those with a column of A), in the
    # same pass: the slaves' T w below writes neither a's free entries nor total
    for k in range(dims[ed.NFREE]):
        c = free[k]
        a[c] = w_f[k]
        total[c] -= lumped[c] * a[c]
    if dims[ed.NSLAVES] > 0:
        run(table, OP_RIGID_EXPAND, a.ctypes.data, 0, 1.0 if convective else 0.0)


@kernel
def _folded_product(table, a, total):
    """total (NX,) += the folded clusters' gravity less their rigid bodies' mass times a, at
    rest, through their operation (`rigid_inertia_kernels`, on slot x)."""
    call_engine(_i(table, slot.DIMS)[ed.ENGINE], OP_RIGID_BODIES, table, 0.0, a.ctypes.data,
                total.ctypes.data, 0, PRODUCT_AT_REST)


@kernel
def element_products(table, x, xdot, moving, with_gravity, a, total):
    """total (NX,; N, N m) += Dp^T Mp (g_p - (D2p v) v - Dp a_e) of every element that
    `motion.inertia_forces` visits (all with inertia points but the touching elements whose
    mass is folded or zero), for the accelerations a (NX,) on x; (D2p v) v only if moving,
    g_p only with_gravity.
    A BEAM in closed form (`beam_mass.beam_point_product`) where its group's points are the
    BEAM's (group field point_blocks: the BEAM's mass pattern and every Dp of the BEAM's
    blocks, decided once at packing rather than by `beam_blocks_only` element by element,
    which cost about 4 us a call on manipulator_control's 57 BEAMs), a node inertia in
    closed form (group field node_inertia: `node_inertia_product`), any other element
    through Dp's full rows."""
    _element_pass(table, x, xdot, moving, with_gravity, a, total, total[:0])


@kernel
def forces_and_products(table, x, xdot, moving, a, forces, total):
    """forces (NX,; N, N m) += Dp^T Mp (g_p - (D2p v) v) and total += Dp^T Mp (g_p - (D2p v) v
    - Dp a_e), (D2p v) v only if moving: `element_products` with gravity at a = 0 into forces
    and at a into total in one element pass, each element's points (Dp, (D2p v) v) evaluated
    once for both, a BEAM's two closed-form products in one pass over its Mp and Dp
    (`beam_mass.beam_point_products`). Each gets the same products in the same order as
    from its own `element_products` call (with gravity; at a = 0 and at a): the same bits
    (a zero's sign aside)."""
    _element_pass(table, x, xdot, moving, True, a, total, forces)


@kernel
def _element_pass(table, x, xdot, moving, with_gravity, a, total, forces):
    """`element_products` into total, and where forces is not empty (NX,) also the same
    products at a = 0 into forces (`forces_and_products`)."""
    dims = _i(table, slot.DIMS)
    rigid = dims[ed.NSLAVES] > 0
    split = forces.size > 0
    # the BEAMs' points as their rates kept them (`formed_rates`), where those are of x
    # and xdot: slots x and xdot of this evaluation
    current = (dims[ed.POINTS_CURRENT] == 1 and x.ctypes.data == _f(table, slot.X).ctypes.data
               and xdot.ctypes.data == _f(table, slot.XDOT).ctypes.data)
    for g in range(dims[ed.NGROUPS]):
        row = group(table, g)
        inertia = group_inertia(table, g)
        n, m, P, _, _, coords, _, masses, gravity, pattern = inertia
        beams = row[ed.G_POINT_BLOCKS] == 1
        scratch = inertia_scratch(table, 0, P, m)
        xl, vl, point, acc, w, Dp, o = scratch
        kept = current and n > 0 and row[ed.G_POINTS_OFFSET] >= 0  # a BEAM group
        points = _f(table, slot.BEAM_POINTS)[max(row[ed.G_POINTS_OFFSET], 0):]
        w0 = _f(table, slot.LOCAL)[o: o + P]  # a BEAM's Mp times its points at a = 0
        nodes = row[ed.G_NODE_INERTIA] == 1
        refs = _f(table, slot.GROUP_DATA)[row[ed.G_DATA_OFFSET]:]
        width = row[ed.G_REF_WIDTH]
        for i in range(n):
            if not visits_element(table, row, i, rigid):
                continue
            if nodes:  # a node inertia's points and both products in closed form
                for b in range(m):
                    xl[b] = x[coords[i * m + b]]
                    vl[b] = xdot[coords[i * m + b]] if moving else 0.0
                    point[b] = a[coords[i * m + b]]
                node_point_products(refs[i * width: i * width + 9], xl, vl, moving,
                                    with_gravity, gravity, masses[i * P * P: (i + 1) * P * P],
                                    point, w, acc, split)
                for b in range(m):
                    total[coords[i * m + b]] += w[b]
                    if split:
                        forces[coords[i * m + b]] += acc[b]
                continue
            if kept:  # the BEAM's products with Dp and (D2p v) v read from its kept points
                _kept_products(points[i * POINTS_WIDTH: (i + 1) * POINTS_WIDTH], moving,
                               with_gravity, gravity, masses[i * P * P: (i + 1) * P * P],
                               coords[i * m: (i + 1) * m], a, scratch, w0, total, forces)
                continue
            element_points(inertia, scratch, i, x, xdot, 2 if moving else 1)
            for pp in range(P):
                g_p = gravity[pp] if with_gravity else 0.0
                point[pp] = g_p - acc[pp] if moving else g_p
                acc[pp] = point[pp]  # kept for the product at a = 0 (acc is read: done)
            Mp = masses[i * P * P: (i + 1) * P * P]
            # a_e into the scratch's x, Dp^T w into its v: the points read them, and are done
            for b in range(m):
                xl[b] = a[coords[i * m + b]]
            if split and beams:  # both products in one pass over Mp and Dp, the one at
                # a = 0 from the points' values kept in acc, into xl
                beam_point_products(Mp, Dp, xl, point, w, vl, acc, w0)
                for b in range(m):
                    total[coords[i * m + b]] += vl[b]
                    forces[coords[i * m + b]] += xl[b]
                continue
            _product(beams, Mp, pattern, P, m, Dp, xl, point, w, vl)
            for b in range(m):
                total[coords[i * m + b]] += vl[b]
            if split:  # the same at a = 0, from the points' values kept in acc
                for b in range(m):
                    xl[b] = 0.0
                _product(beams, Mp, pattern, P, m, Dp, xl, acc, w, vl)
                for b in range(m):
                    forces[coords[i * m + b]] += vl[b]


@kernel(inline="always")  # into the element pass
def _kept_products(points, moving, with_gravity, gravity, Mp, coords, a, scratch, w0, total,
                   forces):
    """One BEAM's part of `_element_pass` from its kept points (`formed_rates`): the same
    point values and products (`beam_mass.kept_point_products`, `kept_point_product`), so
    the same bits as from its inertia kernel's Dp and acc. coords (14,) its coordinates."""
    xl, vl, point, acc, w, _, _ = scratch
    for pp in range(24):
        g_p = gravity[pp] if with_gravity else 0.0
        point[pp] = g_p - points[ACC_AT + pp] if moving else g_p
        acc[pp] = point[pp]
    for b in range(14):
        xl[b] = a[coords[b]]
    if forces.size > 0:
        kept_point_products(Mp, points, xl, point, w, vl, acc, w0)
        for b in range(14):
            total[coords[b]] += vl[b]
            forces[coords[b]] += xl[b]
    else:
        kept_point_product(Mp, points, xl, point, w, vl)
        for b in range(14):
            total[coords[b]] += vl[b]


@kernel(inline="always")
def _product(beams, Mp, pattern, P, m, Dp, a_e, point, w, out_e):
    """point -= Dp a_e, w = Mp point, out_e = Dp^T w: a BEAM's closed form or any element's."""
    if beams:
        beam_point_product(Mp, Dp, a_e, point, w, out_e)
    else:
        element_product(Mp, pattern, P, m, Dp, a_e, point, w, out_e)


@kernel
def element_product(Mp, pattern, P, m, Dp, a_e, point, w, out_e):
    """point (P,) -= Dp a_e, w = Mp point over `pattern` (flat p P + q), out_e (m,) = Dp^T w,
    for any element (Dp (P, m), a_e (m,)): column by column and row by row, so that the sums
    are P and m independent ones rather than chains of m and P."""
    for b in range(m):
        ab = a_e[b]
        if ab != 0.0:
            for pp in range(P):
                point[pp] -= Dp[pp, b] * ab
    point_forces(Mp, pattern, P, point, w)
    for b in range(m):
        out_e[b] = 0.0
    for pp in range(P):
        wp = w[pp]
        if wp != 0.0:
            for b in range(m):
                out_e[b] += Dp[pp, b] * wp
