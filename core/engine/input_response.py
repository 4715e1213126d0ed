"""The change of the accelerations that a change of the held inputs makes, at a fixed state.

The inputs u (N, N m) enter the coordinate force r of `motion.evaluate` linearly, r = ... +
B(x) u, and nothing else of the augmented system depends on them, so at the state of the last
evaluation

    [M_ff  J_o^T] [d xddot_f]   [T^T B(x) du]
    [J_o   0    ] [d lambda ] = [0          ],    du = u - u_eval

with the factors that evaluation left: one solve instead of an evaluation (the kinematics, the
element masses and the factorisation). d qddot is then d xddot on the DOF coordinates and
De_m d xddot on the DOF deformations. A one-step integrator uses it for the first stage after
a change of the held inputs (`simulation.esdirk`). After the ESDIRK's stage residual in mass
form (`stage_force`), which neither assembles nor factors A, the response solves A at the
stage's state by iterative refinement with the factors of an earlier state that the storage
still holds (`refinement`: to 1e-12 of d xddot, or to the caller's weighted bound on d qddot:
the ESDIRK's, from its step and error weights), and only when there are none, or they no
longer contract fast, has that operation assemble and factor A at the stage's state
(FACTOR_A), whose factors the next responses then refine with. Exact but for round-off
(with refinement: its tolerance) at the evaluation's state;
only the augmented form keeps those factors, and only without actuators (whose forces depend
on the coil currents, a state) and without kinematic inputs: otherwise NOT_AVAILABLE.
With kinematic inputs (`prescribed`) the evaluation's qddot is the constrained one, qddot_0 +
W F, whose change is d qddot_0 projected by I - W S^-1 E^T and zero on the inputs' rows, with
the efforts changed too: the solve above is not it.
"""

from ..numerics.jit import kernel
from . import data as ed
from . import slots as slot
from .factors import augmented_resolve
from .motion import qddot_of_solution
from .operations import FACTOR_A, OP_RIGID_CONDENSE, OP_STAGE_FORCE, run
from .ports import add_input_forces
from .refinement import refined_solve_within
from .slots import float_array as _f
from .slots import int_array as _i


@kernel(inline="always")  # into its operation's entry, its one caller
def input_response(table, out, weights):
    """out (NDOF,) = d qddot (m/s^2, rad/s^2) for the change of the inputs in slot inputs since
    the last evaluation, at that evaluation's state and with its factors. weights (NDOF, or
    empty; s^2/m, s^2/rad): where the response is refined, an error e of it with
    sqrt(mean((weights_j e_j)^2)) <= 1 is accepted too (`refinement.refined_solve_within`;
    empty: its fixed relative tolerance alone). A status (OK, or
    NOT_AVAILABLE when no evaluation's factors are current, in the reduced form, with
    actuators or with kinematic inputs; SINGULAR_MASS when a stage force's A, factored here,
    is singular)."""
    dims = _i(table, slot.DIMS)
    if (dims[ed.A_FACTORS] == ed.NO_FACTORS or dims[ed.AUGMENTED] == 0
            or _f(table, slot.PORT_VALUES).size != 0 or dims[ed.NKI] != 0):
        return ed.NOT_AVAILABLE
    inputs = _f(table, slot.INPUTS)
    nin = inputs.size
    evaluated = _f(table, slot.EVALUATED_INPUTS)
    du = evaluated[nin: 2 * nin]
    out[:] = 0.0
    changed = False
    for j in range(nin):
        du[j] = inputs[j] - evaluated[j]
        changed = changed or du[j] != 0.0
    if not changed:
        return ed.OK
    nf, n_rigid = dims[ed.NFREE], dims[ed.NRIGID]
    rigid = dims[ed.NSLAVES] > 0
    free = _i(table, slot.FREE)
    force = _f(table, slot.X_TRIAL)  # scratch (NX,): B du, then d xddot
    force[:] = 0.0
    add_input_forces(_i(table, slot.INPUT_PORTS), du, _f(table, slot.X), force)
    rhs = _f(table, slot.AUG_RHS)
    if rigid:  # T^T: the slaves' forces on their masters
        run(table, OP_RIGID_CONDENSE, force.ctypes.data, rhs.ctypes.data, 0.0)
    else:
        for a in range(nf):
            rhs[a] = force[free[a]]
    rhs[nf: nf + n_rigid] = 0.0
    if dims[ed.A_FACTORS] == ed.A_AT_STAGE:  # A at a stage force's state: refined with kept
        # factors, else made by its operation (compiled only where stage forces are)
        if not refined_solve_within(table, nf + n_rigid, rhs, weights, force, out):
            _i(table, slot.COUNTERS)[ed.RESPONSE_FACTORS] += 1
            status = run(table, OP_STAGE_FORCE, 0, 0, FACTOR_A)
            if status != ed.OK:
                return status
            augmented_resolve(table, nf + n_rigid, rhs)
    else:
        augmented_resolve(table, nf + n_rigid, rhs)
    # d xddot in `force`'s room (the refinement's scratch before); the slaves' T d zddot
    # without c, which the inputs leave as it is, and no h (the DOF deformations' De_m d xddot)
    qddot_of_solution(table, rhs, force, False, rhs, False, out)
    return ed.OK
