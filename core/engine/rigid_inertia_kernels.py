"""The spatial clusters' folded element masses in the compiled engine, per cluster.

`rigid_inertia` sums, at packing, each spatial cluster's element masses into constant tensors
on its master z = (x_m, lambda_m); an evaluation in the augmented form then adds per cluster
its mass block M_z(lambda) (7, 7; kg, kg m, kg m^2), quadratic in lambda, and its gravity
minus its convective force (N, N m), from closed formulas (`add_rigid_bodies`: about 600
multiplications a cluster, however many elements it holds), and visits none of the folded
elements. The tangent's dynamic balance (`tangent.balance_force`) reads the coordinate force
on x with each element's share where the element sits, as the stress resultants and the
slaves' geometric stiffness need it: `add_folded_forces` puts the folded elements' forces
there, element by element, once per tangent. A residual in mass form
(`inertia_product`) needs the block only times an acceleration: `rigid_body_products` adds
the forces less M_z acc_z, without assembling.

All three are one operation, OP_RIGID_BODIES (`rigid_bodies_entry`), reached through the table of
operations (`run`) and compiled only for a model with a folded cluster (slot rigid_bodies not
empty: `engine.connect`): called directly, they were compiled into the evaluation's and the
tangent's entries of every engine with rigid clusters, a planar one's (which has no folded
cluster) included. A call by address costs a few nanoseconds per evaluation.
"""

import numpy as np

from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from . import data as ed
from . import rigid as rg
from . import rigid_inertia as ri
from . import slots as slot
from .factors import add_element_mass
from .operations import ENTRY
from .point_masses import element_points, point_forces
from .rigid_kernels import touching
from .slots import float_array as _f
from .slots import group_inertia, inertia_scratch, rigid_element
from .slots import int_array as _i

EW, BW, TW = rg.ELEMENT_WIDTH, ri.BODY_WIDTH, ri.TENSOR_WIDTH
# OP_RIGID_BODIES' parts (s; floats: the operations' number argument is a float64): the
# rigid bodies onto the augmented matrix and slot rigid_force (`add_rigid_bodies`), or the
# folded elements' forces onto an (NX,) array (`add_folded_forces`), or the rigid bodies'
# forces less their mass times given accelerations onto an (NX,) (`rigid_body_products`),
# each at rest or moving
(BODIES_AT_REST, BODIES_MOVING, FOLDED_AT_REST, FOLDED_MOVING, PRODUCT_AT_REST,
 PRODUCT_MOVING) = (float(p) for p in range(6))


@kernel
def own_mass(table, t):
    """Whether touching element t's mass is evaluated on its own: it has mass, and that mass
    is not folded into its cluster's rigid body (`rigid_inertia`)."""
    element = _i(table, slot.RIGID_ELEMENTS)[t * EW: (t + 1) * EW]
    return element[rg.E_MASS_OFFSET] >= 0 and element[rg.E_FOLDED] == 0


@kernel(inline="always")
def visits_element(table, row, i, rigid):
    """Whether the element passes (`inertia_product`) evaluate element i of the group `row`
    on its own: every element but, in a model with clusters (`rigid`), a touching one whose
    mass is zero or folded into its cluster's rigid body (`own_mass`). The BEAMs' rates keep
    points for exactly these (`formed_rates`)."""
    if not rigid:
        return True
    t = rigid_element(table, row, i)
    return t < 0 or own_mass(table, t)


@kernel
def body_mass_and_force(table, c, x, xdot, moving, force):
    """Folded cluster c's mass block M_z(lambda_m) (7, 7; kg, kg m, kg m^2; on the master's
    translation then rotation coordinates, a view into slot rigid_local) and its gravity
    force minus, if moving, its convective force (N, N m) added onto `force` (NX,) at the
    master's coordinates, for the coordinates x (NX,; m, Euler parameters) and velocities
    xdot (NX,; read if moving); returns (M_z, the cluster's row of slot rigid_bodies)."""
    bodies, tensors = _i(table, slot.RIGID_BODIES), _f(table, slot.RIGID_BODY_TENSORS)
    local = _f(table, slot.RIGID_LOCAL)
    # scratch (ri.BODY_SCRATCH): L (4, 4, 4), M_z (7, 7), the carrier's Me (mz <= 7 squared),
    # lambda, its rate
    L, Mz = local[:64], local[64:113]
    lam, rate = local[162:166], local[166:ri.BODY_SCRATCH]
    row, d = bodies[c * BW: (c + 1) * BW], tensors[c * TW: (c + 1) * TW]
    for b in range(4):
        lam[b] = x[row[ri.B_ROTATION + b]]
        rate[b] = xdot[row[ri.B_ROTATION + b]] if moving else 0.0
    for q in range(64):  # L_c = sum_b lambda_b K_bc
        s = 0.0
        for b in range(4):
            s += lam[b] * d[ri.T_SECOND + b * 64 + q]
        L[q] = s
    for k in range(3):
        for j in range(3):
            Mz[k * 7 + j] = d[ri.T_MASS + k * 3 + j]
        for a in range(4):  # sum_b lambda_b F_b
            s = 0.0
            for b in range(4):
                s += lam[b] * d[ri.T_FIRST + b * 12 + k * 4 + a]
            Mz[k * 7 + 3 + a] = s
            Mz[(3 + a) * 7 + k] = s
    for a in range(4):  # sum_c lambda_c L_c, symmetric
        for e in range(a, 4):
            s = 0.0
            for cc in range(4):
                s += lam[cc] * L[cc * 16 + a * 4 + e]
            Mz[(3 + a) * 7 + 3 + e] = s
            Mz[(3 + e) * 7 + 3 + a] = s
    for k in range(3):  # gravity less sum_c lambdadot_c F_c lambdadot
        f = d[ri.T_GRAVITY + k]
        if moving:
            for cc in range(4):
                for a in range(4):
                    f -= rate[cc] * d[ri.T_FIRST + cc * 12 + k * 4 + a] * rate[a]
        force[row[ri.B_TRANSLATION + k]] += f
    for a in range(4):  # sum_b lambda_b g_b less sum_c lambdadot_c L_c lambdadot
        f = 0.0
        for b in range(4):
            f += lam[b] * d[ri.T_GRAVITY_TURN + b * 4 + a]
        if moving:
            for cc in range(4):
                for e in range(4):
                    f -= rate[cc] * L[cc * 16 + a * 4 + e] * rate[e]
        force[row[ri.B_ROTATION + a]] += f
    return Mz, row


@kernel
def add_rigid_bodies(table, x, xdot, moving, A, na):
    """Every folded cluster's mass block M_z(lambda_m) onto A (the carrier's entries: `
    factors.add_element_mass`, row length na), and its gravity force minus, if moving, its
    convective force onto slot rigid_force at the master's coordinates, for the masters'
    coordinates x (NX,; m, Euler parameters) and velocities xdot (NX,; read if moving)."""
    bodies = _i(table, slot.RIGID_BODIES)
    force, local = _f(table, slot.RIGID_FORCE), _f(table, slot.RIGID_LOCAL)
    Me = local[113:162]  # the carrier's Me (`body_mass_and_force`'s scratch)
    position = _i(table, slot.POINT_COLUMNS)[:7]
    dims = _i(table, slot.DIMS)
    mass_base = dims[ed.A_RIGID] + 2 * _f(table, slot.RIGID_DE).size
    for c in range(bodies.size // BW):
        Mz, row = body_mass_and_force(table, c, x, xdot, moving, force)
        _, _, mz, z, _, mass_offset = touching(table, row[ri.B_CARRIER])
        for e in range(mz * mz):
            Me[e] = 0.0
        for j in range(7):  # M_z in the carrier's order of z
            pj = row[ri.B_PLACES + j]
            if pj < 0:
                continue
            for k in range(7):
                pk = row[ri.B_PLACES + k]
                if pk >= 0:
                    Me[pj * mz + pk] = Mz[j * 7 + k]
        add_element_mass(table, A, na, mass_base + mass_offset, z, mz, Me[: mz * mz],
                         position)


@kernel
def rigid_body_products(table, x, xdot, moving, acc, out):
    """out (NX,; N, N m) += every folded cluster's gravity force minus, if moving, its
    convective force, minus M_z(lambda_m) acc_z, at the master's coordinates: the product
    with the accelerations acc (NX,; m/s^2, 1/s^2 on the Euler parameters) of the block that
    `add_rigid_bodies` assembles, over the master's coordinates that block lands on (those in
    its carrier's z, B_PLACES >= 0), for x and xdot as there."""
    bodies = _i(table, slot.RIGID_BODIES)
    for c in range(bodies.size // BW):
        Mz, row = body_mass_and_force(table, c, x, xdot, moving, out)
        for j in range(7):
            if row[ri.B_PLACES + j] < 0:
                continue
            s = 0.0
            for k in range(7):
                if row[ri.B_PLACES + k] >= 0:
                    s += Mz[j * 7 + k] * acc[row[k]]  # row[:7]: translation, rotation
            out[row[j]] -= s


@kernel
def add_folded_forces(table, x, xdot, moving, out):
    """out (NX,; N) += Dp^T Mp (g_p - (D2p v) v) of every folded element, on its own
    coordinates x (NX,) and, if moving, velocities xdot (NX,; the slaves' filled): the share
    that `motion.inertia_forces` leaves to `add_rigid_bodies`."""
    dims = _i(table, slot.DIMS)
    elements = _i(table, slot.RIGID_ELEMENTS)
    # scratch past what `tangent` keeps in slot local (as `tangent._mass_times`)
    max_m, ndof = dims[ed.MAX_M], dims[ed.NDOF]
    base = 2 * ndof + max_m * max_m + max_m * ndof
    for t in range(elements.size // EW):
        if elements[t * EW + rg.E_FOLDED] != 1:
            continue
        g, i = elements[t * EW + rg.E_GROUP], elements[t * EW + rg.E_ELEMENT]
        inertia = group_inertia(table, g)
        _, m, P, _, _, coords, _, masses, gravity, pattern = inertia
        scratch = inertia_scratch(table, base, P, m)
        _, _, point, acc, w, Dp, _ = scratch
        element_points(inertia, scratch, i, x, xdot, 2 if moving else 1)
        for pp in range(P):
            point[pp] = gravity[pp] - acc[pp] if moving else gravity[pp]
        point_forces(masses[i * P * P: (i + 1) * P * P], pattern, P, point, w)
        for a in range(m):
            s = 0.0
            for pp in range(P):
                s += Dp[pp, a] * w[pp]
            out[coords[i * m + a]] += s


@entry(ENTRY)
def rigid_bodies_entry(op, user_data, t, a, b, c, s):
    """OP_RIGID_BODIES on slots x and xdot: s = BODIES_...: `add_rigid_bodies` onto the
    augmented matrix's values at a (t of them: its dense (na, na) or its sparse values);
    s = FOLDED_...: `add_folded_forces` onto a (NX,); s = PRODUCT_...:
    `rigid_body_products` with the accelerations a (NX,) onto b (NX,)."""
    table = address_of(user_data)
    dims = _i(table, slot.DIMS)
    x, xdot = _f(table, slot.X), _f(table, slot.XDOT)
    if s == BODIES_AT_REST or s == BODIES_MOVING:
        add_rigid_bodies(table, x, xdot, s == BODIES_MOVING, carray(a, (int(t),), np.float64),
                         dims[ed.NFREE] + dims[ed.NRIGID])
    elif s == FOLDED_AT_REST or s == FOLDED_MOVING:
        add_folded_forces(table, x, xdot, s == FOLDED_MOVING,
                          carray(a, (dims[ed.NX],), np.float64))
    else:
        nx = dims[ed.NX]
        rigid_body_products(table, x, xdot, s == PRODUCT_MOVING, carray(a, (nx,), np.float64),
                            carray(b, (nx,), np.float64))
    return ed.OK
