"""A sampled feedback loop around a Simulator, compiled: no Python call per sample.

At the samples t_k = k / fs (k = 0 .. N), with y_k the loop outputs (positions, m) measured at
t_k, r_k the reference and x_c the state of a discrete linear controller (A, B, C, D):

    e_k   = r_k - y_k                    (or r_k - q round(y_k / q), an encoder's quantum q)
    u_k+1 = C x_c + D e_k + u_ff,k+1,    x_c <- A x_c + B e_k      (computed at t_k)
    plant: u_k held over [t_k, t_k+1)                            (zero-order hold)

so the force acts one sample after the measurement it comes from (one sample of computation
delay, as in a real-time controller and in a co-simulation master), and u_0 = u_ff,0. With a
quantum (m, rad) the controller sees each measured output rounded to the nearest multiple of
it, halves to even (numpy's `round`: q * rint(y / q), the same two roundings of IEEE
arithmetic whoever computes them); the positions returned stay the true y_k. Any other
additive input, e.g. a disturbance force, rides on u_ff: it is known per sample. An
input that a voice-coil actuator drives (`flexure.core.mechanics.actuators`) takes u_k as its
drive signal (V), held likewise; its coil current is part of the integrator's state. Past
the last sample of the reference and feedforward arrays their last entries hold.

The plant is the Simulator's own integrator, driven exactly as `Simulator.set_inputs` plus
`advance` drive it, so this loop and a loop of Python calls give the same numbers, bit for bit;
the difference is that here the whole run is one compiled function, with the controller in
compiled code too. With the one-step ESDIRK (`flexure.core.simulation.esdirk`, the loop's
default) a changed force costs one evaluation and the integrator steps on with its step size and
Newton matrix; with CVODE it restarts at every changed force (its C functions called directly).
The loop borrows the integrator through `Simulator.held_input_drive` and restarts it through
the kernels `Simulator._restart` runs (`stepper.restart_plant`, `esdirk.restart`,
`sundials_restart.cvode_restart`); the methods it drives are those with `Method.compiled_loop`
(`methods.COMPILED_LOOP_METHODS`), each by the driver of its stepper's module (`DRIVERS`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..engine import access, engine
from ..engine import data as ed
from ..engine.ports import port_specs, position_value
from ..errors import SimulationError
from ..mechanics.ports import output_dofs
from ..numerics.dense import copy
from ..numerics.jit import kernel
from ..numerics.native import (
    as_float_pointer,
    call_engine,
    call_get_real,
    call_solve,
    call_stepper,
    call_with_time,
    carray,
)
from . import esdirk
from .measuring import start_from_plant
from .methods import COMPILED_LOOP_METHODS
from .status import STATUS_MESSAGES
from .stepper import restart_plant
from .sundials_restart import (
    A_ACTUAL_INIT_STEP,
    A_ANALYTIC,
    A_MEMORY,
    A_SOLVE,
    A_STOP,
    A_TRET,
    A_Y,
    L_INITIAL_STEP,
    L_JACOBIAN,
    cvode_restart,
)

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from .simulator import Simulator


def run_sampled_loop(sim: Simulator, *, fs: float, samples: int, reference: ArrayLike,
                     feedforward: ArrayLike,
                     controller: tuple[ArrayLike, ArrayLike, ArrayLike, ArrayLike],
                     loop_inputs: Sequence[int], loop_outputs: Sequence[int],
                     quantum: ArrayLike | None = None,
                     progress: Callable[[float], None] | None = None,
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the loop from the simulator's current state (t = 0 after `reset`).

    Parameters
    ----------
    sim : Simulator
        The plant, with a method of `methods.COMPILED_LOOP_METHODS` (ESDIRK or CVODE).
    fs : float
        Sample rate (Hz).
    samples : int
        The number of intervals N; the run ends at t_N = N / fs.
    reference, feedforward : array_like (>= 1, n_loops)
        r_k (m) and u_ff,k (N, or V for an actuator's drive signal) per sample (the last row
        holds past the end).
    controller : tuple of array_like (A, B, C, D)
        The discrete controller from errors (m) to forces (N) or drive signals (V): A (s, s),
        B (s, n_loops), C (n_loops, s), D (n_loops, n_loops).
    loop_inputs, loop_outputs : sequences of int
        The model input driven by each loop, and the model output (a position, or an angle
        about a global axis) it measures.
    quantum : array_like (n_loops,), optional
        Each loop's encoder quantum q (m, rad; > 0): the controller's error is
        r_k - q rint(y_k / q). Default: exact measurements.
    progress : callable, optional
        Called with the fraction of samples done, about 100 times.

    Returns
    -------
    t : ndarray (N+1,)
        The sample times, s.
    position : ndarray (N+1, n_loops)
        y_k, m (rad for an angle).
    force : ndarray (N+1, n_loops)
        u_k held from t_k, N (N m, or V for a drive signal); the last row repeats the one
        before.

    Raises
    ------
    SimulationError
        The simulator's method is not one the loop drives, a loop output is not a position,
        the reference or feedforward has the wrong number of columns, a quantum is not one
        positive finite number per loop, or the integration or a measurement fails (naming
        the time).
    """
    if not sim.integrator.method.compiled_loop:
        raise SimulationError(f"the compiled sampled loop does not drive method "
                              f"{sim.method!r}; use one of {', '.join(COMPILED_LOOP_METHODS)}")
    ports = [sim.model.outputs[j] for j in loop_outputs]
    if any(port.quantity != "position" for port in ports):
        raise SimulationError("the compiled sampled loop measures positions only")
    A, B, C, D = (np.ascontiguousarray(np.atleast_2d(np.asarray(m, float))) for m in controller)
    reference = np.ascontiguousarray(reference, dtype=float)
    feedforward = np.ascontiguousarray(feedforward, dtype=float)
    n_loops = len(loop_inputs)
    if reference.shape[1] != n_loops or feedforward.shape[1] != n_loops:
        raise SimulationError(f"reference and feedforward: expected {n_loops} columns, got "
                              f"{reference.shape[1]} and {feedforward.shape[1]}")
    quanta = _quanta(quantum, n_loops)
    N = int(samples)
    position = np.zeros((N + 1, n_loops))
    force = np.zeros((N + 1, n_loops))
    # the measured outputs, packed (engine.ports): a coordinate, or an angle about a global
    # axis; then the DOF each one is, or -1 (`_measure`)
    coordinates = np.concatenate([port_specs(ports).ravel(),
                                  output_dofs(sim.model, ports)])
    # what `_sample` reads and writes, one tuple that the integrators' loops hand on; the
    # last two are its scratch (n_loops,): the errors and the controller's outputs
    controller = (reference, feedforward, A, B, C, D, np.zeros(A.shape[0]),
                  np.array(loop_inputs, dtype=np.int64), coordinates, quanta, position, force,
                  np.empty(n_loops), np.empty(n_loops))
    loop = (float(fs), controller)
    with sim.held_input_drive() as drive:  # the simulator continues from where it ends
        solver, loop_state = drive.stepper, drive.loop_state
        addresses = np.zeros(_ADDRESSES, dtype=np.int64)
        # `_measure`'s, on the outputs' packed model
        engine.connect(drive.outputs, engine.OP_POSITIONS)
        addresses[[_PLANT, _OUTPUT, _ENGINE]] = (drive.plant.address, drive.outputs.address,
                                                 drive.plant.int_array("dims")[ed.ENGINE])
        run = DRIVERS[solver.method.module](sim, solver, addresses, loop_state, drive.held, loop)
        chunk = max(1, N // 100 if progress is not None else N)
        start_time = time.perf_counter()
        for done in range(0, N, chunk):  # in chunks of samples, for the progress report
            stop = min(N, done + chunk)
            flag = run(done, stop)
            if flag != 0:
                raise _failure(sim, solver, flag, loop_state[0])
            if progress is not None:
                progress(stop / N)
        # measure y_N and leave the simulator at t_N with the last force held
        status = _measure(addresses, solver.y_array, np.zeros(2 * sim.ndof), coordinates,
                          position[N])
        if status != ed.OK:
            raise SimulationError(f"t = {loop_state[0]:.9g} s: outputs: "
                                  f"{STATUS_MESSAGES[status]}")
        force[N] = force[N - 1]
        drive.wall = time.perf_counter() - start_time
    return np.arange(N + 1) / fs, position, force


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


def _esdirk_samples(sim, solver, addresses, loop_state, held, loop):
    """run(start, stop) -> flag: samples start .. stop - 1 on the one-step integrator."""
    scratch = np.zeros(2 * sim.ndof)

    addresses[_ADVANCE] = solver.advance_entry.address

    def run(start, stop):
        return _loop_esdirk(addresses, loop_state, held, solver.memory, solver.flags,
                            solver.vectors, solver.arguments, scratch, start, stop, *loop)

    return run


def _cvode_samples(sim, solver, addresses, loop_state, held, loop):
    """run(start, stop) -> flag: samples start .. stop - 1 on CVODE, restarting it at every
    change of the held force (`sundials_restart.cvode_restart`, with what the solver has learnt in
    its own arrays)."""
    # whether a Jacobian is kept for the next restart (sundials.Cvode.reset)
    solver.learnt[L_JACOBIAN] = float(solver.jacobian_cached())
    scratch = np.zeros(2 * sim.ndof)

    def run(start, stop):
        jacobians = int(sim.data.int_array("counters")[ed.JACOBIAN_COUNT])
        flag = _loop(addresses, solver.address_table, loop_state, solver.learnt, solver.totals,
                     held, solver.y_array, scratch, start, stop, *loop)
        if sim.data.int_array("counters")[ed.JACOBIAN_COUNT] > jacobians:
            solver.learnt[L_JACOBIAN] = 1.0
        return flag

    return run


# The compiled drivers by the module of the stepper they drive (`Method.module`); each
# makes run(start, stop) -> flag for samples start .. stop - 1
DRIVERS = {"esdirk": _esdirk_samples, "sundials": _cvode_samples}


def _failure(sim, solver, flag, t):
    if flag == _MEASURE_FAILED:
        return SimulationError(f"t = {t:.9g} s: outputs: the kinematics of the measured "
                               "positions could not be solved")
    error = solver.failure(flag, t)
    return SimulationError(f"simulation of {sim.model.name!r} in the sampled loop: {error}")


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
                    state: np.ndarray, error: np.ndarray, output: np.ndarray) -> None:
    """One sample of a discrete linear controller: output = C x + D e, then x <- A x + B e.

    Compiled (numba); the sums run in index order, so every caller gets the same numbers.

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
    """
    for i in range(C.shape[0]):
        output[i] = _state_space_row(C, D, state, error, i)
    new_state = np.empty(A.shape[0])
    for i in range(A.shape[0]):
        new_state[i] = _state_space_row(A, B, state, error, i)
    copy(state, new_state)


# the addresses handed to the compiled loop, in this order (CVODE's own are in its
# `address_table`, sundials_restart.A_...)
(_PLANT, _OUTPUT, _ENGINE, _ADVANCE, _ADDRESSES) = range(5)
_MEASURE_FAILED = -1000


@kernel
def _measure(addresses, y, scratch, coordinates, out):
    """The loop outputs (positions, m; angles, rad) at the integrator state y into out; a
    status. As `Simulator.outputs`: q_ref + y at the DOFs when every output is a coordinate
    DOF, else Newton from the plant's last coordinates moved to y (`measuring`).
    coordinates: the outputs' packed rows (`engine.ports.port_specs`, flat), then the DOF of
    each output or -1 (`mechanics.ports.output_dofs`)."""
    q_ref = access.reference_dofs(addresses[_PLANT])
    dofs = coordinates[coordinates.size - out.size:]
    if np.all(dofs >= 0):
        for j in range(out.size):
            out[j] = q_ref[dofs[j]] + y[dofs[j]]
        return ed.OK
    ndof = access.dims(addresses[_PLANT])[ed.NDOF]  # y: [.., coil currents]
    access.restart_kinematics(addresses[_OUTPUT], access.coordinates(addresses[_PLANT]))
    for j in range(ndof):
        scratch[j] = q_ref[j] + y[j]
    start_from_plant(addresses[_PLANT], addresses[_OUTPUT], scratch)
    status = call_engine(addresses[_ENGINE], engine.OP_POSITIONS, addresses[_OUTPUT], 0.0,
                         scratch.ctypes.data, 0, 0, 0.0)
    if status != ed.OK:
        return status
    x = access.coordinates(addresses[_OUTPUT])
    for j in range(out.size):
        out[j] = position_value(coordinates, j, x)
    return ed.OK


@kernel(inline="always")  # into the loop of the integrator in use, its one caller
def _sample(addresses, y, scratch, k, controller, held):
    """Sample k: measure y_k, compute u_k+1 = C x_c + D e_k + u_ff,k+1 (the controller state
    stepped; e_k of y_k rounded to its quantum where quanta > 0), and put u_k into the held
    plant inputs (the others zero) for [t_k, t_k+1).
    Returns 1 when the held inputs changed, 0 when not, -1 when y_k could not be measured.
    controller: (reference, feedforward, A, B, C, D, state, inputs, coordinates, quanta,
    position, force, error, output) as `run_sampled_loop` packs it, error and output scratch
    (n_loops,)."""
    (reference, feedforward, A, B, C, D, state, inputs, coordinates, quanta, position, force,
     error, output) = controller
    if _measure(addresses, y, scratch, coordinates, position[k]) != ed.OK:
        return -1
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
    controller_step(A, B, C, D, state, error, output)
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


@kernel
def _loop(addresses, cvode, loop_state, learnt, totals, held, y, scratch, start, stop, fs,
          controller):
    """Samples start .. stop - 1 of the loop on CVODE (`cvode`: its `address_table`; learnt
    and totals: its arrays); 0, or CVODE's failure flag (or _MEASURE_FAILED) with
    loop_state[0] the time reached. Each change of the held force restarts it as
    `Simulator._restart` does, through the same kernels."""
    plant = addresses[_PLANT]
    x_plant = access.coordinates(plant)
    memory = cvode[A_MEMORY]
    tret = carray(as_float_pointer(cvode[A_TRET]), (1,))
    t = loop_state[0]
    restart = loop_state[1] != 0.0
    for k in range(start, stop):
        changed = _sample(addresses, y, scratch, k, controller, held)
        if changed < 0:
            loop_state[0] = t
            return _MEASURE_FAILED
        if changed or restart:  # as Simulator.set_inputs and its restart in advance
            restart_plant(plant, held, x_plant, True)
            flag = cvode_restart(cvode, learnt, totals, t)
            if flag < 0:
                loop_state[0] = t
                return flag
            restart = False
        t_next = (k + 1) / fs
        call_with_time(cvode[A_STOP], memory, t_next)
        flag = call_solve(cvode[A_SOLVE], memory, t_next, cvode[A_Y],
                          cvode[A_TRET], 1)
        if flag < 0:
            loop_state[0] = tret[0]
            loop_state[1] = 1.0
            return flag
        if learnt[L_INITIAL_STEP] == 0.0:  # as sundials.Cvode.learn_initial_step
            call_get_real(cvode[A_ACTUAL_INIT_STEP], memory, learnt.ctypes.data)
        learnt[L_JACOBIAN] = 1.0 if cvode[A_ANALYTIC] != 0 else 0.0
        t = t_next
    loop_state[0] = t
    loop_state[1] = 1.0 if restart else 0.0
    return 0


@kernel
def _loop_esdirk(addresses, loop_state, held, memory, flags, vectors, arguments, scratch,
                 start, stop, fs, controller):
    """Samples start .. stop - 1 of the loop on the one-step integrator; 0, or its failure
    status (or _MEASURE_FAILED) with loop_state[0] the time reached. Each change of the held
    force does what `Simulator.set_inputs` and the restart in `advance` do with it: the new
    inputs, the integrator's state re-entered (its first stage recomputed). The integrator
    steps through its C entry (`esdirk_entry`: at addresses[_ADVANCE], with the stepper's
    `arguments`), not a linked copy of `esdirk.advance`."""
    plant = addresses[_PLANT]
    x_plant = access.coordinates(plant)
    y = vectors[esdirk.V_Y]
    t = loop_state[0]
    for k in range(start, stop):
        changed = _sample(addresses, y, scratch, k, controller, held)
        if changed < 0:
            loop_state[0] = t
            return _MEASURE_FAILED
        if changed or loop_state[1] != 0.0:  # as Simulator._restart, through its kernels
            # no state set since the last step (as Simulator._restart_kinematics): the first
            # stage from the last one and the engine's input response (esdirk.restart)
            inputs_only = loop_state[2] == 0.0
            restart_plant(plant, held, x_plant, not inputs_only)
            esdirk.restart(plant, memory, flags, t, inputs_only)
            loop_state[1] = loop_state[2] = 0.0
        t_next = (k + 1) / fs
        flags[esdirk.I_ONE_STEP] = flags[esdirk.I_MAX_STEPS] = 0  # to t_next, no budget
        status = call_stepper(addresses[_ADVANCE], arguments.ctypes.data, t_next)
        if status != esdirk.OK:
            loop_state[0] = memory[esdirk.M_T]
            loop_state[1] = loop_state[2] = 1.0
            return status
        t = t_next
    loop_state[0] = t
    return 0
