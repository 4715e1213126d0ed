"""The sparse Newton matrix's terms of the rigid clusters, on the reduced free coordinates z.

With rigid clusters (`rigid`: x_s = S(z), xdot_s = T zdot, xddot_s = T zddot + c) the
Newton matrix's H = M + hg C_x + hg^2 K_x (`newton`) lives on z, and M_bar, C_bar, K_bar are
DF_z^T (.) DF_z of

    M_z  = the augmented system's mass block (T^T M T, the folded clusters' 7 x 7 blocks),
    C_z  = sum_e T_e^T C_e T_e,
    K_z  = sum_e T_e^T K_e T_e - sum_s rho_s d2 x_s / dz2,

the dense tangent's terms (`tangent`: K = DF^T K_x DF with DF's slave rows T DF_z, and
`rigid_kernels.rigid_geometric`) in coordinate space: K_e, C_e the element's blocks on its
coordinates x (`newton.element_tangent`), T_e its block of T, rho the forces the eliminated
rigid rows carried (`rigid_kernels.slave_forces`), acting through the curvature of a slave
translation in its master's rotation (C_r on the Euler parameters, -R(phi) r on a planar
angle). As in the dense tangent, the velocity terms of c(zdot) are not in C_z.

    mass_block      M_z with J_o beside and below it: `motion.inertia_forces` and
                    `factors.add_rigid_rows` into H's values (the augmented system's
                    pattern, packed sparse: the same slots)
    touching_tangent  T_e^T K_e T_e and T_e^T C_e T_e of one touching element onto H's parts
    slave_curvature   - sum_s rho_s d2 x_s / dz2 onto K_x's part

Maps: the rigid parts of h_map (`newton_packing._rigid_pairs`), from `base`. Units as
`newton`: kg, N s/m, N/m and their rotational counterparts.
"""

from ..numerics.jit import kernel
from . import data as ed
from . import rigid as rg
from . import slots as slot
from .factors import add_rigid_rows
from .motion import any_nonzero, inertia_forces
from .rigid_kernels import add_curvature, slave_forces, transform_rows
from .slots import float_array as _f
from .slots import int_array as _i

EW, SW = rg.ELEMENT_WIDTH, rg.SLAVE_WIDTH
EULER_PAIRS = 16  # `newton_packing.EULER_PAIRS`


@kernel
def mass_block(table, Mv):
    """Mv (H's values) = the augmented system [M_z J_o^T; J_o 0] at the last evaluation's
    state, as `motion.evaluate` assembles it (the forces it adds go to slot x_trial, scratch
    here; slot rigid_force is made again as that evaluation made it)."""
    dims = _i(table, slot.DIMS)
    na = dims[ed.NFREE] + dims[ed.NRIGID]
    x, xdot = _f(table, slot.X), _f(table, slot.XDOT)
    Mv[:] = 0.0
    inertia_forces(table, x, xdot, any_nonzero(xdot), _f(table, slot.X_TRIAL), Mv, na)
    add_rigid_rows(table, Mv, na)


@kernel
def own_tangent(table, t):
    """Whether touching element t has a tangent of its own: it has deformation rows (not
    inside a cluster, whose deformations vanish with their K_e and C_e)."""
    element = _i(table, slot.RIGID_ELEMENTS)[t * EW: (t + 1) * EW]
    return element[rg.E_INTERNAL] == 0 and element[rg.E_DE_OFFSET] >= 0


@kernel
def touching_tangent(table, t, m, Ke, Ce, Kv, Cv, hmap, base, work):
    """K_z = T_e^T K_e T_e onto Kv and (with damping) C_z = T_e^T C_e T_e onto Cv at the slots
    of touching element t's z-pairs (h_map from base: `newton_packing._rigid_pairs`); Ke, Ce
    (m * m, row by row) on its coordinates. work: 3 m mz entries (T_e, K_e T_e, C_e T_e)."""
    mz = _i(table, slot.RIGID_ELEMENTS)[t * EW + rg.E_MZ]
    damped = _i(table, slot.DIMS)[ed.HAS_DAMPING] == 1
    n_touching = _i(table, slot.RIGID_ELEMENTS).size // EW
    T, KT, CT = work[: m * mz], work[m * mz: 2 * m * mz], work[2 * m * mz: 3 * m * mz]
    transform_rows(table, t, m, T, mz)
    KT[:] = 0.0
    CT[:] = 0.0
    for c in range(m):  # K_e T_e, C_e T_e (m, mz)
        for d in range(m):
            k, cd = Ke[c * m + d], Ce[c * m + d]
            if k == 0.0 and cd == 0.0:
                continue
            for b in range(mz):
                tb = T[d * mz + b]
                KT[c * mz + b] += k * tb
                CT[c * mz + b] += cd * tb
    start = base + n_touching + 1 + hmap[base + t]
    for a in range(mz):
        for b in range(mz):
            s = hmap[start + a * mz + b]
            if s < 0:
                continue
            k, cd = 0.0, 0.0
            for c in range(m):
                tc = T[c * mz + a]
                if tc != 0.0:
                    k += tc * KT[c * mz + b]
                    cd += tc * CT[c * mz + b]
            Kv[s] += k
            if damped:
                Cv[s] += cd


@kernel
def slave_curvature(table, r_full, lam, Kv, hmap, base):
    """Kv -= sum_s rho_s d2 x_s / dz2 on the pairs of each slave translation's master
    rotation coordinates (`rigid_kernels.add_curvature`), rho the eliminated rigid rows'
    forces (`rigid_kernels.slave_forces`, for the full balance's r_full (NX,) and
    multipliers lam (n_free,)); h_map from base (`newton_packing._rigid_pairs`)."""
    rho = slave_forces(table, r_full, lam)
    n_slaves = _i(table, slot.RIGID_SLAVES).size // SW
    H = _f(table, slot.RIGID_LOCAL)[:EULER_PAIRS]  # one slave's terms (scratch)
    n_touching = _i(table, slot.RIGID_ELEMENTS).size // EW
    start = base + n_touching + 1 + hmap[base + n_touching]
    for j in range(n_slaves):
        places = hmap[start + j * EULER_PAIRS: start + (j + 1) * EULER_PAIRS]
        H[:] = 0.0
        add_curvature(table, j, rho, H)
        for a in range(EULER_PAIRS):
            if places[a] >= 0:
                Kv[places[a]] -= H[a]
