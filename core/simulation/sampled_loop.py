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
the last sample of the reference and feedforward arrays their last entries hold. A kinematic
input follows the simulator's path (slot motion_path: `Simulator(..., motion_duration=T)` or
`set_motion`, the scene's quintic; held where `stepwise_motion` put it): every evaluation of
the integrator reads it at its own time (`esdirk_newton.evaluate`, CVODE's right-hand side), as in
`Simulator.advance_to`; the motion is a known disturbance of the loop, its effort not a loop
input. After a run `Simulator.efforts` gives the efforts at t_N.

The plant is the Simulator's own integrator, driven exactly as `Simulator.set_inputs` plus
`advance` drive it, so this loop and a loop of Python calls give the same numbers, bit for bit;
the difference is that here the whole run is one compiled function, with the controller in
compiled code too. With the one-step ESDIRK (`flexure.core.simulation.esdirk`, the loop's
default) a changed force costs one evaluation and the integrator steps on with its step size and
Newton matrix; with CVODE it restarts at every changed force (its C functions called directly).
The loop borrows the integrator through `Simulator.held_input_drive` and restarts it through
the kernels `Simulator._restart` runs (`stepper.restart_plant`, `esdirk_kernels.restart`,
`sundials_restart.cvode_restart`); the methods it drives are those with `Method.compiled_loop`
(`methods.COMPILED_LOOP_METHODS`), each by the driver of its stepper's module (`DRIVERS`). The
compiled side, and the C entries through which this module runs it, are in
`sampled_loop_kernels`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..engine.ports import port_specs
from ..engine.status import status_message
from ..errors import SimulationError
from ..mechanics.ports import output_dofs
from .methods import COMPILED_LOOP_METHODS
from .sampled_control import FORCE, POSITION, controller_arrays, controller_step
from .sampled_loop_kernels import END_MEASURE, MEASURE_FAILED, loop_runner
from .sampled_measure import (
    ADDRESSES,
    ADVANCE,
    ENGINE,
    MEASURE,
    OUTPUT,
    PLANT,
    measure_entry,
)
from .sundials_restart import L_JACOBIAN

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
    N = int(samples)
    # the measured outputs, packed (engine.ports): a coordinate, or an angle about a global
    # axis; then the DOF each one is, or -1 (`sampled_loop_kernels.measure`)
    coordinates = np.concatenate([port_specs(ports).ravel(),
                                  output_dofs(sim.model, ports)])
    controller = controller_arrays(reference, feedforward, controller, loop_inputs,
                                   quantum=quantum, samples=N, coordinates=coordinates)
    position, force = controller[POSITION], controller[FORCE]
    n_loops = len(loop_inputs)
    loop = (float(fs), controller)
    with sim.held_input_drive() as drive:  # the simulator continues from where it ends
        solver, loop_state = drive.stepper, drive.loop_state
        addresses = np.zeros(ADDRESSES, dtype=np.int64)
        # `measure`'s, on the outputs' packed model: only where an output is not a DOF (a DOF
        # is read from the state; a first loop then compiles the measuring entry and the
        # positions' only where they are used)
        if np.any(coordinates[coordinates.size - n_loops:] < 0):
            engine.connect(drive.outputs, engine.OP_POSITIONS)
            addresses[MEASURE] = measure_entry.address
        addresses[[PLANT, OUTPUT, ENGINE]] = (drive.plant.address, drive.outputs.address,
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
        # y_N was measured after the last sample; the simulator stays at t_N with the last
        # force held
        force[N] = force[N - 1]
        drive.wall = time.perf_counter() - start_time
    return np.arange(N + 1) / fs, position, force


def _esdirk_samples(sim, solver, addresses, loop_state, held, loop):
    """run(start, stop) -> flag: samples start .. stop - 1 on the one-step integrator."""
    scratch = np.zeros(2 * sim.ndof)

    addresses[ADVANCE] = solver.advance_entry.address

    fs, controller = loop
    run_samples = loop_runner("esdirk", controller, (
        addresses, loop_state, held, solver.memory, solver.flags, solver.vectors,
        solver.arguments, scratch))

    def run(start, stop):
        return run_samples(start, stop, fs)

    return run


def _cvode_samples(sim, solver, addresses, loop_state, held, loop):
    """run(start, stop) -> flag: samples start .. stop - 1 on CVODE, restarting it at every
    change of the held force (`sundials_restart.cvode_restart`, with what the solver has learnt in
    its own arrays)."""
    # whether a Jacobian is kept for the next restart (sundials.Cvode.reset)
    solver.learnt[L_JACOBIAN] = float(solver.jacobian_cached())
    scratch = np.zeros(2 * sim.ndof)
    fs, controller = loop
    run_samples = loop_runner("sundials", controller, (
        addresses, solver.address_table, loop_state, solver.learnt, solver.totals, held,
        solver.y_array, scratch))

    def run(start, stop):
        jacobians = int(sim.data.int_array("counters")[ed.JACOBIAN_COUNT])
        flag = run_samples(start, stop, fs)
        if sim.data.int_array("counters")[ed.JACOBIAN_COUNT] > jacobians:
            solver.learnt[L_JACOBIAN] = 1.0
        return flag

    return run


# The compiled drivers by the module of the stepper they drive (`Method.module`); each
# makes run(start, stop) -> flag for samples start .. stop - 1
DRIVERS = {"esdirk": _esdirk_samples, "sundials": _cvode_samples}


def _failure(sim, solver, flag, t):
    if flag <= END_MEASURE:
        return SimulationError(f"t = {t:.9g} s: outputs: {status_message(END_MEASURE - flag)}")
    if flag == MEASURE_FAILED:
        return SimulationError(f"t = {t:.9g} s: outputs: the kinematics of the measured "
                               "positions could not be solved")
    error = solver.failure(flag, t)
    return SimulationError(f"simulation of {sim.model.name!r} in the sampled loop: {error}")




__all__ = ["DRIVERS", "controller_step", "run_sampled_loop"]
