"""The elements' deformation rates in the compiled engine, for the equations of motion
(`motion`): for coordinate velocities xdot (m/s, 1/s) and accelerations xddot, with each
element's De and D2e of the last kinematic solution (slots de, d2e):

    element_rates                   edot = De xdot (1/s, m/s by the deformation) and the
                                    constraint rows' h_i = xdot^T D2e_i xdot (from the
                                    element's own kernel where it forms h: its D2e is not
                                    evaluated at the solution, `kinematics.AT_SOLUTION`)
    stress_resultants               sigma_c = S e_s + D edot_s (N, N m by the deformation)
    scatter_stress                  r -= De^T sigma (N, N m)
    dof_deformation_accelerations   the DOF deformations' De_m xddot + h_m

element by element over the packed groups (`slots.group_deformations`).
"""

from ..numerics.jit import kernel
from ..numerics.sparse_lu import unsigned_index as _u
from . import data as ed
from . import rigid as rg
from . import slots as slot
from .kinematics import forms_quadratic_forms
from .operations import OP_FORMED_RATES, RATES, run
from .slots import float_array as _f
from .slots import group, group_deformations, rigid_element
from .slots import int_array as _i


@kernel
def dof_deformation_accelerations(table, xddot, quad, moving, qddot):
    """qddot of the DOF deformations: De_m xddot + h_m (the constraint rows of those DOFs)."""
    dims = _i(table, slot.DIMS)
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    row_of_def = _i(table, slot.ROW_OF_DEF)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        for i in range(n):
            for b in range(k):
                rr = row_of_def[defs[i * k + b]]
                if rr < n_rigid or rr >= n_rigid + n_edof:
                    continue
                s = quad[rr] if moving else 0.0
                base = (i * k + b) * m
                for a in range(m):
                    s += De[base + a] * xddot[coords[i * m + a]]
                qddot[n_xdof + rr - n_rigid] = s


@kernel
def element_rates(table, xdot, moving):
    """edot = De xdot (slot edot) and, if moving, xdot^T D2e_i xdot of the constraint rows
    into slot g (n_free,: zero on the unit rows of the DOF coordinates): contracting D2e, or
    from the element's directional kernel where it has one (OP_FORMED_RATES,
    `formed_rates`). The elements a rigid cluster makes identically zero (`rigid`) get
    edot = 0 without a product: their De is not evaluated (`kinematics.deformations`), their
    rows are out of the system and their deformations carry no stress, so nothing reads
    their rates."""
    dims = _i(table, slot.DIMS)
    edot, quad = _f(table, slot.EDOT), _f(table, slot.G)
    row_of_def = _i(table, slot.ROW_OF_DEF)
    v = _f(table, slot.LOCAL)  # the element's xdot, gathered once for its k rows
    skipping = dims[ed.NSLAVES] > 0
    touching = _i(table, slot.RIGID_ELEMENTS)
    quad[:] = 0.0
    kept = moving  # whether every group with kept points (a BEAM's) has them of this state
    for g in range(dims[ed.NGROUPS]):
        row = group(table, g)
        if moving and row[ed.G_K] > 0 and forms_quadratic_forms(
                row[ed.G_DEFORMATIONS_ENTRY], v, row[ed.G_M], row[ed.G_K], row[ed.G_REF_WIDTH]):
            # through its operation (`formed_rates`), compiled only for models with such an
            # element; `engine.connect` gives it to every model that has one; it keeps a
            # BEAM group's inertia points (slot beam_points)
            run(table, OP_FORMED_RATES, g, xdot.ctypes.data, RATES)
            continue
        if row[ed.G_POINTS_OFFSET] >= 0:
            kept = False
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        for i in range(n):
            if skipping and internal(table, row, i, touching):
                for b in range(k):
                    edot[defs[i * k + b]] = 0.0
                continue
            for a in range(m):
                v[a] = xdot[coords[i * m + a]]
            for b in range(k):
                s = 0.0
                base = (i * k + b) * m
                for a in range(m):
                    s += De[base + a] * v[a]
                edot[defs[i * k + b]] = s
                r = row_of_def[defs[i * k + b]]
                if moving and r >= 0:
                    h = 0.0
                    base2 = (i * k + b) * m * m
                    for a in range(m):
                        va = v[a]
                        if va == 0.0:
                            continue
                        t = 0.0
                        for c in range(m):
                            t += D2e[base2 + a * m + c] * v[c]
                        h += va * t
                    quad[r] = h
    dims[ed.POINTS_CURRENT] = 1 if kept else 0


@kernel(inline="always")
def internal(table, row, i, touching):
    """Whether element i of the group `row` is internal to a rigid cluster (`rigid`)."""
    t = rigid_element(table, row, i)
    return t >= 0 and touching[t * rg.ELEMENT_WIDTH + rg.E_INTERNAL] == 1


@kernel
def stress_resultants(table):
    """slot sigma = S e + D edot on the stressed deformations (S, D by compressed rows; D
    only where the model has damping), zero on the others; returns sigma."""
    dims = _i(table, slot.DIMS)
    sigma, e, edot = _f(table, slot.SIGMA), _f(table, slot.E), _f(table, slot.EDOT)
    stressed, S, D = _i(table, slot.STRESSED), _f(table, slot.S), _f(table, slot.D)
    pointers, columns = _i(table, slot.STRESS_POINTERS), _i(table, slot.STRESS_COLUMNS)
    sigma[:] = 0.0
    damped = dims[ed.HAS_DAMPING] == 1
    for a in range(stressed.size):  # unsigned indices: no test for one from the end
        s = 0.0
        for p in range(pointers[a], pointers[a + 1]):
            b = _u(stressed[_u(columns[p])])
            s += S[p] * e[b]
            if damped:
                s += D[p] * edot[b]
        sigma[_u(stressed[a])] = s
    return sigma


@kernel
def scatter_stress(table, sigma, r):
    """r -= De^T sigma, element by element."""
    dims = _i(table, slot.DIMS)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        for i in range(n):
            for b in range(k):
                s = sigma[defs[i * k + b]]
                if s == 0.0:
                    continue
                base = (i * k + b) * m
                for a in range(m):  # unsigned: no test for an index from the end
                    r[_u(coords[i * m + a])] -= De[_u(base + a)] * s
