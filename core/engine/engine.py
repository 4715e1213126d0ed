"""The compiled evaluation engine: kinematics, inertia, equations of motion and their tangent.

One place computes, for DOFs q and velocities qdot (m, rad, m/s, rad/s) and the held inputs u
(N, N m), everything the integrators need, compiled with numba and cached on disk. Each job
has its module; this one holds the forms the integrators call and the operations' entries:

    data             the model packed into flat arrays (`EngineData`), status codes
    slots            the packed model's arrays by slot (indices, accessors)
    kinematics       the elements' deformations, x = F(q), DF
    factors          J and the augmented system: assembled and factored banded, or sparse
                     (`sparse_packing`: their patterns and scatter maps, packed per model)
    motion           qddot from M_bar qddot = DF^T r (or the augmented system), M_bar
    input_response   the change of qddot that a change of the inputs makes, from the factors
                     of the last evaluation
    refinement       a solve of the augmented system with an earlier state's factors, refined
                     (the input response's; `refined_accelerations`: the evaluation's)
    stage_force      the ESDIRK's stage residual in mass form, r - M xddot, without a solve
    static_step      the statics' Newton step on the sparse saddle-point system
    point_masses     an element's point forces and mass Dp^T Mp Dp through its inertia points
    tangent          stiffness K0 + G0 and damping C0 of the dynamic balance
    rigid            the rigid clusters packed: the slaves' coordinates and the rigid beams'
                     rows out of J and the augmented system (`rigid_kernels`: the slaves
                     explicit in their masters, x_s = S(z), and the chain rule through T)
    prescribed       the first-order form with kinematic inputs: u, u', u'' at the time
                     given, the constrained accelerations, the efforts and the Jacobian
    prescribed_residual  the implicit form (IDA's) with kinematic inputs
    newton           the ESDIRK's Newton matrix sparse on the coordinates (large models)
    reactions        the stress resultants of the full dynamic balance, reactions included
    operations       the operations' codes, and `run`: one through its address
    engine (here)    the first-order and implicit forms, one C entry point per operation
                     (`ENTRIES`), `connect`, `call`

with the dense kernels (M_bar's LU, the integrators' Newton matrices) from `numerics.dense`.

First-order form (CVODE, ESDIRK): the state y = [q - q_ref, qdot] and ydot = [qdot, qddot],
its Jacobian [[0, I], [-M_bar^-1 K, -M_bar^-1 C]]. Implicit form (IDA): the residual
[qp - qdot; M_bar (qddot_p - qddot(q, qdot))] and its Jacobian d res / d y + cj d res / d yp
= [[cj I, -I], [K, C + cj M_bar]]. A scene with voltage-driven actuators appends their coil
currents i (A) to the state, y = [q - q_ref, qdot, i], with their rates and tangent blocks
from `actuators` through an operation of their own (`coil_entries`). Every operation is a
C function of its own (`ENTRIES`), compiled the first time a model needs it (`connect`: the
sparse factorisations, the rigid clusters' kernels, the folded clusters' rigid bodies
(`rigid_inertia_kernels`), the moment inputs' load stiffness (`port_entries`) and the coils'
only for models that use them); compiled code (a SUNDIALS callback, the sampled loop, the
engine's own functions) reaches it through the process's table of their addresses, Python
through `call`.

Everything works element by element on the packed arrays of `data.EngineData` (no
dense (NX, NX) matrix is formed), and no evaluation allocates. The plain-numpy twin of every
quantity is in `mechanics` (its kinematics, assembly and mechanics modules, which the static
analyses use); tests compare the two to round-off.

Status codes (`data`): each function returns OK or the reason it could not finish;
nothing raises inside compiled code.
"""

import numpy as np

from ..numerics.dense import lu_factor, lu_solve, lu_solve_rows, put
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, call_engine, carray, float_address
from . import beam_mass_entry, formed_rates, newton, operations, rigid_kernels, sparse_factors
from . import data as ed
from . import slots as slot
from .coil_entries import (
    COILS_COLUMNS_BLOCKS,
    COILS_IMPLICIT_BLOCKS,
    COILS_RATES,
    COILS_RESIDUAL,
    COILS_ROWS_BLOCKS,
    COILS_SET,
    coils_entry,
)
from .input_response import input_response
from .kinematic_entries import (
    configuration_entry,
    deformations_entry,
    kinematics_entry,
    positions_entry,
)
from .motion import evaluate, reduced_mass
from .operations import (
    OP_ACCELERATIONS,
    OP_COILS,
    OP_CONFIGURATION,
    OP_DEFORMATIONS,
    OP_DF,
    OP_EVALUATE,
    OP_INPUT_RESPONSE,
    OP_JACOBIAN,
    OP_KINEMATICS,
    OP_MASS,
    OP_MASS_OF,
    OP_POSITIONS,
    OP_PRESCRIBED_JACOBIAN,
    OP_PRESCRIBED_RESIDUAL,
    OP_PRESCRIBED_RESIDUAL_JACOBIAN,
    OP_PRESCRIBED_RHS,
    OP_RESIDUAL,
    OP_RESIDUAL_JACOBIAN,
    OP_RHS,
    OP_SPARSE_FACTOR,
    OP_SPARSE_SOLVE,
    OP_STAGE_FORCE,
    OP_STATIC_STEP,
    OP_STRESS_RESULTANTS,
    OP_TANGENT,
    RIGID_OPERATIONS,
    SPARSE_AUGMENTED,
    run,
)
from .part_entries import df_entry, mass_of_entry, row_products_entry
from .port_entries import input_stiffness_entry, port_rows_entry
from .ports import PORT_WIDTH, ROTATION
from .prescribed import prescribed_jacobian_entry, prescribed_rhs_entry
from .prescribed_residual import prescribed_residual_entry, prescribed_residual_jacobian_entry
from .reactions import stress_resultants_entry
from .rigid_inertia_kernels import rigid_bodies_entry
from .slots import float_array, int_array
from .stage_force import stage_force_entry
from .static_step import static_step_entry
from .tangent import tangent

# what other modules take from here (the accessors and the dense LU are the engine's too)
__all__ = ["ENGINE_ENTRY", "ENTRIES", "OP_ACCELERATIONS", "OP_CONFIGURATION", "OP_DEFORMATIONS",
           "OP_EVALUATE", "OP_INPUT_RESPONSE", "OP_JACOBIAN", "OP_KINEMATICS", "OP_MASS",
           "OP_POSITIONS", "OP_RESIDUAL", "OP_RESIDUAL_JACOBIAN", "OP_RHS", "OP_STATIC_STEP",
           "OP_STRESS_RESULTANTS", "OP_TANGENT", "call", "connect", "first_order_jacobian",
           "first_order_rhs", "float_array", "implicit_jacobian", "implicit_residual", "int_array",
           "lu_factor", "lu_solve"]

_i, _f = int_array, float_array  # the short names of the many uses below


# -- first-order form for the integrators ---------------------------------------------------------
@kernel(inline="always")  # into its operation's entry, its one caller
def first_order_rhs(table, y, ydot):
    """ydot = [qdot, qddot(, di/dt)] for the state y = [q - q_ref, qdot(, i)]; a status code.

    The absolute DOFs are formed in the last NDOF entries of the scratch array, which no
    other part of an evaluation uses. ydot may be empty: the evaluation only."""
    dims = _i(table, slot.DIMS)
    n, n_el = dims[ed.NDOF], dims[ed.NEL]
    for j in range(2 * n + n_el):
        if not np.isfinite(y[j]):
            return ed.NONFINITE_STATE
    q_abs = _f(table, slot.LOCAL)[_f(table, slot.LOCAL).size - n:]
    q_ref = _f(table, slot.Q_REF)
    for j in range(n):
        q_abs[j] = q_ref[j] + y[j]
    if n_el:  # the coils' kernels through their operation (`coil_entries`)
        status = run(table, OP_COILS, y.ctypes.data, 0, COILS_SET)
        if status != ed.OK:
            return status
    status = run(table, OP_ACCELERATIONS, q_abs.ctypes.data, y.ctypes.data + 8 * n, 0.0)
    if status != ed.OK:
        return status
    qddot = _f(table, slot.QDDOT)
    for j in range(n):
        if not np.isfinite(qddot[j]):
            return ed.NONFINITE_RESULT
    if ydot.size:  # empty when only the evaluation left in F is wanted
        for j in range(n):
            ydot[j] = y[n + j]
            ydot[n + j] = qddot[j]
        if n_el:
            return run(table, OP_COILS, ydot.ctypes.data, 0, COILS_RATES)
    return ed.OK


@kernel(inline="always")  # into its operation's entry, its one caller
def first_order_jacobian(table, y, J, column_major):
    """d ydot / d y (N, N; N = 2n plus the coil currents) into J (flat; column-major for
    SUNDIALS' dense matrix): [[0, I], [-M_bar^-1 K, -M_bar^-1 C]] with the model's tangent at
    y, and the coils' blocks (`actuators.first_order_blocks`); a status code."""
    status = run(table, OP_RHS, y.ctypes.data, 0, 0.0)  # the evaluation only
    if status != ed.OK:
        return status
    n = _i(table, slot.DIMS)[ed.NDOF]
    status = run(table, OP_TANGENT, _f(table, slot.QDDOT).ctypes.data, 0, 0.0)
    if status != ed.OK:
        return status
    K, C = _f(table, slot.STIFFNESS), _f(table, slot.DAMPING)
    mass_lu, piv = _f(table, slot.MASS_LU), _i(table, slot.MASS_PIVOTS)
    column = _f(table, slot.REDUCED_FORCE)
    n_el = _i(table, slot.DIMS)[ed.NEL]
    N = 2 * n + n_el
    J[:] = 0.0
    for j in range(n):
        put(J, N, j, n + j, 1.0, column_major)
    if not column_major:  # rows n.. of J = -M^-1 [K C], solved where they lie
        for i in range(n):
            row = (n + i) * N
            for j in range(n):
                J[row + j] = K[i * n + j]
                J[row + n + j] = C[i * n + j]
        lu_solve_rows(mass_lu, n, piv, J, n * N, N, 2 * n)
        for i in range(n):
            row = (n + i) * N
            for j in range(2 * n):
                J[row + j] = -J[row + j]
        if n_el:
            return run(table, OP_COILS, J.ctypes.data, 0, COILS_ROWS_BLOCKS)
        return ed.OK
    for j in range(n):  # column j of -M^-1 K and of -M^-1 C
        for i in range(n):
            column[i] = K[i * n + j]
        lu_solve(mass_lu, n, piv, column)
        for i in range(n):
            put(J, N, n + i, j, -column[i], column_major)
        for i in range(n):
            column[i] = C[i * n + j]
        lu_solve(mass_lu, n, piv, column)
        for i in range(n):
            put(J, N, n + i, n + j, -column[i], column_major)
    if n_el:
        return run(table, OP_COILS, J.ctypes.data, 0, COILS_COLUMNS_BLOCKS)
    return ed.OK


@kernel(inline="always")  # into its operation's entry, its one caller
def implicit_residual(table, y, yp, res):
    """IDA's residual [qp - qdot; M_bar (qddot_p - qddot(q, qdot, i)); ip - di/dt] (the last
    rows for the coil currents only); a status code."""
    status = run(table, OP_RHS, y.ctypes.data, 0, 0.0)  # the evaluation only
    if status != ed.OK:
        return status
    status = run(table, OP_MASS, 0, 0, 0.0)  # motion.reduced_mass
    if status != ed.OK:
        return status
    n = _i(table, slot.DIMS)[ed.NDOF]
    mass, qddot = _f(table, slot.MASS), _f(table, slot.QDDOT)
    for i in range(n):
        res[i] = yp[i] - y[n + i]
        s = 0.0
        for j in range(n):
            s += mass[i * n + j] * (yp[n + j] - qddot[j])
        res[n + i] = s
    if _i(table, slot.DIMS)[ed.NEL]:
        return run(table, OP_COILS, yp.ctypes.data, res.ctypes.data, COILS_RESIDUAL)
    return ed.OK


@kernel(inline="always")  # into its operation's entry, its one caller
def implicit_jacobian(table, y, yp, cj, J):
    """IDA's d res / d y + cj d res / d yp, column-major (N, N; N = 2n plus the coil
    currents): [[cj I, -I], [K, C + cj M_bar]] with the tangent's dynamic balance at
    qddot = yp[n: 2n], and the coils' blocks (`actuators.implicit_blocks`); a status code."""
    status = run(table, OP_RHS, y.ctypes.data, 0, 0.0)  # the evaluation only
    if status != ed.OK:
        return status
    n = _i(table, slot.DIMS)[ed.NDOF]
    status = run(table, OP_TANGENT, yp.ctypes.data + 8 * n, 0, 0.0)
    if status != ed.OK:
        return status
    K, C, mass = _f(table, slot.STIFFNESS), _f(table, slot.DAMPING), _f(table, slot.MASS)
    n_el = _i(table, slot.DIMS)[ed.NEL]
    N = 2 * n + n_el
    J[:] = 0.0
    for i in range(n):
        J[i * N + i] = cj
        J[(n + i) * N + i] = -1.0
        for j in range(n):
            J[j * N + n + i] = K[i * n + j]
            J[(n + j) * N + n + i] = C[i * n + j] + cj * mass[i * n + j]
    if n_el:  # cj as the operation's time argument
        return call_engine(_i(table, slot.DIMS)[ed.ENGINE], OP_COILS, table, cj,
                           J.ctypes.data, 0, 0, COILS_IMPLICIT_BLOCKS)
    return ed.OK


# -- the operations: one compiled C function each, compiled when a model first needs it ------
# (`operations.ENTRY`: their one signature)
ENGINE_ENTRY = operations.ENTRY
_F8 = np.float64


@kernel(inline="always")
def _state_size(table):
    """The integrators' state size: [q - q_ref, qdot, coil currents]."""
    dims = _i(table, slot.DIMS)
    return 2 * dims[ed.NDOF] + dims[ed.NEL]


@entry(ENGINE_ENTRY)
def rhs_entry(op, user_data, t, a, b, c, s):
    """OP_RHS: y (a), ydot (b; null: the evaluation only); a model with kinematic inputs
    runs OP_PRESCRIBED_RHS at time t."""
    table = address_of(user_data)
    if _i(table, slot.DIMS)[ed.NKI]:
        return run(table, OP_PRESCRIBED_RHS, address_of(a), address_of(b), t)
    n = _state_size(table)
    return first_order_rhs(table, carray(a, (n,), _F8),
                           carray(b, (n if address_of(b) else 0,), _F8))


@entry(ENGINE_ENTRY)
def jacobian_entry(op, user_data, t, a, b, c, s):
    """OP_JACOBIAN: y (a), J (b); s = 1 for column-major; a model with kinematic inputs
    runs OP_PRESCRIBED_JACOBIAN at time t."""
    table = address_of(user_data)
    if _i(table, slot.DIMS)[ed.NKI]:
        return call_engine(_i(table, slot.DIMS)[ed.ENGINE], OP_PRESCRIBED_JACOBIAN,
                           user_data, t, a, b, c, s)
    n = _state_size(table)
    return first_order_jacobian(table, carray(a, (n,), _F8), carray(b, (n * n,), _F8),
                                s != 0.0)


@entry(ENGINE_ENTRY)
def residual_entry(op, user_data, t, a, b, c, s):
    """OP_RESIDUAL: y (a), yp (b), res (c); a model with kinematic inputs runs
    OP_PRESCRIBED_RESIDUAL at time t."""
    table = address_of(user_data)
    if _i(table, slot.DIMS)[ed.NKI]:
        return call_engine(_i(table, slot.DIMS)[ed.ENGINE], OP_PRESCRIBED_RESIDUAL,
                           user_data, t, a, b, c, s)
    n = _state_size(table)
    return implicit_residual(table, carray(a, (n,), _F8), carray(b, (n,), _F8),
                             carray(c, (n,), _F8))


@entry(ENGINE_ENTRY)
def residual_jacobian_entry(op, user_data, t, a, b, c, s):
    """OP_RESIDUAL_JACOBIAN: y (a), yp (b), J (c); s = cj; a model with kinematic inputs
    runs OP_PRESCRIBED_RESIDUAL_JACOBIAN at time t."""
    table = address_of(user_data)
    if _i(table, slot.DIMS)[ed.NKI]:
        return call_engine(_i(table, slot.DIMS)[ed.ENGINE], OP_PRESCRIBED_RESIDUAL_JACOBIAN,
                           user_data, t, a, b, c, s)
    n = _state_size(table)
    return implicit_jacobian(table, carray(a, (n,), _F8), carray(b, (n,), _F8), s,
                             carray(c, (n * n,), _F8))




@entry(ENGINE_ENTRY)
def evaluate_entry(op, user_data, t, a, b, c, s):
    """OP_EVALUATE: q (a), qdot (b); qddot, DF and M_bar."""
    table = address_of(user_data)
    status = run(table, OP_ACCELERATIONS, address_of(a), address_of(b), 0.0)
    return run(table, OP_MASS, 0, 0, 0.0) if status == ed.OK else status


@entry(ENGINE_ENTRY)
def tangent_entry(op, user_data, t, a, b, c, s):
    """OP_TANGENT: qddot (a)."""
    table = address_of(user_data)
    return tangent(table, carray(a, (_i(table, slot.DIMS)[ed.NDOF],), _F8))



@entry(ENGINE_ENTRY)
def accelerations_entry(op, user_data, t, a, b, c, s):
    """OP_ACCELERATIONS: q (a), qdot (b)."""
    table = address_of(user_data)
    ndof = _i(table, slot.DIMS)[ed.NDOF]
    return evaluate(table, carray(a, (ndof,), _F8), carray(b, (ndof,), _F8))



@entry(ENGINE_ENTRY)
def mass_entry(op, user_data, t, a, b, c, s):
    """OP_MASS."""
    return reduced_mass(address_of(user_data))


@entry(ENGINE_ENTRY)
def input_response_entry(op, user_data, t, a, b, c, s):
    """OP_INPUT_RESPONSE: out (a); the error weights of a refined response (b, (NDOF,);
    null: the refinement's fixed tolerance)."""
    table = address_of(user_data)
    n = _i(table, slot.DIMS)[ed.NDOF]
    return input_response(table, carray(a, (n,), _F8),
                          carray(b, (n if address_of(b) else 0,), _F8))


@entry(ENGINE_ENTRY)
def sparse_factor_entry(op, user_data, t, a, b, c, s):
    """OP_SPARSE_FACTOR: out (a, (1,)); s = which matrix."""
    sparse_factors.factor(address_of(user_data), int(s), carray(a, (1,), _F8))
    return ed.OK


@entry(ENGINE_ENTRY)
def sparse_solve_entry(op, user_data, t, a, b, c, s):
    """OP_SPARSE_SOLVE: b (a); s = which factors."""
    table = address_of(user_data)
    dims = _i(table, slot.DIMS)
    n = dims[ed.NFREE] + (dims[ed.NRIGID] if int(s) == SPARSE_AUGMENTED else 0)
    sparse_factors.solve(table, int(s), carray(a, (n,), _F8))
    return ed.OK


@entry(ENGINE_ENTRY)
def missing_entry(op, user_data, t, a, b, c, s):
    """An operation that no `connect` has asked for: NOT_CONNECTED."""
    return ed.NOT_CONNECTED


# each operation's entry, by code; and the operations each one calls through the table
ENTRIES = (rhs_entry, jacobian_entry, residual_entry, residual_jacobian_entry, kinematics_entry,
           deformations_entry, evaluate_entry, tangent_entry, positions_entry,
           accelerations_entry, configuration_entry, mass_entry, input_response_entry,
           sparse_factor_entry, sparse_solve_entry) + (
           rigid_kernels.rigid_entry,) * len(RIGID_OPERATIONS) + (
           df_entry, mass_of_entry, prescribed_rhs_entry, prescribed_jacobian_entry,
           prescribed_residual_entry, prescribed_residual_jacobian_entry,
           newton.jacobian_entry, newton.factor_entry, newton.solve_entry,
           stress_resultants_entry, row_products_entry, coils_entry, rigid_bodies_entry,
           input_stiffness_entry, beam_mass_entry.beam_masses_entry,
           formed_rates.formed_rates_entry, stage_force_entry,
           newton.force_solve_entry, static_step_entry, port_rows_entry)
CALLS = {OP_RHS: (OP_ACCELERATIONS,), OP_JACOBIAN: (OP_RHS, OP_TANGENT),
         OP_RESIDUAL: (OP_RHS, OP_MASS), OP_RESIDUAL_JACOBIAN: (OP_RHS, OP_TANGENT),
         OP_KINEMATICS: (OP_CONFIGURATION, OP_DF), OP_EVALUATE: (OP_ACCELERATIONS, OP_MASS),
         OP_TANGENT: (OP_MASS,), OP_ACCELERATIONS: (OP_CONFIGURATION, OP_DF, OP_MASS_OF),
         OP_MASS: (OP_DF, OP_MASS_OF), OP_PRESCRIBED_RHS: (OP_ACCELERATIONS, OP_MASS),
         OP_PRESCRIBED_JACOBIAN: (OP_PRESCRIBED_RHS, OP_TANGENT),
         OP_PRESCRIBED_RESIDUAL: (OP_PRESCRIBED_RHS,),
         OP_PRESCRIBED_RESIDUAL_JACOBIAN: (OP_PRESCRIBED_RHS, OP_TANGENT),
         OP_STRESS_RESULTANTS: (OP_DF,), OP_STATIC_STEP: (OP_CONFIGURATION,),
         **newton.CALLS}
# the addresses of the operations' entries in this process (missing_entry's until connected)
ENGINE_TABLE = np.zeros(len(ENTRIES), dtype=np.int64)


def connect(data, *ops):
    """Compile (or load from the cache) the entries of the operations `ops` (all of them when
    none is given) and of those they call, put their addresses into this process's table of
    operations, and that table's address into the packed model (dims[ENGINE]), for the
    compiled callers (SUNDIALS' callbacks, the ESDIRK's, the sampled loop's, `run`) that call
    the engine through it. An operation no model of the process has asked for is not
    compiled: a model without coil currents or IDA never compiles the implicit form. The
    addresses belong to this process, so they are set at run time, never cached. Returns
    `data`."""
    if not ENGINE_TABLE.any():
        ENGINE_TABLE[:] = missing_entry.address
    dims = data.int_array("dims")
    wanted = list(ops) if ops else list(range(len(ENTRIES)))
    if ops and (dims[ed.J_SPARSE] or dims[ed.A_SPARSE]):  # the factors' own operations
        wanted += [OP_SPARSE_FACTOR, OP_SPARSE_SOLVE]
    if OP_JACOBIAN in ops and dims[ed.NEWTON_SPARSE]:  # the ESDIRK's sparse Newton matrix
        wanted += newton.OPERATIONS
    if ops and dims[ed.NSLAVES] > 0:  # the rigid clusters'
        wanted += RIGID_OPERATIONS
        if dims[ed.NEWTON_SPARSE]:  # their evaluation's refined accelerations, whatever asks
            wanted.append(OP_STAGE_FORCE)  # (`refined_accelerations`)
    if ops and dims[ed.NKI] > 0:  # the kinematic inputs' forms (`prescribed`)
        wanted += [OP_PRESCRIBED_RHS, OP_PRESCRIBED_JACOBIAN]
        if OP_RESIDUAL in ops or OP_RESIDUAL_JACOBIAN in ops:  # and IDA's
            wanted += [OP_PRESCRIBED_RESIDUAL, OP_PRESCRIBED_RESIDUAL_JACOBIAN]
    if ops and dims[ed.NDOF] >= operations.ROW_GROUPS_FROM:  # the tangent's, large models
        wanted.append(operations.OP_ROW_PRODUCTS)
    if ops and dims[ed.NEL] > 0:  # the coil currents' part of the forms
        wanted.append(OP_COILS)
    if ops and data.int_array("rigid_bodies").size:  # the folded clusters' rigid bodies
        wanted.append(operations.OP_RIGID_BODIES)
    if ops and np.any(data.int_array("input_ports")[::PORT_WIDTH] == ROTATION):  # moments'
        wanted.append(operations.OP_INPUT_STIFFNESS)
    if ops and beam_mass_entry.uses(data):  # the BEAMs' element masses in closed form
        wanted.append(operations.OP_BEAM_MASSES)
    if ops and formed_rates.uses(data):  # the rates of the elements that form h themselves
        wanted.append(operations.OP_FORMED_RATES)
    while wanted:
        op = wanted.pop()
        if ENGINE_TABLE[op] == missing_entry.address:
            ENGINE_TABLE[op] = ENTRIES[op].address
            wanted.extend(CALLS.get(op, ()))
    dims[ed.ENGINE] = ENGINE_TABLE.ctypes.data
    return data


def call(data, op, a=None, b=None, c=None, s=0.0, t=0.0):
    """Run one engine operation from Python (a ctypes call, about 1 us): data an
    `EngineData` (connected here to the operation), a, b, c contiguous float64 arrays of the
    operation. Returns the status."""
    connect(data, op)
    return ENTRIES[op].ctypes(op, data.address, t, _address(a), _address(b), _address(c),
                              float(s))


def _address(array):
    return None if array is None else float_address(array)
