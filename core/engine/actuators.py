"""Voice-coil actuators in the compiled engine: input forces, coil currents and their tangent.

The equations are those of `flexure.core.mechanics.actuators` (the plain-numpy twin): an
input without an actuator is a force u (N, N m) on its coordinate; a current-driven one puts
F = Km sat(G u) there; a voltage-driven one F = Km i, with its coil current i (A) a state,

    di/dt = (sat(G u) - R i - Km v) / L,     v = xdot of the actuated coordinate (m/s),

and sat a clip at +- the amplifier's saturation (its derivative zero beyond it). The
integrators' state is y = [q - q_ref, qdot, i] (n = NDOF; the currents, one per voltage-driven
actuator, at 2n ..). The packed model holds per input its kind and current index (slot
actuators) and Km, R, L, G, saturation (slot actuator_data); `motion.evaluate` reads the
currents of the state from slot currents, which `set_currents` fills before it.

Tangent blocks (exact): d qddot / d i_k = M_bar^-1 DF_c^T Km (qddot is linear in the force),
d idot_k / d qdot = -Km / L DF_c (v = DF_c qdot), d idot_k / d i_k = -R / L, with DF_c the row of
DF of the actuated coordinate c. Approximated: d idot_k / d q = -Km / L (D2F_c qdot) is left
out of the Newton matrix; it is zero when c is a DOF coordinate (DF_c a unit row) or at rest.
"""

from ..numerics.dense import lu_solve
from ..numerics.jit import kernel
from . import data as ed
from . import slots as slot
from .slots import float_array as _f
from .slots import int_array as _i


@kernel
def amplifier(coefficients, j, u):
    """sat(G u): the amplifier output (V or A) of input j for its drive signal u (V)."""
    s = coefficients[j * ed.A_WIDTH + ed.A_SATURATION]
    return min(max(coefficients[j * ed.A_WIDTH + ed.A_GAIN] * u, -s), s)


@kernel
def add_input_forces(table, r):
    """r += the force of every input on its coordinate (N, N m): u, Km sat(G u) or Km i."""
    inputs, coords = _f(table, slot.INPUTS), _i(table, slot.INPUT_COORDS)
    kinds, coefficients = _i(table, slot.ACTUATORS), _f(table, slot.ACTUATOR_DATA)
    currents = _f(table, slot.CURRENTS)
    for j in range(inputs.size):
        kind = kinds[2 * j]
        if kind == ed.FORCE_INPUT:
            r[coords[j]] += inputs[j]
        elif kind == ed.CURRENT_DRIVE:
            r[coords[j]] += coefficients[j * ed.A_WIDTH + ed.A_KM] * amplifier(
                coefficients, j, inputs[j])
        else:
            r[coords[j]] += coefficients[j * ed.A_WIDTH + ed.A_KM] * currents[kinds[2 * j + 1]]


@kernel
def set_currents(table, y, n):
    """The coil currents of the state y (at 2n ..) into slot currents."""
    currents = _f(table, slot.CURRENTS)
    for k in range(currents.size):
        currents[k] = y[2 * n + k]


@kernel
def current_rates(table, out, n):
    """di/dt (A/s) of every coil into out[2n + k] at the currents in slot currents and the
    velocities xdot of the last `evaluate`."""
    inputs, coords = _f(table, slot.INPUTS), _i(table, slot.INPUT_COORDS)
    kinds, coefficients = _i(table, slot.ACTUATORS), _f(table, slot.ACTUATOR_DATA)
    currents, xdot = _f(table, slot.CURRENTS), _f(table, slot.XDOT)
    for j in range(inputs.size):
        k = kinds[2 * j + 1]
        if kinds[2 * j] != ed.VOLTAGE_DRIVE:
            continue
        base = j * ed.A_WIDTH
        out[2 * n + k] = (amplifier(coefficients, j, inputs[j])
                          - coefficients[base + ed.A_R] * currents[k]
                          - coefficients[base + ed.A_KM] * xdot[coords[j]]
                          ) / coefficients[base + ed.A_L]


@kernel
def current_residual(table, yp, res, n):
    """IDA's residual of the coils, res[2n + k] = yp[2n + k] - di_k/dt, after `evaluate`."""
    current_rates(table, res, n)
    for k in range(_f(table, slot.CURRENTS).size):
        res[2 * n + k] = yp[2 * n + k] - res[2 * n + k]


@kernel
def _put(J, N, i, j, value, column_major):
    if column_major:
        J[j * N + i] = value
    else:
        J[i * N + j] = value


@kernel
def first_order_blocks(table, J, N, n, column_major):
    """The coils' blocks of d ydot / d y (N = 2n + currents) after the tangent (DF and the LU
    of M_bar current): d qddot / d i, d idot / d qdot, d idot / d i."""
    coords, kinds = _i(table, slot.INPUT_COORDS), _i(table, slot.ACTUATORS)
    coefficients, DF = _f(table, slot.ACTUATOR_DATA), _f(table, slot.DF)
    mass_lu, piv = _f(table, slot.MASS_LU), _i(table, slot.MASS_PIVOTS)
    column = _f(table, slot.REDUCED_FORCE)
    for j in range(coords.size):
        if kinds[2 * j] != ed.VOLTAGE_DRIVE:
            continue
        state = 2 * n + kinds[2 * j + 1]
        base, c = j * ed.A_WIDTH, coords[j]
        km, inductance = coefficients[base + ed.A_KM], coefficients[base + ed.A_L]
        for i in range(n):
            column[i] = km * DF[c * n + i]
        lu_solve(mass_lu, n, piv, column)
        for i in range(n):
            _put(J, N, n + i, state, column[i], column_major)
            _put(J, N, state, n + i, -km / inductance * DF[c * n + i], column_major)
        _put(J, N, state, state, -coefficients[base + ed.A_R] / inductance, column_major)


@kernel
def implicit_blocks(table, J, N, n, cj):
    """The coils' blocks of IDA's d res / d y + cj d res / d yp (column-major, N = 2n +
    currents) after the tangent: -Km DF_c^T (the force in the mechanical rows), Km / L DF_c and
    cj + R / L (the coil rows)."""
    coords, kinds = _i(table, slot.INPUT_COORDS), _i(table, slot.ACTUATORS)
    coefficients, DF = _f(table, slot.ACTUATOR_DATA), _f(table, slot.DF)
    for j in range(coords.size):
        if kinds[2 * j] != ed.VOLTAGE_DRIVE:
            continue
        state = 2 * n + kinds[2 * j + 1]
        base, c = j * ed.A_WIDTH, coords[j]
        km, inductance = coefficients[base + ed.A_KM], coefficients[base + ed.A_L]
        for i in range(n):
            J[state * N + n + i] = -km * DF[c * n + i]
            J[(n + i) * N + state] = km / inductance * DF[c * n + i]
        J[state * N + state] = cj + coefficients[base + ed.A_R] / inductance
