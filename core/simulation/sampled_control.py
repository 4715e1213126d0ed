"""The controller's side of a compiled sampled loop: the discrete controller's step and one
sample's control (the error, the next force, the held plant inputs), compiled.

Every compiled loop measures its plant its own way (the nonlinear plant by its kinematics,
`sampled_loop_kernels.measure`; the linearised one by its output rows, `linear_loop_kernels`)
and then calls `control_sample`, so every plant sees the same forces from the same
measurements. The Python loop (`controllers/sample_loop.py`'s `simulate_loop`) steps the
controller through `controller_step` too. `controller_arrays` packs what `control_sample`
reads and writes; `controller_table` reads it back from a C entry's table. No numba or
engine module is imported here.
"""

import numpy as np

from ..errors import SimulationError
from ..numerics.array_tables import floats, floats2d, ints
from ..numerics.dense import copy
from ..numerics.jit import kernel

# the controller's arrays, in the order `control_sample` unpacks them, and their kinds in a C
# entry's table (numerics.array_tables): reference .. output
CONTROLLER_KINDS = "FFFFFFfiifFFfff"
POSITION, FORCE = 10, 11  # where the run's samples are, (N+1, n_loops) each


@kernel(inline="always")
def _state_space_row(P, Q, state, error, i):
    """Row i of P x + Q e: the two dot products each summed in index order, then added."""
    s = 0.0
    for j in range(P.shape[1]):
        s += P[i, j] * state[j]
    d = 0.0
    for j in range(Q.shape[1]):
        d += Q[i, j] * error[j]
    return s + d


@kernel
def controller_step(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray,
                    state: np.ndarray, error: np.ndarray, output: np.ndarray,
                    new_state: np.ndarray) -> None:
    """One sample of a discrete linear controller: output = C x + D e, then x <- A x + B e.

    Compiled (numba); the sums run in index order, so every caller gets the same numbers.
    Allocates nothing: A x + B e goes through the caller's `new_state` before it replaces x.

    Parameters
    ----------
    A, B, C, D : ndarray, 2-D, float64
        The controller's matrices: (s, s), (s, n), (m, s), (m, n).
    state : ndarray (s,), float64
        x, updated in place.
    error : ndarray (n,), float64
        e, in the loops' output units (m, rad).
    output : ndarray (m,), float64
        Receives u, in the loops' input units (N, N m, V).
    new_state : ndarray (s,), float64
        Scratch: receives A x + B e, then copied into `state`.
    """
    for i in range(C.shape[0]):
        output[i] = _state_space_row(C, D, state, error, i)
    for i in range(A.shape[0]):
        new_state[i] = _state_space_row(A, B, state, error, i)
    copy(state, new_state)


@kernel(inline="always")  # into the loop of the plant in use, its one caller
def control_sample(k, controller, held):
    """Sample k after y_k was measured into position[k]: u_k+1 = C x_c + D e_k + u_ff,k+1
    (the controller state stepped; e_k of y_k rounded to its quantum where quanta > 0), and
    u_k into the held plant inputs (the others zero) for [t_k, t_k+1).
    Returns 1 when the held inputs changed, 0 when not.
    controller: (reference, feedforward, A, B, C, D, state, inputs, coordinates, quanta,
    position, force, error, output, new_state) as `run_sampled_loop` packs it, error and
    output scratch (n_loops,), new_state scratch (s,); coordinates are the nonlinear plant's
    (unread here)."""
    (reference, feedforward, A, B, C, D, state, inputs, _, quanta, position, force,
     error, output, new_state) = controller
    n_loops = inputs.size
    if k == 0:  # element by element: a slice assignment compiles numba's shape-error message
        for i in range(n_loops):
            force[0, i] = feedforward[0, i]
    r = reference[min(k, reference.shape[0] - 1)]
    ff = feedforward[min(k + 1, feedforward.shape[0] - 1)]
    for i in range(n_loops):
        measured = position[k, i]
        if quanta[i] > 0.0:  # as numpy's q * round(y / q): rint rounds halves to even
            measured = quanta[i] * np.rint(measured / quanta[i])
        error[i] = r[i] - measured
    controller_step(A, B, C, D, state, error, output, new_state)
    for i in range(n_loops):
        force[k + 1, i] = output[i] + ff[i]
    changed = 0
    for j in range(held.size):
        value = 0.0
        for i in range(n_loops):
            if inputs[i] == j:
                value = force[k, i]
        if value != held[j]:
            changed = 1
            held[j] = value
    return changed


def controller_arrays(reference, feedforward, controller, loop_inputs, *, quantum, samples,
                      coordinates):
    """What `control_sample` reads and writes, checked and packed: (reference, feedforward,
    A, B, C, D, state, inputs, coordinates, quanta, position, force, error, output,
    new_state), the positions (m, rad) and forces (N, N m, V) zeros of (samples + 1,
    n_loops), the controller's state zero; the last three scratch, allocated once per run.

    Parameters
    ----------
    reference, feedforward : array_like (>= 1, n_loops)
        r_k (m, rad) and u_ff,k (N, N m, V) per sample (the last row holds past the end).
    controller : tuple of array_like (A, B, C, D)
        The discrete controller from errors to forces.
    loop_inputs : sequence of int
        The plant input each loop drives.
    quantum : array_like (n_loops,) or None
        The encoders' quanta (m, rad; > 0), or None for exact measurements.
    samples : int
        N.
    coordinates : ndarray of int64
        The plant's own description of the outputs it measures (unread by the controller).

    Raises
    ------
    SimulationError
        The reference or feedforward has the wrong number of columns, or a quantum is not
        one positive finite number per loop.
    """
    A, B, C, D = (np.ascontiguousarray(np.atleast_2d(np.asarray(m, float))) for m in controller)
    reference = np.ascontiguousarray(reference, dtype=float)
    feedforward = np.ascontiguousarray(feedforward, dtype=float)
    n_loops = len(loop_inputs)
    if reference.shape[1] != n_loops or feedforward.shape[1] != n_loops:
        raise SimulationError(f"reference and feedforward: expected {n_loops} columns, got "
                              f"{reference.shape[1]} and {feedforward.shape[1]}")
    position = np.zeros((samples + 1, n_loops))
    force = np.zeros((samples + 1, n_loops))
    # the last three are scratch: the errors and the controller's outputs (n_loops,), its
    # next state (s,)
    return (reference, feedforward, A, B, C, D, np.zeros(A.shape[0]),
            np.array(loop_inputs, dtype=np.int64), np.ascontiguousarray(coordinates),
            _quanta(quantum, n_loops), position, force, np.empty(n_loops), np.empty(n_loops),
            np.empty(A.shape[0]))


def _quanta(quantum, n_loops):
    """The quanta (n_loops,) the kernels take: q > 0 per loop, or zeros for exact ones."""
    if quantum is None:
        return np.zeros(n_loops)
    try:
        quanta = np.asarray(quantum, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        quanta = np.full(0, np.nan)
    if quanta.shape != (n_loops,) or not np.all(np.isfinite(quanta) & (quanta > 0)):
        raise SimulationError(f"quantum: expected {n_loops} positive finite values (m, rad), "
                              f"one per loop, got {quantum!r}")
    return np.ascontiguousarray(quanta)


@kernel(inline="always")
def controller_table(table):
    """The controller's arrays from the first entries of a C entry's table (CONTROLLER_KINDS),
    as `controller_arrays` packed them."""
    return (floats2d(table, 0), floats2d(table, 1), floats2d(table, 2), floats2d(table, 3),
            floats2d(table, 4), floats2d(table, 5), floats(table, 6), ints(table, 7),
            ints(table, 8), floats(table, 9), floats2d(table, 10), floats2d(table, 11),
            floats(table, 12), floats(table, 13), floats(table, 14))
