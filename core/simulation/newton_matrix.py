"""The Newton matrix of the implicit integrators: I - hg J, factored and solved.

J is the model's first-order Jacobian (n, n; row-major, flat) and hg the step size times the
method's diagonal coefficient (s). For a second-order system, J = [[0, I], [A, B]] (A = d qddot
/ d q, B = d qddot / d qdot), from SCHUR_FROM DOFs on the matrix is solved through its Schur
complement: (I - hg J) [dq; dv] = [r1; r2] is dq = r1 + hg dv with

    (I - hg B - hg^2 A) dv = r2 + hg A r1,

an LU of NDOF^3 / 3 multiplications instead of 8 NDOF^3 / 3. Below it the full matrix keeps
the small models' numbers as they were (its LU costs under a millisecond there). A state with
coil currents ([q - q_ref, qdot, i], `engine.actuators`) is not of that form (with one coil n
is odd, with more the identity block is not at n / 2): it takes the full matrix, as does a
restored J of any other form (the form is checked, not assumed).

Sparse (SPARSE). M_bar, K_bar, C_bar and hence J are dense in DOF space when every nodal
coordinate depends on the DOFs (a spatial cantilever whose DOFs are all its deformations):
forming J costs O(NDOF^3) (M_bar^-1 [K C]) and the Schur complement's LU NDOF^3 / 3. A model
that the engine packs with dims[NEWTON_SPARSE] = 1 (`engine.newton_packing`: the augmented
form, at least SPARSE_NEWTON_FROM = 50 DOFs, no coil currents or kinematic inputs,
element-local S and D, every element with mass; rigid clusters with their augmented system
factored sparse, on the reduced coordinates z: `engine.newton_rigid`) takes instead the same Schur
equation in coordinate space,

    (M_bar + hg C_bar + hg^2 K_bar) dv = M_bar r2 - hg K_bar r1,   dq = r1 + hg dv,

solved as the sparse saddle-point system [H J_o^T; J_o 0] [dx; lambda] = [M a - hg K_x b; 0]
with H = M + hg C_x + hg^2 K_x on the free coordinates, a = J^-1 [0; r2], b = J^-1 [0; r1]
and dv = (J's DOF rows) dx (`engine.newton`, docs/analyses.md). Its "Jacobian" is M, C_x,
K_x and J's LU at the Jacobian's state, kept in the packed model (the J array of the
integrator is not used); `sparse_factor` and `sparse_solve` reach them through the engine's
operations. The rule of when to renew J is the ESDIRK's, unchanged; the factors are made
again at every new hg (a sparse factorisation costs a fifth of an evaluation, so the slack the
dense path keeps, an iteration more per stage, does not pay: `esdirk_newton.SPARSE_LU_SLACK`);
the solve is the dense path's (I - hg J)^-1 to round-off, so the step's error control is the
dense path's. Costs grow with the element count.
"""

from ..engine import access, engine
from ..engine import data as ed
from ..engine.operations import OP_NEWTON_FACTOR, OP_NEWTON_FORCE_SOLVE, OP_NEWTON_SOLVE
from ..numerics.jit import kernel
from ..numerics.native import call_engine

SCHUR_FROM = 50  # DOFs from which the Newton matrix is solved by its Schur complement
SINGULAR, FULL, SCHUR, SPARSE = 0, 1, 2, 3  # what `factor` (or `sparse_factor`) made


@kernel
def factor(J, LU, piv, hg):
    """LU (n * n,) = the factors of I - hg J (FULL), or of its Schur complement (SCHUR: in the
    first NDOF^2 entries); SINGULAR when a pivot vanishes."""
    n = piv.size
    if second_order(J, n):
        m = n // 2
        for i in range(m):  # S = I - hg B - hg^2 A
            for j in range(m):
                a, b = J[(m + i) * n + j], J[(m + i) * n + m + j]
                LU[i * m + j] = -hg * b - hg * hg * a
            LU[i * m + i] += 1.0
        return SCHUR if engine.lu_factor(LU, m, piv) > 1e-300 else SINGULAR
    for i in range(n * n):
        LU[i] = -hg * J[i]
    for i in range(n):
        LU[i * n + i] += 1.0
    return FULL if engine.lu_factor(LU, n, piv) > 1e-300 else SINGULAR


@kernel
def second_order(J, n):
    """Whether J (n * n,) is [[0, I], [A, B]] with at least SCHUR_FROM DOFs."""
    m = n // 2
    if m < SCHUR_FROM or n != 2 * m:
        return False
    for i in range(m):
        for j in range(n):
            if J[i * n + j] != (1.0 if j == m + i else 0.0):
                return False
    return True


@kernel
def newton_solve(J, LU, piv, hg, schur, v):
    """v <- (I - hg J)^-1 v with the factors of `factor` (hg: the one they were made with;
    schur: whether it answered SCHUR)."""
    n = piv.size
    if not schur:
        engine.lu_solve(LU, n, piv, v)
        return
    m = n // 2
    t = LU[m * m: m * m + m]  # scratch: the Schur complement uses the first m^2 entries
    for i in range(m):  # t = r2 + hg A r1
        s = v[m + i]
        row = (m + i) * n
        for j in range(m):
            s += hg * J[row + j] * v[j]
        t[i] = s
    engine.lu_solve(LU, m, piv, t)
    for i in range(m):
        v[m + i] = t[i]
        v[i] += hg * t[i]


@kernel
def sparse_factor(table, hg):
    """The sparse Newton matrix at hg (s) factored in the packed model at address `table`,
    from its last sparse Jacobian (engine operation NEWTON_FACTOR): SPARSE, or SINGULAR."""
    ok = call_engine(access.dims(table)[ed.ENGINE], OP_NEWTON_FACTOR, table, 0.0, 0, 0, 0,
                     hg) == ed.OK
    return SPARSE if ok else SINGULAR


@kernel
def sparse_solve(table, hg, v):
    """v (2 NDOF,) <- (I - hg J)^-1 v with the factors of the last `sparse_factor` (made with
    this hg, s)."""
    call_engine(access.dims(table)[ed.ENGINE], OP_NEWTON_SOLVE, table, 0.0, v.ctypes.data, 0,
                0, hg)


@kernel
def sparse_force_solve(table, hg, v):
    """v (2 NDOF,) <- (I - hg J)^-1 [r1; r2] given v = [r1; hg g], the velocity half as the
    force hg g = M_bar r2 (N s, N m s; the ESDIRK's stage residual in mass form,
    `engine.stage_force`), with the factors of the last `sparse_factor` (made with this hg,
    s): the same as `sparse_solve` of [r1; r2] but for M_bar at the iterate against M_bar at
    the Jacobian's state."""
    call_engine(access.dims(table)[ed.ENGINE], OP_NEWTON_FORCE_SOLVE, table, 0.0,
                v.ctypes.data, 0, 0, hg)
