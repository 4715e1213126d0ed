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
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numba import carray

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
    call_get_long,
    call_get_real,
    call_reinit,
    call_solve,
    call_with_time,
)
from . import esdirk
from .esdirk import Esdirk
from .measuring import start_from_plant
from .status import STATUS_MESSAGES

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
        The plant, with an ESDIRK or CVODE method.
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
        The simulator's method is not ESDIRK or CVODE, a loop output is not a position,
        the reference or feedforward has the wrong number of columns, a quantum is not one
        positive finite number per loop, or the integration or a measurement fails (naming
        the time).
    """
    solver, plant, outputs, restart_needed, restart_kinematics = sim.hand_over()
    if not isinstance(solver, Esdirk):
        from .sundials import Cvode  # loaded only where CVODE runs (its compiled callbacks)

        if not isinstance(solver, Cvode):
            raise SimulationError("the compiled sampled loop drives CVODE or ESDIRK; use "
                                  "method 'esdirk', 'cvode-bdf' or 'cvode-adams'")
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
    # loop variables kept between chunks: [t, restart needed, kinematics restart needed]
    loop_state = np.array([sim.time, float(restart_needed), float(restart_kinematics)])
    held = np.array(sim.inputs, dtype=float)
    addresses = np.zeros(_ADDRESSES, dtype=np.int64)
    engine.connect(outputs, engine.OP_POSITIONS)  # `_measure`'s, on the outputs' packed model
    addresses[[_PLANT, _OUTPUT, _ENGINE]] = (plant.address, outputs.address,
                                             plant.int_array("dims")[ed.ENGINE])
    samples_of = _esdirk_samples if isinstance(solver, Esdirk) else _cvode_samples
    run = samples_of(sim, solver, plant, addresses, loop_state, held, loop)
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
        raise SimulationError(f"t = {loop_state[0]:.9g} s: outputs: {STATUS_MESSAGES[status]}")
    force[N] = force[N - 1]
    sim.take_back(loop_state[0], solver.y_array, held, restart_needed=loop_state[1] != 0.0,
                  wall=time.perf_counter() - start_time)
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


def _esdirk_samples(sim, solver, plant, addresses, loop_state, held, loop):
    """run(start, stop) -> flag: samples start .. stop - 1 on the one-step integrator."""
    scratch = np.zeros(2 * sim.ndof)

    def run(start, stop):
        return _loop_esdirk(addresses, loop_state, held, solver.memory, solver.flags,
                            solver.vectors, solver.J, solver.LU, solver.pivots, solver.atol,
                            *solver.tables, scratch, start, stop, *loop)

    return run


def _cvode_samples(sim, solver, plant, addresses, loop_state, held, loop):
    """run(start, stop) -> flag: samples start .. stop - 1 on CVODE, restarting it at every
    change of the held force; what it learns is handed back to the solver after each run."""
    for key, slot in (("solve", _SOLVE), ("reinit", _REINIT), ("stop", _STOP),
                      ("memory", _MEMORY), ("y", _Y), ("tret", _TRET),
                      ("init_step", _INIT_STEP), ("actual_init_step", _ACTUAL_INIT_STEP),
                      ("num_steps", _NUM_STEPS)):
        addresses[slot] = solver.addresses[key]
    addresses[_ANALYTIC] = int(solver.analytic)
    steps = np.zeros(2, dtype=np.int64)  # [steps before the restarts in the loop, scratch]
    # what the integrator keeps between restarts (sundials.Cvode.reset): [initial step,
    # Jacobian cached (0 or 1)]
    memory = np.array([solver.initial_step, float(solver.jacobian_cached())])
    scratch = np.zeros(2 * sim.ndof)

    def run(start, stop):
        jacobians = int(plant.int_array("counters")[ed.JACOBIAN_COUNT])
        flag = _loop(addresses, loop_state, memory, steps, held, solver.y_array, scratch, start,
                     stop, *loop)
        solver.add_steps(steps[0])
        steps[0] = 0
        solver.initial_step = memory[0]
        if plant.int_array("counters")[ed.JACOBIAN_COUNT] > jacobians:
            memory[1] = 1.0
        return flag

    return run


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


# the addresses handed to the compiled loop, in this order
(_SOLVE, _REINIT, _STOP, _MEMORY, _Y, _TRET, _PLANT, _OUTPUT, _ENGINE, _INIT_STEP,
 _ACTUAL_INIT_STEP, _NUM_STEPS, _ANALYTIC, _ADDRESSES) = range(14)
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
def _loop(addresses, loop_state, memory, steps, held, y, scratch, start, stop, fs, controller):
    """Samples start .. stop - 1 of the loop; 0, or CVODE's failure flag (or
    _MEASURE_FAILED) with loop_state[0] the time reached."""
    plant = addresses[_PLANT]
    plant_inputs, x_plant = access.inputs(plant), access.coordinates(plant)
    dims = access.dims(plant)
    tret = carray(as_float_pointer(addresses[_TRET]), (1,))
    t = loop_state[0]
    restart = loop_state[1] != 0.0
    for k in range(start, stop):
        changed = _sample(addresses, y, scratch, k, controller, held)
        if changed < 0:
            loop_state[0] = t
            return _MEASURE_FAILED
        if changed or restart:  # as Simulator.set_inputs and its restart in advance
            copy(plant_inputs, held)
            access.restart_kinematics(plant, x_plant)
            call_get_long(addresses[_NUM_STEPS], addresses[_MEMORY], steps[1:].ctypes.data)
            steps[0] += steps[1]
            flag = call_reinit(addresses[_REINIT], addresses[_MEMORY], t, addresses[_Y])
            if flag < 0:
                loop_state[0] = t
                return flag
            if memory[0] > 0.0:  # as sundials.Cvode.reset
                call_with_time(addresses[_INIT_STEP], addresses[_MEMORY], memory[0])
            if memory[1] != 0.0 and addresses[_ANALYTIC] != 0:
                dims[ed.JACOBIAN_REUSE] = 1
            restart = False
        t_next = (k + 1) / fs
        call_with_time(addresses[_STOP], addresses[_MEMORY], t_next)
        flag = call_solve(addresses[_SOLVE], addresses[_MEMORY], t_next, addresses[_Y],
                          addresses[_TRET], 1)
        if flag < 0:
            loop_state[0] = tret[0]
            loop_state[1] = 1.0
            return flag
        if memory[0] == 0.0:  # as sundials.Cvode.learn_initial_step
            call_get_real(addresses[_ACTUAL_INIT_STEP], addresses[_MEMORY], memory.ctypes.data)
        memory[1] = 1.0 if addresses[_ANALYTIC] != 0 else 0.0
        t = t_next
    loop_state[0] = t
    loop_state[1] = 1.0 if restart else 0.0
    return 0


@kernel
def _loop_esdirk(addresses, loop_state, held, memory, flags, vectors, J, LU, pivots, atol,
                 tableau_A, tableau_EW, tableau_P, scratch, start, stop, fs, controller):
    """Samples start .. stop - 1 of the loop on the one-step integrator; 0, or its failure
    status (or _MEASURE_FAILED) with loop_state[0] the time reached. Each change of the held
    force does what `Simulator.set_inputs` and the restart in `advance` do with it: the new
    inputs, the integrator's state re-entered (its first stage recomputed)."""
    plant = addresses[_PLANT]
    plant_inputs, x_plant = access.inputs(plant), access.coordinates(plant)
    counters = access.counters(plant)
    y = vectors[esdirk.V_Y]
    t = loop_state[0]
    for k in range(start, stop):
        changed = _sample(addresses, y, scratch, k, controller, held)
        if changed < 0:
            loop_state[0] = t
            return _MEASURE_FAILED
        if changed or loop_state[1] != 0.0:  # as Simulator._restart and Esdirk.reset
            copy(plant_inputs, held)
            # no state set since the last step (as Simulator._restart_kinematics): the first
            # stage from the last one and the engine's input response (Esdirk.reset)
            keep = (loop_state[2] == 0.0 and memory[esdirk.M_T] == t
                    and flags[esdirk.I_FSAL] != esdirk.FSAL_NONE)
            if loop_state[2] != 0.0:
                access.restart_kinematics(plant, x_plant)
                loop_state[2] = 0.0
            memory[esdirk.M_T] = t
            flags[esdirk.I_FSAL] = esdirk.FSAL_INPUTS if keep else esdirk.FSAL_NONE
            counters[ed.FAILED_STATUS] = 0
            loop_state[1] = 0.0
        t_next = (k + 1) / fs
        flags[esdirk.I_ONE_STEP] = flags[esdirk.I_MAX_STEPS] = 0  # to t_next, no budget
        status = esdirk.advance(plant, memory, flags, vectors, J, LU, pivots, atol, tableau_A,
                                tableau_EW, tableau_P, t_next)
        if status != esdirk.OK:
            loop_state[0] = memory[esdirk.M_T]
            loop_state[1] = loop_state[2] = 1.0
            return status
        t = t_next
    loop_state[0] = t
    return 0
