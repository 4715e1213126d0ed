"""The tangent of the equations of motion in the compiled engine: the integrators' Newton
matrix.

At the state of the last `motion.evaluate` and accelerations qddot: mass M_bar,
damping C0 = DeF_s^T D DeF_s (N s/m, N m s/rad) and stiffness K0 + G0 (N/m, N m/rad),

    K0 = DeF_s^T S DeF_s,   G0 = sum_e DF_e^T (sum_i sigma_i D2e_i) DF_e - DF^T (df/dx) DF,
    DeF = De DF, df/dx the load stiffness of the moment inputs (`ports`; zero without them;
    an actuator's moment at its value of that evaluation, `actuators`),

with sigma the stress resultants of the full dynamic balance: sigma_c plus the multipliers
J^-T (r - M DF qddot) on the constraint rows (the subscript s: the stressed deformations).
"""

from ..numerics.dense import copy
from ..numerics.jit import kernel
from . import data as ed
from . import slots as slot
from .actuators import evaluated_port_values
from .factors import j_solve
from .operations import OP_MASS, OP_RIGID_CONDENSE, OP_RIGID_GEOMETRIC, run
from .point_masses import element_points, massless, point_forces
from .ports import has_moment_inputs, subtract_input_stiffness
from .slots import float_array as _f
from .slots import (
    group_deformations,
    group_inertia,
    inertia_scratch,
)
from .slots import int_array as _i


@kernel(inline="always")  # into its operation's entry, its one caller
def tangent(table, qddot):
    """Stiffness K0 + G0 and damping C0 (NDOF, NDOF) into slot stiffness, slot damping at the
    state of the last `evaluate`, with the dynamic balance taken at accelerations qddot; DF,
    M_bar and its LU as `reduced_mass` does. A status."""
    status = run(table, OP_MASS, 0, 0, 0.0)  # motion.reduced_mass
    if status != ed.OK:
        return status
    dims = _i(table, slot.DIMS)
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    DF, x, conv = _f(table, slot.DF), _f(table, slot.X), _f(table, slot.CONV)
    # r_full = r - M xddot with xddot = DF qddot + conv (the reduced form's r holds - M conv
    # already), then the multipliers J^-T r_full on the free coordinates
    acc = _f(table, slot.XDDOT)
    with_conv = dims[ed.REDUCED] == 0
    for a in range(nx):
        s = conv[a] if with_conv else 0.0
        for j in range(ndof):
            s += DF[a * ndof + j] * qddot[j]
        acc[a] = s
    r_full = _f(table, slot.X_TRIAL)
    copy(r_full, _f(table, slot.FORCE))
    _mass_times(table, x, acc, r_full)
    free, lam = _i(table, slot.FREE), _f(table, slot.DX)
    rigid = dims[ed.NSLAVES] > 0
    if rigid:  # on the reduced coordinates: T^T r_full
        run(table, OP_RIGID_CONDENSE, r_full.ctypes.data, lam.ctypes.data, 0.0)
    else:
        for a in range(nf):
            lam[a] = r_full[free[a]]
    j_solve(table, lam, True)  # J^-T
    sigma = _f(table, slot.EDOT)  # reused: the full stress resultants
    copy(sigma, _f(table, slot.SIGMA))
    rows = _i(table, slot.ROWS)
    for j in range(rows.size):
        sigma[rows[j]] += lam[j]
    # DeF = De DF (NE, NDOF) and G0 = sum DF_e^T (sum_i sigma_i D2e_i) DF_e
    DeF, K, C = _f(table, slot.DEF), _f(table, slot.STIFFNESS), _f(table, slot.DAMPING)
    K[:] = 0.0
    C[:] = 0.0
    DeF[:] = 0.0
    local = _f(table, slot.LOCAL)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        H = local[: m * m]
        HD = local[m * m: m * m + m * ndof]
        for i in range(n):
            for b in range(k):
                base = (i * k + b) * m
                d = defs[i * k + b]
                for j in range(ndof):
                    s = 0.0
                    for a in range(m):
                        s += De[base + a] * DF[coords[i * m + a] * ndof + j]
                    DeF[d * ndof + j] = s
            H[:] = 0.0
            unstressed = True
            for b in range(k):
                s = sigma[defs[i * k + b]]
                if s == 0.0:
                    continue
                unstressed = False
                base2 = (i * k + b) * m * m
                for a in range(m * m):
                    H[a] += s * D2e[base2 + a]
            if unstressed:  # H = 0 adds nothing to K (an element inside a rigid cluster)
                continue
            for a in range(m):  # HD = H DF_e
                for j in range(ndof):
                    s = 0.0
                    for c in range(m):
                        s += H[a * m + c] * DF[coords[i * m + c] * ndof + j]
                    HD[a * ndof + j] = s
            for a in range(m):
                for j1 in range(ndof):
                    dfa = DF[coords[i * m + a] * ndof + j1]
                    if dfa == 0.0:
                        continue
                    for j2 in range(ndof):
                        K[j1 * ndof + j2] += dfa * HD[a * ndof + j2]
    # K0 = DeF_s^T S DeF_s, C0 = DeF_s^T D DeF_s
    stressed, S, D = _i(table, slot.STRESSED), _f(table, slot.S), _f(table, slot.D)
    pointers, columns = _i(table, slot.STRESS_POINTERS), _i(table, slot.STRESS_COLUMNS)
    damped = dims[ed.HAS_DAMPING] == 1
    SD = local[: ndof]
    DD = local[ndof: 2 * ndof]
    for a in range(stressed.size):  # S and D by compressed rows
        for j in range(ndof):
            s = 0.0
            t = 0.0
            for p in range(pointers[a], pointers[a + 1]):
                v = DeF[stressed[columns[p]] * ndof + j]
                s += S[p] * v
                if damped:
                    t += D[p] * v
            SD[j] = s
            DD[j] = t
        for i in range(ndof):
            v = DeF[stressed[a] * ndof + i]
            if v == 0.0:
                continue
            for j in range(ndof):
                K[i * ndof + j] += v * SD[j]
                if damped:
                    C[i * ndof + j] += v * DD[j]
    if rigid:  # what the eliminated rigid rows' multipliers added
        run(table, OP_RIGID_GEOMETRIC, r_full.ctypes.data, lam.ctypes.data, 0.0)
    # the moments of the last evaluation: an input's, or an actuator's (Km sat(G u), Km i)
    specs, inputs = _i(table, slot.INPUT_PORTS), evaluated_port_values(table)
    if has_moment_inputs(specs, inputs):  # - DF^T df/dx DF: a moment's force depends on x
        subtract_input_stiffness(specs, inputs, DF, ndof, K)
    return ed.OK


@kernel
def _mass_times(table, x, v, out):
    """out -= M(x) v for a coordinate vector v (NX,): lumped plus element masses."""
    dims = _i(table, slot.DIMS)
    nx = dims[ed.NX]
    lumped = _f(table, slot.LUMPED)
    for a in range(nx):
        out[a] -= lumped[a] * v[a]
    max_m, ndof = dims[ed.MAX_M], dims[ed.NDOF]
    for g in range(dims[ed.NGROUPS]):
        inertia = group_inertia(table, g)
        n, m, P, _, _, coords, _, masses, _, pattern = inertia
        # scratch past what `tangent` keeps in LOCAL: SD and DD (2 ndof), H and HD (max_m^2,
        # max_m ndof), as if they were laid end to end
        scratch = inertia_scratch(table, 2 * ndof + max_m * max_m + max_m * ndof, P, m)
        _, _, _, acc, w, Dp, _ = scratch
        for i in range(n):
            Mp = masses[i * P * P: (i + 1) * P * P]
            if massless(Mp, pattern):  # M v = 0 there
                continue
            element_points(inertia, scratch, i, x, x, 1)  # order 1: no velocities are read
            for pp in range(P):
                s = 0.0
                for a in range(m):
                    s += Dp[pp, a] * v[coords[i * m + a]]
                acc[pp] = s
            point_forces(Mp, pattern, P, acc, w)  # w = Mp acc over the entries Mp has
            for a in range(m):
                s = 0.0
                for pp in range(P):
                    s += Dp[pp, a] * w[pp]
                out[coords[i * m + a]] -= s

