"""The compiled side of the linear loop (`linear_loop`): the linearised plant's step in real
modal coordinates, the loop over samples, and the C entry through which Python runs it (a
process that loads the compiled code from the cache runs the loop without numba).

The plant (`linear_loop.RealModes` packs it), with du = u - u0 held over the step of h:

- one mode of each conjugate pair of eigenvalues, w_i = a_i + j b_i (its conjugate's
  coordinate is the conjugate), with e^(lambda_i h) = p_i + j q_i and the inputs' factor
  g_i = g_i' + j g_i'' (a row):

      a_i <- (p_i a_i - q_i b_i) + g_i' du        b_i <- (q_i a_i + p_i b_i) + g_i'' du

- a real eigenvalue's mode, w_i <- d_i w_i + g_i du;
- the modes a step forgets (d = 0): their part of y is a matrix F times du;

      y = (y_c + sum_pairs (c_i' a_i + c_i'' b_i) + sum_reals c_i w_i) + (D + F) du

(c_i' = 2 Re(C V)_i and c_i'' = -2 Im(C V)_i for a pair, whose conjugate's part of
Re(C V w) is the same again), every sum in index order: the same numbers on every CPU.
"""

import numpy as np

from ..numerics.array_tables import array_table, floats, floats2d
from ..numerics.jit import entry, kernel
from ..numerics.native import as_int_pointer, carray
from .sampled_control import CONTROLLER_KINDS, POSITION, control_sample, controller_table

OVERFLOW = -1  # the state is no longer finite: loop_state[0] is the sample it left from


@kernel(inline="always")
def modal_step(pairs, reals, du, sums):
    """One step of the real modal form (see the module): the new states into the groups'
    new_state arrays, the outputs' sums over the modes into sums (n_outputs,). Returns the
    sum of the new states' entries: not finite when any is not.
    pairs: (rotation, drive, readout, state, new_state); reals: (decay, drive, readout,
    state, new_state), as `RealModes` packs them."""
    n_inputs, n_outputs = du.size, sums.size
    for o in range(n_outputs):
        sums[o] = 0.0
    total = 0.0
    rotation, drive, readout, state, new_state = pairs
    for i in range(state.shape[0]):
        a, b = state[i, 0], state[i, 1]
        p, q = rotation[i, 0], rotation[i, 1]
        forced_a = 0.0
        forced_b = 0.0
        for j in range(n_inputs):
            forced_a += drive[i, j] * du[j]
            forced_b += drive[i, n_inputs + j] * du[j]
        a_new = (p * a - q * b) + forced_a
        b_new = (q * a + p * b) + forced_b
        new_state[i, 0] = a_new
        new_state[i, 1] = b_new
        total += a_new + b_new
        for o in range(n_outputs):
            sums[o] += readout[i, o] * a_new + readout[i, n_outputs + o] * b_new
    decay, drive, readout, state, new_state = reals
    for i in range(state.size):
        forced = 0.0
        for j in range(n_inputs):
            forced += drive[i, j] * du[j]
        w_new = decay[i] * state[i] + forced
        new_state[i] = w_new
        total += w_new
        for o in range(n_outputs):
            sums[o] += readout[i, o] * w_new
    return total


@kernel(inline="always")  # into its C entry, its one caller: one compilation unit
def loop_linear(plant, loop_state, held, start, stop, controller):
    """Samples start .. stop - 1 of the loop on the real modal form: y_k is in position[k]
    (the caller measured y_0), the controller's sample (`control_sample`), then the step to
    t_k+1 and y_k+1 into position[k+1]. 0, or OVERFLOW with loop_state[0] = k (the states
    kept at t_k). plant: (u0, the pairs' rotation, drive, readout, state, new_state, the
    reals' decay, drive, readout, state, new_state, du, sums, constant, direct) as
    `linear_loop` packs it."""
    u0, du, sums, constant, direct = plant[0], plant[11], plant[12], plant[13], plant[14]
    pairs, reals = plant[1:6], plant[6:11]
    position = controller[POSITION]
    for k in range(start, stop):
        control_sample(k, controller, held)
        for j in range(du.size):
            du[j] = held[j] - u0[j]
        total = modal_step(pairs, reals, du, sums)
        if not np.isfinite(total):
            loop_state[0] = k
            return OVERFLOW
        pair_state, pair_new, real_state, real_new = pairs[3], pairs[4], reals[3], reals[4]
        for i in range(pair_state.shape[0]):
            pair_state[i, 0] = pair_new[i, 0]
            pair_state[i, 1] = pair_new[i, 1]
        for i in range(real_state.size):
            real_state[i] = real_new[i]
        for o in range(sums.size):
            direct_part = 0.0
            for j in range(du.size):
                direct_part += direct[o, j] * du[j]
            position[k + 1, o] = (constant[o] + sums[o]) + direct_part
    loop_state[0] = stop
    return 0


# the plant's arrays in a C entry's table, after the controller's (CONTROLLER_KINDS): u0;
# the pairs' rotation, drive, readout, state, new_state; the reals' decay, drive, readout,
# state, new_state; du, sums, constant, direct; then loop_state and held
LINEAR_KINDS = "fFFFFFfFFfffffFff"
_N = len(CONTROLLER_KINDS)


@entry("int32(voidptr, int64, int64)")
def _linear_entry(address, start, stop):
    """`loop_linear` on the arrays of the table at `address` (CONTROLLER_KINDS, then
    LINEAR_KINDS)."""
    table = carray(as_int_pointer(address), (3 * (_N + len(LINEAR_KINDS)),))
    controller = controller_table(table)
    plant = (floats(table, _N), floats2d(table, _N + 1), floats2d(table, _N + 2),
             floats2d(table, _N + 3), floats2d(table, _N + 4), floats2d(table, _N + 5),
             floats(table, _N + 6), floats2d(table, _N + 7), floats2d(table, _N + 8),
             floats(table, _N + 9), floats(table, _N + 10), floats(table, _N + 11),
             floats(table, _N + 12), floats(table, _N + 13), floats2d(table, _N + 14))
    return loop_linear(plant, floats(table, _N + 15), floats(table, _N + 16), start, stop,
                       controller)


def prepare_linear_loop():
    """Load (or compile, on first use) the loop's C entry now, outside a timed run."""
    return _linear_entry.address


def linear_loop_runner(controller, plant, loop_state, held):
    """run(start, stop) -> flag: samples start .. stop - 1 of `loop_linear` through its C
    entry, on the controller's arrays (`sampled_control.controller_arrays`), the plant's
    (LINEAR_KINDS' first fifteen), loop_state (1,) and held (n_inputs,)."""
    kept = (*controller, *plant, loop_state, held)  # the table points into them
    table = array_table(kept, CONTROLLER_KINDS + LINEAR_KINDS)
    address = table.ctypes.data
    function = _linear_entry.ctypes

    def run(start, stop, _keep=(kept, table)):
        return function(address, start, stop)

    return run
