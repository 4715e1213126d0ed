"""Voice-coil actuators in the compiled engine: port values, coil currents and their tangent.

The equations are those of `flexure.core.mechanics.actuators` (the plain-numpy twin): an
input without an actuator puts its value u (N, N m) on its port; a current-driven one puts
F = Km sat(G u) there; a voltage-driven one F = Km i, with its coil current i (A) a state,

    di/dt = (sat(G u) - R i - Km v) / L,

v the port's velocity (`ports.port_velocity`: xdot of the coordinate, m/s, or the angular
velocity about the global axis of a moment port, rad/s) and sat a clip at +- the amplifier's
saturation (its derivative zero beyond it). The port turns its value into the generalised
force (`ports.add_input_forces`). The integrators' state is y = [q - q_ref, qdot, i]
(n = NDOF; the currents, one per voltage-driven actuator, at 2n ..). The packed model holds
per input its kind and current index (slot actuators) and Km, R, L, G, saturation (slot
actuator_data); `motion.evaluate` reads the currents of the state from slot currents, which
`set_currents` fills before it, and leaves the port values in slot port_values.

Tangent blocks (exact): d qddot / d i_k = M_bar^-1 DF^T b_j Km (qddot is linear in the port
value), d idot_k / d qdot = -Km / L b_j^T DF (v = b_j^T DF qdot), d idot_k / d i_k = -R / L,
with b_j the port's unit generalised force on the coordinates (a unit column on a coordinate,
2 E_k^T on the Euler parameters of a moment about axis k). The load stiffness of a moment port
takes its value Km i (`tangent`). Approximated: d idot_k / d q = -Km / L d(b_j^T DF qdot)/dq
is left out of the Newton matrix; it is zero when the port is a DOF coordinate (b_j^T DF a
unit row) or at rest.
"""

from ..numerics.dense import lu_solve, put
from ..numerics.jit import kernel
from . import data as ed
from . import slots as slot
from .ports import port_row, port_velocity
from .slots import float_array as _f
from .slots import int_array as _i


@kernel(inline="always")
def amplifier(coefficients, j, u):
    """sat(G u): the amplifier output (V or A) of input j for its drive signal u (V)."""
    s = coefficients[j * ed.A_WIDTH + ed.A_SATURATION]
    return min(max(coefficients[j * ed.A_WIDTH + ed.A_GAIN] * u, -s), s)


@kernel
def port_values(table):
    """The value each input puts on its port (N, N m): u, Km sat(G u) or Km i, at the held
    inputs and the currents in slot currents. Without actuators the held inputs themselves
    (slot inputs); with them slot port_values, filled here."""
    inputs, values = _f(table, slot.INPUTS), _f(table, slot.PORT_VALUES)
    if values.size == 0:
        return inputs
    kinds, coefficients = _i(table, slot.ACTUATORS), _f(table, slot.ACTUATOR_DATA)
    currents = _f(table, slot.CURRENTS)
    for j in range(inputs.size):
        kind = kinds[2 * j]
        if kind == ed.FORCE_INPUT:
            values[j] = inputs[j]
        elif kind == ed.CURRENT_DRIVE:
            values[j] = coefficients[j * ed.A_WIDTH + ed.A_KM] * amplifier(
                coefficients, j, inputs[j])
        else:
            values[j] = coefficients[j * ed.A_WIDTH + ed.A_KM] * currents[kinds[2 * j + 1]]
    return values


@kernel
def evaluated_port_values(table):
    """The port values (N, N m) of the last `port_values` (the last evaluation's)."""
    values = _f(table, slot.PORT_VALUES)
    return _f(table, slot.INPUTS) if values.size == 0 else values


@kernel
def set_currents(table, y, n):
    """The coil currents of the state y (at 2n ..) into slot currents."""
    currents = _f(table, slot.CURRENTS)
    for k in range(currents.size):
        currents[k] = y[2 * n + k]


@kernel
def current_rates(table, out, n):
    """di/dt (A/s) of every coil into out[2n + k] at the currents in slot currents and the
    coordinates x and velocities xdot of the last `evaluate`."""
    inputs, specs = _f(table, slot.INPUTS), _i(table, slot.INPUT_PORTS)
    kinds, coefficients = _i(table, slot.ACTUATORS), _f(table, slot.ACTUATOR_DATA)
    currents, x, xdot = _f(table, slot.CURRENTS), _f(table, slot.X), _f(table, slot.XDOT)
    for j in range(inputs.size):
        k = kinds[2 * j + 1]
        if kinds[2 * j] != ed.VOLTAGE_DRIVE:
            continue
        base = j * ed.A_WIDTH
        out[2 * n + k] = (amplifier(coefficients, j, inputs[j])
                          - coefficients[base + ed.A_R] * currents[k]
                          - coefficients[base + ed.A_KM] * port_velocity(specs, j, x, xdot)
                          ) / coefficients[base + ed.A_L]


@kernel
def current_residual(table, yp, res, n):
    """IDA's residual of the coils, res[2n + k] = yp[2n + k] - di_k/dt, after `evaluate`."""
    current_rates(table, res, n)
    for k in range(_f(table, slot.CURRENTS).size):
        res[2 * n + k] = yp[2 * n + k] - res[2 * n + k]


@kernel(inline="always")
def _coil(table, j, n, row):
    """The coil of voltage-driven input j after the tangent: (its index in the state y,
    Km (N/A), L (H), R (ohm)), and b_j^T DF, the port's velocity per qdot, into row (n,)."""
    kinds, coefficients = _i(table, slot.ACTUATORS), _f(table, slot.ACTUATOR_DATA)
    port_row(_i(table, slot.INPUT_PORTS), j, _f(table, slot.X), _f(table, slot.DF), n, row)
    base = j * ed.A_WIDTH
    return (2 * n + kinds[2 * j + 1], coefficients[base + ed.A_KM],
            coefficients[base + ed.A_L], coefficients[base + ed.A_R])


@kernel
def first_order_blocks(table, J, N, n, column_major):
    """The coils' blocks of d ydot / d y (N = 2n + currents; `_coil_blocks`)."""
    _coil_blocks(table, J, N, n, column_major, False, 0.0)


@kernel
def implicit_blocks(table, J, N, n, cj):
    """The coils' blocks of IDA's d res / d y + cj d res / d yp (column-major, N = 2n +
    currents; `_coil_blocks`)."""
    _coil_blocks(table, J, N, n, True, True, cj)


@kernel(inline="always")
def _coil_blocks(table, J, N, n, column_major, implicit, cj):
    """The coils' tangent blocks (the module's) in the integrators' Jacobian J (flat (N, N),
    N = 2n + currents, column-major or row-major) after the tangent (DF and the LU of M_bar
    current): those of d ydot / d y, or, `implicit`, of IDA's d res / d y + cj d res / d yp,
    whose rows are yp - ydot on the coils and M_bar (qddot_p - qddot) on the mechanics: the
    same blocks negated, the mechanical ones without M_bar^-1 (-Km DF^T b_j), and cj added
    on the coils' diagonal."""
    kinds = _i(table, slot.ACTUATORS)
    mass_lu, piv = _f(table, slot.MASS_LU), _i(table, slot.MASS_PIVOTS)
    column = _f(table, slot.REDUCED_FORCE)
    sign = -1.0 if implicit else 1.0
    for j in range(kinds.size // 2):
        if kinds[2 * j] != ed.VOLTAGE_DRIVE:
            continue
        state, km, inductance, resistance = _coil(table, j, n, column)
        for i in range(n):
            put(J, N, state, n + i, sign * (-km / inductance * column[i]), column_major)
            column[i] *= km
        if not implicit:
            lu_solve(mass_lu, n, piv, column)
        for i in range(n):
            put(J, N, n + i, state, sign * column[i], column_major)
        rate = -resistance / inductance
        put(J, N, state, state, cj - rate if implicit else rate, column_major)
