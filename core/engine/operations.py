"""The engine's operations: their codes, and how compiled code runs one through its entry.

Each operation of the engine is one C function (`engine.ENTRIES`); compiled code reaches it
through the process's table of their addresses, whose address `engine.connect` puts in
dims[ENGINE] of the packed model (`native.call_engine` takes the table and the operation's
code). The engine's own functions call each other's heavy parts (the evaluation, the
kinematics, the tangent) through that table too, with `run`, rather than directly: numba links
a callee's compiled code into each caller and optimises it again there, so direct calls made
the first compilation optimise the whole evaluation once per form of the equations (a third of
it). A call through an address costs a few nanoseconds and inlines nothing that mattered; and
an operation that no model of the process uses (the implicit form without IDA) is never
compiled.

The operations and their arrays (a, b, c: addresses of float64 arrays; s: a number):

    RHS                  y, ydot (0: evaluate only, for a Jacobian or a residual)
    JACOBIAN             y, J; s = 1 for column-major
    RESIDUAL             y, yp, res
    RESIDUAL_JACOBIAN    y, yp, J; s = cj
    KINEMATICS           q; x = F(q) and DF
    DEFORMATIONS         x; s = the order of the derivatives
    EVALUATE             q, qdot; qddot, DF and M_bar
    TANGENT              qddot; K0 + G0 and C0
    POSITIONS            q; x by Newton from slot x_start, nothing else
    ACCELERATIONS        q, qdot; qddot (`motion.evaluate`: no DF or M_bar unless its form has
                         them)
    CONFIGURATION        q; x = F(q) and J's factors (`kinematics.solve_kinematics`: no DF)
    MASS                 DF, M_bar and its LU at the last evaluation (`motion.reduced_mass`)
    INPUT_RESPONSE       out (NDOF,); the change of qddot that the change of the inputs since
                         the last evaluation makes at its state (`input_response`); b = the
                         error weights (NDOF,) a refined response may stop at (0: its fixed
                         relative tolerance)
    SPARSE_FACTOR        out (1,): the pivot ratio; s = SPARSE_J or SPARSE_AUGMENTED: factor
                         that matrix's sparse LU (`sparse_factors.factor`)
    SPARSE_SOLVE         b; s = SPARSE_J, SPARSE_J_TRANSPOSED or SPARSE_AUGMENTED: solve in
                         place with its sparse factors (`sparse_factors.solve`)
    RIGID_...            the rigid clusters' kernels (`rigid_kernels`, one entry for all):
      FILL               x (NX,): the slaves' coordinates from their masters' (`fill_slaves`)
      EXPAND             v (NX,); s = 1 with the slaves' c (`expand`)
      EXPAND_COLUMNS     the slaves' rows of slot DF (`expand_columns`)
      CONVECTIVE         x, xdot (NX,) (`convective`)
      RATES              `rigid_rates`
      CONDENSE           v (NX,), out (n_free,) (`condense`); s = WITH_FORCE also slot
                         force's T^T into slot dx, in the same pass (`condense_pair`)
      GEOMETRIC          r_full (NX,), lam (n_free,); into slot stiffness (`rigid_geometric`)
      DE                 `rigid_de`
    DF                   DF into slot DF from J's factors (`kinematics.compute_DF`)
    MASS_OF              M_bar into slot mass; s = 1 with the element masses' forces into slot
                         force, 2 also moving, -1 the forces alone
                         (`motion.reduced_mass_of`)
    ROW_PRODUCTS         C (a, (NDOF, NDOF)); s = the count of rows: the tangent's C += DF^T W
                         on a model from ROW_GROUPS_FROM DOFs (`tangent`: `dense.add_row_groups`,
                         compiled only for such a model)

    PRESCRIBED_RHS       y, ydot (0: evaluate only); s = the time t (s): RHS with the
                         kinematic inputs on their path (`prescribed`; RHS runs it on a
                         model that has them)
    PRESCRIBED_JACOBIAN  y, J; its t; s = 1 for column-major: JACOBIAN's (`prescribed`)
    PRESCRIBED_RESIDUAL  y, yp, res; its t: RESIDUAL with the kinematic inputs on their path
                         (`prescribed_residual`; RESIDUAL runs it on a model that has them)
    PRESCRIBED_RESIDUAL_JACOBIAN  y, yp, J; its t; s = cj: RESIDUAL_JACOBIAN's
    NEWTON_JACOBIAN, NEWTON_FACTOR, NEWTON_SOLVE  the ESDIRK's sparse Newton matrix: y; s = hg;
                         v and s = hg (`newton`; models with dims[NEWTON_SPARSE] = 1)
    STRESS_RESULTANTS    qddot (NDOF,), out (NE,): the stress resultants of the full dynamic
                         balance at the last evaluation, the rigid deformations' reactions
                         (`reactions`)
    COILS                the coil currents' part of the forms (`coil_entries`): s = the
                         part; a = y, ydot, yp or J; b = IDA's residual; t = cj; compiled
                         only for models with voltage-driven actuators (dims[NEL] > 0)
    RIGID_BODIES         the folded clusters' rigid bodies (`rigid_inertia_kernels`): s = the
                         part; a = the augmented matrix's values (t: their count) or an (NX,)
                         force; compiled only for models with a folded cluster (slot
                         rigid_bodies not empty)
    INPUT_STIFFNESS      slot stiffness -= the moment inputs' load stiffness at slot DF
                         (`port_entries`; the tangent runs it when a moment is not zero):
                         compiled only for models with an input port on a rotation
    BEAM_MASSES          a = an inertia group's index, b = its first augmented-map entry (as
                         integers); s = 1 moving: the group's element masses and point forces
                         in the BEAM's closed form (`beam_mass_entry`), NOT_AVAILABLE for a
                         group that is not of BEAMs; compiled only for models with BEAMs and
                         no rigid clusters
    FORMED_RATES         s = RATES: a = a group's index (as an integer), b = xdot (NX,): the
                         rates of a group whose element forms h = xdot^T D2e xdot itself;
                         s = HESSIANS: their D2e at the last kinematic solution, for the
                         tangent and the Newton matrix (`formed_rates`); compiled only for
                         models with such an element (the BEAM)
    STAGE_FORCE          s = FORCE: y, acc, g (may be acc): the ESDIRK's stage residual in
                         mass form, g = M_bar (qddot(y) - acc) without forming the augmented
                         system; s = FACTOR_A: that system assembled and factored at the
                         last stage force's state, for `input_response` (`stage_force`);
                         s = REFINED_ACCELERATIONS: a = the augmented system's solution (na,), an
                         evaluation's accelerations refined with the kept factors
                         (`refined_accelerations`); with the Newton operations, and for
                         every model with rigid clusters and the sparse Newton matrix
    NEWTON_FORCE_SOLVE   v = [r1; hg g]; s = hg: NEWTON_SOLVE with the velocity half a force
    STATIC_STEP          q, qdot (zeros), out (2 NDOF,): the statics' Newton step [dq; Q] on
                         the sparse Newton matrix's saddle-point system (`static_step`;
                         the statics' augmented packing with dims[NEWTON_SPARSE] = 1)
    PORT_ROWS            a = the outputs' packed rows (int64), b = out (nin + s, NDOF), c =
                         their orders (int64); s = their count: the inputs' columns of B and
                         the outputs' rows of C on the DOFs at the last evaluation
                         (`port_entries`; the linearisation's)

DF and MASS_OF are parts of the evaluation that several operations use: as operations of their
own (`part_entries`) they are compiled once, not again inside each caller; ROW_PRODUCTS is the
tangent's product in a form that is faster on large models and longer to compile, so that a
process with small models only never compiles it; COILS is apart so that a model without
coils never compiles the coils' kernels, RIGID_BODIES so that a model without a folded cluster
(a planar one) never compiles the rigid bodies', INPUT_STIFFNESS so that a model without
moment inputs never compiles their load stiffness, BEAM_MASSES so that a model without BEAMs
never compiles their closed form, FORMED_RATES so that a model without BEAMs never compiles
their directional rates.
"""

from ..numerics.jit import kernel
from ..numerics.native import call_engine
from . import data as ed
from .slots import DIMS, int_array

# every operation's C entry: (op, user data, t, a, b, c, s) -> status, a, b, c the operation's
# arrays, s its number; compiled code calls it through the table of their addresses
# (`native.call_engine`), so every module that defines an entry takes this one signature
ENTRY = "int32(int64, voidptr, float64, voidptr, voidptr, voidptr, float64)"

(OP_RHS, OP_JACOBIAN, OP_RESIDUAL, OP_RESIDUAL_JACOBIAN, OP_KINEMATICS, OP_DEFORMATIONS,
 OP_EVALUATE, OP_TANGENT, OP_POSITIONS, OP_ACCELERATIONS, OP_CONFIGURATION, OP_MASS,
 OP_INPUT_RESPONSE, OP_SPARSE_FACTOR, OP_SPARSE_SOLVE, OP_RIGID_FILL, OP_RIGID_EXPAND,
 OP_RIGID_EXPAND_COLUMNS, OP_RIGID_CONVECTIVE, OP_RIGID_RATES, OP_RIGID_CONDENSE,
 OP_RIGID_GEOMETRIC, OP_RIGID_DE, OP_DF, OP_MASS_OF, OP_PRESCRIBED_RHS,
 OP_PRESCRIBED_JACOBIAN, OP_PRESCRIBED_RESIDUAL, OP_PRESCRIBED_RESIDUAL_JACOBIAN,
 OP_NEWTON_JACOBIAN, OP_NEWTON_FACTOR, OP_NEWTON_SOLVE, OP_STRESS_RESULTANTS,
 OP_ROW_PRODUCTS, OP_COILS, OP_RIGID_BODIES, OP_INPUT_STIFFNESS, OP_BEAM_MASSES,
 OP_FORMED_RATES, OP_STAGE_FORCE, OP_NEWTON_FORCE_SOLVE, OP_STATIC_STEP,
 OP_PORT_ROWS) = range(43)
NEWTON_OPERATIONS = (OP_NEWTON_JACOBIAN, OP_NEWTON_FACTOR, OP_NEWTON_SOLVE, OP_STAGE_FORCE,
                     OP_NEWTON_FORCE_SOLVE)
RIGID_OPERATIONS = tuple(range(OP_RIGID_FILL, OP_RIGID_DE + 1))
# from how many DOFs the tangent's product goes through OP_ROW_PRODUCTS (`tangent`)
ROW_GROUPS_FROM = 150
# OP_RIGID_CONDENSE's two jobs (s): T^T v, or with it T^T of slot force into slot dx
ALONE, WITH_FORCE = 0.0, 1.0
# OP_FORMED_RATES's two jobs (s)
RATES, HESSIANS = 0.0, 1.0
# OP_STAGE_FORCE's three jobs (s): the stage force, the augmented system at its state, or an
# evaluation's accelerations refined with the kept factors
FORCE, FACTOR_A, REFINED_ACCELERATIONS = 0.0, 1.0, 2.0
# which sparse factors OP_SPARSE_FACTOR and OP_SPARSE_SOLVE take (s)
SPARSE_J, SPARSE_J_TRANSPOSED, SPARSE_AUGMENTED = range(3)


@kernel
def run(table, op, a, b, s):
    """Operation `op` on the packed model at the address `table`, with the arrays at the
    addresses a and b (int64; 0 for none) and the number s, through its entry; its status
    code (ed.NOT_CONNECTED when `engine.connect` has not given the table of the entries'
    addresses, or not this operation's)."""
    operations = int_array(table, DIMS)[ed.ENGINE]
    if operations == 0:
        return ed.NOT_CONNECTED
    return call_engine(operations, op, table, 0.0, a, b, 0, s)
