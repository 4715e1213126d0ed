"""Kinematics in the compiled engine: the elements' deformations, x = F(q) and DF.

For DOFs q (m, rad) the coordinates x (m, and the rotation parameters of the elements) solve,
on the free coordinates,

    g(x) = [e_o(x); e_m(x) - q_e; x_m - q_x] = 0

(the deformations e_o prescribed zero, the DOF deformations e_m and the DOF coordinates x_m
equal to their DOFs). With rigid clusters (`rigid`) the free coordinates are those but the
slaves', whose coordinates follow their masters' in closed form before every evaluation of
the deformations, and the rows the clusters make identically zero are out: J = dg/dz holds
the touching elements' De T_e and, for a DOF coordinate on a slave, T's row.

Warm start: the first-order prediction x_prev + DF_prev (q - q_prev); if its residual
exceeds the tolerance, chord iterations with the previous LU of the constraint Jacobian
J = dg/dx_free (converging at a rate of order |dq| / L; stopping on the residual or on the
error that rate leaves after a step), and full Newton from there if they stall, stopping on
the residual or on the step, each row and each unknown within its own tolerance (slots
row_tolerance, step_tolerance: `mechanics.scales`, lengths through the length scale, Euler
parameters and angles through 1, a floor 8 eps of the magnitude). The prediction is checked
on e alone (a BEAM's e costs an eighth of e, De, D2e) unless the last one held (dims
prediction_held), when e and the solution's De are evaluated at it in one pass, the motion's
solution order (an rhs asked again, or a state a step apart, mostly holds again: the second
pass over the elements saved); a chord iterate is evaluated with De
(the motion's order at a solution, `AT_SOLUTION`), since one chord step mostly converges and
the iterate it stops at then needs no evaluation of its own (on manipulator_control's stage
iterations 2.3 us of about 70: docs/benchmarks.md, session 35); the statics' packed model
checks its chord iterates on e alone and evaluates D2e once, at the solution. J DF = [0; I]
gives DF = dx/dq (NX, NDOF) where it is needed (the reduced form, the tangent, the
kinematics operation).

D2e is read by the equations of motion only as the constraint rows' h = xdot^T D2e xdot, and
an element that forms h itself (`entries.ORDER_DIRECTIONAL`: the BEAM) gives it from xdot
for about a tenth of its Hessians' cost. So the solution evaluates such an element's e and
De alone (order AT_SOLUTION), and the readers of D2e, the tangent and the ESDIRK's Newton
matrix, evaluate its Hessians at the solution when they need them (order HESSIANS,
`hessians_at_solution`); the statics' packed model (dims.static) evaluates them at the
solution, as its every evaluation is a tangent's.

J is factored banded or sparse as the model was packed (`factors`: `j_factor`, and `j_solve`
(J^-1 or J^-T), which takes and gives vectors in the model's order). The element
deformations e, De = de/dx and D2e come from each element module's compiled entry point.
"""

import numpy as np

from ..elements.beam_directional import POINTS_WIDTH
from ..elements.entries import ORDER_ASK, ORDER_KEPT
from ..mechanics.scales import ROUND_OFF
from ..numerics.dense import all_finite, copy
from ..numerics.jit import kernel
from ..numerics.native import call_deformations
from . import data as ed
from . import rigid as rg
from . import slots as slot
from .factors import j_factor, j_solve
from .operations import OP_RIGID_EXPAND_COLUMNS, OP_RIGID_FILL, run
from .slots import float_array as _f
from .slots import group, group_coordinates, rigid_element
from .slots import int_array as _i

# -- deformations of every element ---------------------------------------------------------------
# the orders of `deformations` beside 0, 1 and 2, which differ by the element group: whether
# its element forms h = v^T D2e v itself (`forms_quadratic_forms`)
AT_SOLUTION = 3  # e and De, and D2e where the element does not form h (the motion's needs)
HESSIANS = 4  # De and D2e where AT_SOLUTION left D2e out, slot e untouched; nothing elsewhere


@kernel(inline="always")
def forms_quadratic_forms(function, scratch, m, k, width):
    """Whether the element of the deformations entry `function` forms its quadratic forms
    h = v^T D2e v itself (`entries.ORDER_ASK`); scratch (k,) is overwritten."""
    scratch[0] = 0.0
    call_deformations(function, 0, 0, ORDER_ASK, scratch.ctypes.data, 0, 0, m, k, width)
    return scratch[0] == 1.0


@kernel
def deformations(table, x, order, skip_internal):
    """e (NE,) into slot e and, by order, each element's De, D2e into slot de, slot d2e (the
    orders 0, 1, 2, and AT_SOLUTION and HESSIANS by the element group); with skip_internal,
    not those of the elements a rigid cluster makes identically zero (`rigid`: their rows are
    out of the system, their stresses zero)."""
    dims = _i(table, slot.DIMS)
    skipping = skip_internal and dims[ed.NSLAVES] > 0
    touching = _i(table, slot.RIGID_ELEMENTS)
    e = _f(table, slot.E)
    local = _f(table, slot.LOCAL)
    max_m = dims[ed.MAX_M]
    # the BEAMs' kept rotations (slot beam_points) are of this evaluation's x only where
    # it evaluates them (ORDER_KEPT, at the solution's order)
    kept = order == AT_SOLUTION
    for g in range(dims[ed.NGROUPS]):
        row = group(table, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        if k == 0:
            continue
        width, function = row[ed.G_REF_WIDTH], row[ed.G_DEFORMATIONS_ENTRY]
        coords = group_coordinates(table, row)
        defs = _i(table, slot.DEF_INDEX)[row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        refs = _f(table, slot.GROUP_DATA).ctypes.data + 8 * row[ed.G_DATA_OFFSET]
        De = _f(table, slot.DE).ctypes.data + 8 * row[ed.G_DE_OFFSET]
        D2e = _f(table, slot.D2E).ctypes.data + 8 * row[ed.G_D2E_OFFSET]
        xl = local[:m]
        el = local[max_m: max_m + k]
        group_order = order
        if order >= AT_SOLUTION:
            forms_h = forms_quadratic_forms(function, el, m, k, width)
            if order == HESSIANS and not forms_h:
                continue
            group_order = 1 if order == AT_SOLUTION and forms_h else 2
        keeping = row[ed.G_POINTS_OFFSET] >= 0 and group_order == 1 and order == AT_SOLUTION
        stride = k * m * m  # D2e's per element, or the kept points'
        if keeping:  # e, De and the rotations the rates share, into its kept points (the
            # rates' points there, which this overwrites, are no longer of x and xdot)
            group_order, stride = ORDER_KEPT, POINTS_WIDTH
            D2e = _f(table, slot.BEAM_POINTS).ctypes.data + 8 * row[ed.G_POINTS_OFFSET]
            dims[ed.POINTS_CURRENT] = 0
        elif row[ed.G_POINTS_OFFSET] >= 0:
            kept = False
        for i in range(n):
            if skipping:
                t = rigid_element(table, row, i)
                if t >= 0 and touching[t * rg.ELEMENT_WIDTH + rg.E_INTERNAL] == 1:
                    continue
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
            call_deformations(function, xl.ctypes.data, refs + 8 * i * width, group_order,
                              el.ctypes.data, De + 8 * i * k * m, D2e + 8 * i * stride,
                              m, k, width)
            if order == HESSIANS:  # e is the solution's already
                continue
            for b in range(k):
                e[defs[i * k + b]] = el[b]
    dims[ed.ROTATIONS_KEPT] = 1 if kept else 0


@kernel
def solution_order(table):
    """The order of the deformations at a kinematic solution: AT_SOLUTION, or 2 on the
    statics' packed model (every evaluation of it is a tangent's)."""
    return 2 if _i(table, slot.DIMS)[ed.STATIC] == 1 else AT_SOLUTION


@kernel
def hessians_at_solution(table):
    """D2e at the last kinematic solution (slot x) where the solution left it out (`HESSIANS`):
    for the readers of D2e, the tangent and the ESDIRK's Newton matrix."""
    if solution_order(table) != 2:
        deformations(table, _f(table, slot.X), HESSIANS, True)


@kernel
def evaluate_elements(table, x, order):
    """The slaves of the rigid clusters from their masters in x (`rigid_kernels`), then the
    deformations of order `order` at x."""
    if _i(table, slot.DIMS)[ed.NSLAVES] > 0:
        run(table, OP_RIGID_FILL, x.ctypes.data, 0, 0.0)
    deformations(table, x, order, True)


# -- kinematics -----------------------------------------------------------------------------------
@kernel
def kinematic_residual(table, x, q, g):
    """g (n_free,) = [e_rigid; e_dof - q_e; x_dof - q_x] at x with the deformations in slot e;
    returns the largest |g_i| over its row's tolerance (slot row_tolerance): at most 1 when
    solved, NaN when g is not finite."""
    dims = _i(table, slot.DIMS)
    e = _f(table, slot.E)
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    rows = _i(table, slot.ROWS)
    worst = 0.0
    for j in range(n_rigid):
        g[j] = e[rows[j]]
    for j in range(n_edof):
        g[n_rigid + j] = e[rows[n_rigid + j]] - q[n_xdof + j]
    for j in range(n_xdof):
        g[n_rigid + n_edof + j] = x[_i(table, slot.DOF_COORDS)[j]] - q[j]
    tolerance = _f(table, slot.ROW_TOLERANCE)
    for j in range(g.size):
        r = abs(g[j]) / tolerance[j]
        if r > worst or r != r:  # a NaN stays (NaN <= 1 is False: not solved)
            worst = r
    return worst


@kernel
def store_solution(table, q, x):
    """Factor J at the solved x (deformations of `solution_order` evaluated there) and keep
    both as the next warm start; status SINGULAR_CONSTRAINTS if J's pivots say the
    configuration is singular."""
    dims = _i(table, slot.DIMS)
    nx = dims[ed.NX]
    ratio = j_factor(table)
    if not ratio > _f(table, slot.SETTINGS)[ed.SINGULAR_RATIO]:
        return ed.SINGULAR_CONSTRAINTS
    copy(_f(table, slot.X)[:nx], x[:nx])
    copy(_f(table, slot.Q), q)
    dims[ed.WARM] = 1
    return ed.OK


@kernel
def dof_rows(table, v, out):
    """out (n_free,) = [0; v_e; v_x]: a DOF vector v (NDOF,: coordinate DOFs first) on the rows
    of J (rigid rows, DOF deformation rows, DOF coordinate rows), so that J^-1 out = DF v."""
    dims = _i(table, slot.DIMS)
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    out[:] = 0.0
    for j in range(n_xdof):
        out[n_rigid + n_edof + j] = v[j]
    for j in range(n_edof):
        out[n_rigid + j] = v[n_xdof + j]


@kernel
def dof_values(table, rows, out):
    """out (NDOF,) = the DOF rows of `rows` (n_free,, a vector on J's rows), coordinate DOFs
    first: `dof_rows` undone; of J^-T w they are DF^T w."""
    dims = _i(table, slot.DIMS)
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    for j in range(n_xdof):
        out[j] = rows[n_rigid + n_edof + j]
    for j in range(n_edof):
        out[n_xdof + j] = rows[n_rigid + j]


@kernel
def compute_DF(table):
    """DF (NX, NDOF) into slot DF from the LU of J of the last kinematic solution: J DF =
    [0; I] column by column (NDOF solves)."""
    dims = _i(table, slot.DIMS)
    ndof, nf = dims[ed.NDOF], dims[ed.NFREE]
    DF, column, unit = _f(table, slot.DF), _f(table, slot.DX), _f(table, slot.REDUCED_FORCE)
    free = _i(table, slot.FREE)
    DF[:] = 0.0
    for j in range(ndof):
        unit[:] = 0.0
        unit[j] = 1.0
        dof_rows(table, unit, column)
        j_solve(table, column, False)
        for a in range(nf):
            DF[free[a] * ndof + j] = column[a]
    if dims[ed.NSLAVES] > 0:  # the slaves' rows: T DF
        run(table, OP_RIGID_EXPAND_COLUMNS, 0, 0, 0.0)  # on slot DF


@kernel
def newton_step(table, x, g, dx):
    """x -= J^-1 g on the free coordinates, with the factors in slot lu (the step into dx,
    n_free); the largest |dx_a| over its unknown's tolerance (slot step_tolerance, at least
    ROUND_OFF |x_a|: a step below a few ulps of x_a cannot refine it): at most 1 when
    converged, not finite if the step is not."""
    free = _i(table, slot.FREE)
    tolerance = _f(table, slot.STEP_TOLERANCE)
    copy(dx, g)
    j_solve(table, dx, False)
    step = 0.0
    for a in range(_i(table, slot.DIMS)[ed.NFREE]):
        x[free[a]] -= dx[a]
        r = abs(dx[a]) / max(tolerance[a], ROUND_OFF * abs(x[free[a]]))
        if r > step or r != r:  # a NaN stays: not finite
            step = r
    return step


@kernel
def predicted_coordinates(table, q, x, dq, dx):
    """x (NX,) = the last kinematic solution (slot x, at the DOFs in slot q) moved to the DOFs
    q to first order with the factors of J it left: x_prev + J^-1 [0; q - q_prev] on the free
    coordinates, the others (the slaves) as they were. dq (NDOF,) and dx (n_free,) scratch."""
    dims = _i(table, slot.DIMS)
    x_prev, q_prev = _f(table, slot.X), _f(table, slot.Q)
    for j in range(dims[ed.NDOF]):
        dq[j] = q[j] - q_prev[j]
    dof_rows(table, dq, dx)
    j_solve(table, dx, False)
    nx = dims[ed.NX]
    copy(x[:nx], x_prev[:nx])
    free = _i(table, slot.FREE)
    for a in range(dims[ed.NFREE]):
        x[free[a]] += dx[a]


@kernel
def start_from_plant(plant, output, q):
    """Slot x_start of the packed model `output` (its table's address) = the plant's last
    kinematic solution moved to the DOFs q (NDOF,: m, rad) with its factors
    (`predicted_coordinates`; why: `simulation.measuring`). Only for a plant whose last
    solution is of the state measured (the caller knows: after a step, not after a state was
    set); left as the caller set it when the plant holds no solution with its factors
    (before its first, after a restart of its kinematics)."""
    if _i(plant, slot.DIMS)[ed.WARM] != 1:
        return
    predicted_coordinates(plant, q, _f(output, slot.X_START),
                          _f(output, slot.REDUCED_FORCE),  # scratch of the output's,
                          _f(output, slot.DX))  # not the plant's


@kernel(inline="always")  # into its operation's entry, its one caller
def solve_positions(table, q):
    """x = F(q) into slot x by full Newton from slot x_start, stopping as soon as the
    constraint residual is within the tolerance: the positions alone (no D2e, no factors or DF
    kept, no warm start set), for measuring outputs; a status code."""
    dims = _i(table, slot.DIMS)
    dims[ed.MASS_CURRENT] = dims[ed.REDUCED] = dims[ed.WARM] = dims[ed.PREDICTION_HELD] = 0
    dims[ed.POINTS_CURRENT] = 0
    dims[ed.A_FACTORS] = ed.NO_FACTORS
    nx = dims[ed.NX]
    x, g, dx = _f(table, slot.X_TRIAL), _f(table, slot.G), _f(table, slot.DX)
    copy(x, _f(table, slot.X_START))
    if not all_finite(x):
        copy(x, _f(table, slot.X))
    for _ in range(dims[ed.MAX_NEWTON]):
        evaluate_elements(table, x, 0)  # the residual needs e alone; De only for a step
        if kinematic_residual(table, x, q, g) <= 1.0:
            copy(_f(table, slot.X)[:nx], x[:nx])
            return ed.OK
        deformations(table, x, 1, True)
        if not j_factor(table) > 0.0:
            return ed.SINGULAR_CONSTRAINTS
        if not np.isfinite(newton_step(table, x, g, dx)):
            return ed.NOT_CONVERGED
    return ed.NOT_CONVERGED


@kernel(inline="always")  # into its operation's entry, its one caller
def solve_kinematics(table, q):
    """x = F(q) into slot x, with e, De, D2e (of the elements that need it for h: `AT_SOLUTION`)
    and the LU of J there; a status code."""
    dims = _i(table, slot.DIMS)
    dims[ed.MASS_CURRENT] = dims[ed.REDUCED] = 0  # DF and M_bar are of another state now
    dims[ed.A_FACTORS] = ed.NO_FACTORS  # and so are the augmented system's factors
    dims[ed.POINTS_CURRENT] = 0  # and the BEAMs' kept inertia points
    nx = dims[ed.NX]
    x, g, dx = _f(table, slot.X_TRIAL), _f(table, slot.G), _f(table, slot.DX)
    if dims[ed.WARM] == 1:
        # the first-order prediction x_prev + DF_prev (q - q_prev): with DF where the reduced
        # form keeps it (every solution computes it there), else as J_prev^-1 [0; dq] with the
        # factors kept from the previous solution
        dq = _f(table, slot.REDUCED_FORCE)
        if dims[ed.AUGMENTED] == 0:
            x_prev, q_prev, DF = _f(table, slot.X), _f(table, slot.Q), _f(table, slot.DF)
            ndof = dims[ed.NDOF]
            for j in range(ndof):
                dq[j] = q[j] - q_prev[j]
            for a in range(nx):
                s = x_prev[a]
                for j in range(ndof):
                    s += DF[a * ndof + j] * dq[j]
                x[a] = s
        else:
            predicted_coordinates(table, q, x, dq, dx)
        # the residual needs e alone; the chord steps use the kept factors. Where the last
        # prediction held, this one mostly holds too (an integrator's states a step or a
        # correction apart, an rhs asked again), so e comes with the solution's De in one
        # pass rather than two; where it then fails, that De is overwritten by the chord
        # iterate's (the chord steps read the kept factors, not De)
        order = solution_order(table)
        held = dims[ed.PREDICTION_HELD] == 1 and order == AT_SOLUTION
        evaluate_elements(table, x, order if held else 0)
        if kinematic_residual(table, x, q, g) <= 1.0:
            if not held:
                deformations(table, x, order, True)  # the slaves are filled
            dims[ed.PREDICTION_HELD] = 1
            return store_solution(table, q, x)
        dims[ed.PREDICTION_HELD] = 0
        previous = 0.0  # no rate before the second step
        # a chord iterate's e with De, the motion's solution order: a chord step from the
        # first-order prediction mostly converges (its rate is of order |dq| / L), and then
        # its De is the solution's, the e-only evaluation before it saved; the statics'
        # solution order (D2e, some ten times e) stays for the iterate it stops at
        chord_order = order if order == AT_SOLUTION else 0
        for _ in range(dims[ed.CHORD_ITERATIONS]):
            step = newton_step(table, x, g, dx)
            if not np.isfinite(step):
                break
            evaluate_elements(table, x, chord_order)
            # chord steps contract linearly, at the rate of two successive steps: the error
            # left after a step is step rate / (1 - rate), not the step itself (a small step
            # of a slow contraction is no convergence)
            rate = step / previous if previous > 0.0 else 1.0
            previous = step
            if kinematic_residual(table, x, q, g) <= 1.0 or step == 0.0 or (
                    rate < 1.0 and step * rate <= 1.0 - rate):
                if chord_order != order:
                    deformations(table, x, order, True)
                return store_solution(table, q, x)
    else:
        dims[ed.PREDICTION_HELD] = 0
        copy(x, _f(table, slot.X_START))
    if not all_finite(x):
        copy(x, _f(table, slot.X))
    for _ in range(dims[ed.MAX_NEWTON]):  # full Newton, stopping as solve_positions does
        evaluate_elements(table, x, 1)
        if kinematic_residual(table, x, q, g) <= 1.0:
            evaluate_elements(table, x, solution_order(table))
            return store_solution(table, q, x)
        if not j_factor(table) > 0.0:
            return ed.SINGULAR_CONSTRAINTS
        step = newton_step(table, x, g, dx)
        if not np.isfinite(step):
            return ed.NOT_CONVERGED
        if step <= 1.0:
            evaluate_elements(table, x, solution_order(table))
            return store_solution(table, q, x)
    return ed.NOT_CONVERGED

