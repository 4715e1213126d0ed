"""A sampled feedback loop around a `LinearSimulator`, compiled: no Python call per sample.

The loop of `sampled_loop` (the same samples, controller, quantum and timing: the controller's
side is the same compiled `sampled_control.control_sample`) on the linearised plant, stepped
exactly with the inputs held over each sample as `LinearSimulator.advance_to` steps it, in its
modal form. The compiled step works in real arithmetic: a real matrix's complex eigenvalues
come in conjugate pairs with conjugate modal coordinates (the state z is real), so one
coordinate of each pair, its real and imaginary parts, carries both; a real eigenvalue's
coordinate is one real number; the modes a step forgets (e^(lambda h) = 0) are one matrix on
the inputs (`RealModes`; the step in `linear_loop_kernels`); and only the output rows the
loop reads are kept. Per sample: the controller's step (shared with the other compiled
loops; it allocates its new state), one pass over the modes (the rotation by e^(lambda h),
the inputs' part, the outputs' sums) into arrays made once, no Python.

The answers are the Python loop's around the same LinearSimulator
(`controllers/sample_loop.simulate_loop` around `LinearPlant`) to round-off: the pairs'
coordinates are the means of the two the LinearSimulator steps (equal but for the rounding of
V^-1), and the sums run in another order (tests/test_linear_loop.py: the manipulator's loop
within 1e-12 of the stroke). The simulator is left at t_N with the modal state reached and the
last force held, as after the Python loop.

    t, position, force = run_linear_loop(sim, fs=4000.0, samples=N, reference=r,
                                         feedforward=u_ff, controller=(A, B, C, D),
                                         loop_inputs=[0], loop_outputs=[0])
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..errors import SimulationError
from .linear_loop_kernels import OVERFLOW, linear_loop_runner
from .sampled_control import FORCE, POSITION, controller_arrays

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from .linear_simulator import LinearSimulator


class RealModes(NamedTuple):
    """The real modal form of a LinearSimulator's step (see `linear_loop_kernels`), in three
    groups: one mode of each conjugate pair of eigenvalues (a complex coordinate as two real
    ones), the real eigenvalues (one real coordinate each), and the modes a step forgets
    (e^(lambda h) = 0: lambda h below -745, the stiffest overdamped modes; after any step
    their w is g du, their part of the outputs one matrix times du).

    Attributes
    ----------
    rotation : ndarray (n_pairs, 2)
        p, q: e^(lambda h) = p + j q.
    pair_drive : ndarray (n_pairs, 2 n_inputs)
        The real, then the imaginary parts of g = h phi1(lambda h) (V^-1 B) (per N, N m, V).
    pair_readout : ndarray (n_pairs, 2 n_outputs)
        c' = 2 Re(C V), then c'' = -2 Im(C V), of the outputs asked for (a pair's conjugate
        adds the same part again).
    pair_state : ndarray (n_pairs, 2)
        a, b: w = a + j b, now.
    decay : ndarray (n_real,)
        e^(lambda h) of the real eigenvalues a step does not forget.
    real_drive, real_readout : ndarray (n_real, n_inputs), (n_real, n_outputs)
        g and C V: real (V's columns of a real eigenvalue are real, so is C V; g's imaginary
        part is V^-1's rounding, which C V's zero imaginary part never reads).
    real_state : ndarray (n_real,)
        w, now.
    forgotten : ndarray (n_outputs, n_inputs)
        Re(C V g) summed over the modes a step forgets.
    pairs, partners, reals, gone : ndarray of int
        The eigenvalues' indices of each pair's mode and of its conjugate, of the real
        modes, and of the forgotten ones.
    gone_drive : ndarray (n_gone, n_inputs), complex
        The forgotten modes' g.
    """

    rotation: np.ndarray
    pair_drive: np.ndarray
    pair_readout: np.ndarray
    pair_state: np.ndarray
    decay: np.ndarray
    real_drive: np.ndarray
    real_readout: np.ndarray
    real_state: np.ndarray
    forgotten: np.ndarray
    pairs: np.ndarray
    partners: np.ndarray
    reals: np.ndarray
    gone: np.ndarray
    gone_drive: np.ndarray

    @classmethod
    def of(cls, sim: LinearSimulator, h: float, outputs: Sequence[int]) -> RealModes:
        """The real modal form of `sim`'s step of h seconds (its factors as `advance_to` takes
        them), reading the outputs of index `outputs`, at its modal state now.

        Raises
        ------
        SimulationError
            `sim` does not step in its modal form, or a complex eigenvalue's conjugate is not
            next to it (LAPACK's order, which scipy's `eig` keeps).
        """
        if not sim.modal:
            raise SimulationError("the compiled linear loop steps the modal form; this "
                                  f"linearisation's eigenvectors are ill-conditioned "
                                  f"(cond_1(V) = {sim.condition:.3g}): use the Python loop")
        first, partner = _conjugate_pairs(sim.eigenvalues)
        decay, drive = sim.step_factors(h)
        readout = sim.output_modes[list(outputs)]
        w = sim.modal_state
        forgets = (decay[first] == 0) | (decay[partner] == 0)
        gone = np.union1d(first[forgets], partner[forgets])
        first, partner = first[~forgets], partner[~forgets]
        paired = partner != first
        pairs, partners, reals = first[paired], partner[paired], first[~paired]

        def mean(values, axis=0):  # of each pair's mode and its conjugate's conjugate
            return (np.take(values, pairs, axis=axis)
                    + np.take(values, partners, axis=axis).conj()) / 2

        c, g = 2 * mean(readout, axis=1), mean(drive)
        return cls(rotation=_real_parts(mean(decay)),
                   pair_drive=np.ascontiguousarray(np.hstack([g.real, g.imag])),
                   pair_readout=np.ascontiguousarray(np.hstack([c.real.T, -c.imag.T])),
                   pair_state=_real_parts(mean(w)),
                   decay=np.ascontiguousarray(decay[reals].real),
                   real_drive=np.ascontiguousarray(drive[reals].real),
                   real_readout=np.ascontiguousarray(readout[:, reals].real.T),
                   real_state=np.ascontiguousarray(w[reals].real),
                   forgotten=np.ascontiguousarray((readout[:, gone] @ drive[gone]).real),
                   pairs=pairs, partners=partners, reals=reals, gone=gone,
                   gone_drive=drive[gone])

    def modal_state(self, n_states: int, du: np.ndarray) -> np.ndarray:
        """The LinearSimulator's modal state (n_states,), complex, after a step with du
        (N, N m, V) held: w for each pair's mode and its conjugate for its partner, the real
        modes' w, and g du for the forgotten ones (as its own step leaves them)."""
        w = self.pair_state[:, 0] + 1j * self.pair_state[:, 1]
        full = np.zeros(n_states, dtype=complex)
        full[self.pairs], full[self.partners] = w, w.conj()
        full[self.reals] = self.real_state
        full[self.gone] = self.gone_drive @ du
        return full


def _real_parts(values):
    """(n, 2) C-contiguous: the real and imaginary parts of the complex (n,)."""
    return np.ascontiguousarray(np.column_stack([values.real, values.imag]))


def _conjugate_pairs(eigenvalues):
    """(first, partner): the index of each real eigenvalue and of the first of each conjugate
    pair (positive imaginary part), and of its conjugate (itself for a real one)."""
    first, partner = [], []
    i = 0
    while i < eigenvalues.size:
        value = eigenvalues[i]
        if value.imag == 0.0:
            first.append(i), partner.append(i)
            i += 1
        elif value.imag > 0 and i + 1 < eigenvalues.size and eigenvalues[i + 1] == value.conj():
            first.append(i), partner.append(i + 1)
            i += 2
        else:
            raise SimulationError(f"the eigenvalue {value:.6g} (index {i}) is not followed by "
                                  "its conjugate: the compiled linear loop pairs them so")
    return np.array(first, dtype=np.int64), np.array(partner, dtype=np.int64)


def run_linear_loop(sim: LinearSimulator, *, fs: float, samples: int, reference: ArrayLike,
                    feedforward: ArrayLike,
                    controller: tuple[ArrayLike, ArrayLike, ArrayLike, ArrayLike],
                    loop_inputs: Sequence[int], loop_outputs: Sequence[int],
                    quantum: ArrayLike | None = None,
                    progress: Callable[[float], None] | None = None,
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the loop from the simulator's state at t = 0 (after `reset`).

    Parameters
    ----------
    sim : LinearSimulator
        The plant, stepping its modal form (`sim.modal`), at t = 0.
    fs : float
        Sample rate (Hz).
    samples : int
        The number of intervals N; the run ends at t_N = N / fs.
    reference, feedforward : array_like (>= 1, n_loops)
        r_k (m, rad) and u_ff,k (N, N m, or V for an actuator's drive signal) per sample
        (the last row holds past the end).
    controller : tuple of array_like (A, B, C, D)
        The discrete controller from errors to forces, as `run_sampled_loop` takes it.
    loop_inputs, loop_outputs : sequences of int
        The model input driven by each loop, and the model output it measures.
    quantum : array_like (n_loops,), optional
        Each loop's encoder quantum (m, rad; > 0), as `run_sampled_loop` takes it.
    progress : callable, optional
        Called with the fraction of samples done, about 100 times.

    Returns
    -------
    t : ndarray (N+1,)
        The sample times, s.
    position : ndarray (N+1, n_loops)
        y_k (m, rad, or the outputs' units).
    force : ndarray (N+1, n_loops)
        u_k held from t_k (N, N m, V); the last row repeats the one before.

    Raises
    ------
    SimulationError
        The simulator is not at t = 0 or not modal, the loop inputs and outputs or the
        reference, feedforward or quantum do not fit the loops, or the state overflows
        (naming the time; the simulator is then left at the last sample before it).
    """
    if sim.time != 0.0:
        raise SimulationError(f"the linear loop starts at t = 0; the simulator is at "
                              f"t = {sim.time:.9g} s: reset it first")
    if len(loop_inputs) != len(loop_outputs):
        raise SimulationError(f"expected as many loop inputs as loop outputs, one pair per "
                              f"loop: got {len(loop_inputs)} loop inputs and "
                              f"{len(loop_outputs)} loop outputs")
    N = int(samples)
    h = 1.0 / fs  # the first step's, as advance_to(1 / fs) takes it from t = 0
    modes = RealModes.of(sim, h, loop_outputs)
    arrays = controller_arrays(reference, feedforward, controller, loop_inputs,
                               quantum=quantum, samples=N,
                               coordinates=np.zeros(0, dtype=np.int64))
    position, force = arrays[POSITION], arrays[FORCE]
    position[0] = sim.outputs()[list(loop_outputs)]
    held = np.array(sim.inputs, dtype=float)
    start = sim.modal_state
    n_outputs = len(loop_outputs)
    plant = (np.ascontiguousarray(sim.u0, dtype=float),
             modes.rotation, modes.pair_drive, modes.pair_readout, modes.pair_state,
             np.zeros_like(modes.pair_state),
             modes.decay, modes.real_drive, modes.real_readout, modes.real_state,
             np.zeros_like(modes.real_state),
             np.zeros(held.size), np.zeros(n_outputs),
             np.ascontiguousarray(sim.output_constant[list(loop_outputs)]),
             # D du and the forgotten modes' part in one product
             np.ascontiguousarray(sim.D[list(loop_outputs)] + modes.forgotten))
    loop_state = np.zeros(1)
    run = linear_loop_runner(arrays, plant, loop_state, held)
    chunk = max(1, N // 100 if progress is not None else N)
    for done in range(0, N, chunk):  # in chunks of samples, for the progress report
        stop = min(N, done + chunk)
        if run(done, stop) == OVERFLOW:
            k = int(loop_state[0])  # the state stayed at t_k, after the step with u_k-1
            sim.continue_from(k / fs, start if k == 0 else modes.modal_state(
                start.size, _held(force[k - 1], loop_inputs, held.size) - sim.u0), held)
            raise SimulationError(
                f"t = {k / fs:.9g} s: the linearised state overflows over the step to "
                f"{(k + 1) / fs:.9g} s (the linearisation's fastest growth rate: "
                f"{sim.growth_rate:.6g} 1/s; the inputs' largest distance from the "
                f"linearisation's: {np.max(np.abs(held - sim.u0), initial=0.0):.6g})")
        if progress is not None:
            progress(stop / N)
    force[N] = force[N - 1]
    sim.continue_from(N / fs, modes.modal_state(start.size, held - sim.u0), held)
    return np.arange(N + 1) / fs, position, force


def _held(force, loop_inputs, n_inputs):
    """The plant's inputs (n_inputs,) with the loops' forces held (the others zero), as
    `control_sample` sets them."""
    held = np.zeros(n_inputs)
    held[list(loop_inputs)] = force
    return held
