"""The sample loop: a plant stepped under a `LoopController`, sample by sample.

Three implementations of the same loop (the timing is in loop_controller.py):

- `simulate_loop`: the readable reference in Python, around any plant of plants.py (the
  in-process simulator, the linear plant or the scene FMU under fmpy);
- `compiled_loop`: the in-process plant as one compiled run (flexure.core.run_sampled_loop),
  with the same samples, forces and integrator calls as `simulate_loop` around an
  `InProcessPlant`; the tests hold one against the other, bit for bit;
- `linear_loop`: the linear plant (`LinearPlant`) as one compiled run
  (flexure.core.simulation.linear_loop: its exact step in real modal coordinates, the same
  controller's arithmetic), within round-off of `simulate_loop` around it.

All return t (N+1,) s, reference and position (N+1, n_loops) m, force (N+1, n_loops) N.
All run with one BLAS thread (`blas_threads`, scoped to the loop: the host's limits are back
when it returns): a loop's BLAS calls are small, per sample (the linear plant's 1014-state
modal step, the Newton solves of an analysis a controller calls), and several threads spin
against other work on a loaded machine: `flexure loop manipulator_reduced --plant linear`
took 6 to 127 s with OpenBLAS's two threads under load against 1.1 to 1.9 s with one
(docs/benchmarks.md).
`compiled_loop` and `linear_loop` run a state-space feedback (`LoopController.compiled`),
with its encoder quantisation (run_sampled_loop's `quantum`: the same q * round(y / q)) and
its disturbance force (on the feedforward array); a callable feedback, called with the sample
index, takes `simulate_loop` (a Python call per sample).
"""

import numpy as np

from flexure.core.numerics.blas import blas_threads

from .errors import LoopError
from .loop_controller import LoopController


@blas_threads()
def simulate_loop(plant, controller: LoopController, design, *, progress=None):
    """Step `plant` (plants.py interface) under `controller`; returns t, r, y, u arrays.

    Parameters
    ----------
    plant : InProcessPlant, LinearPlant or FmuPlant
    controller : LoopController
    design : FeedbackDesign
        Its `pairs` say which plant inputs and outputs the loops use.
    progress : callable, optional
        Called with the fraction of samples done, about 100 times.
    """
    pairs = design.pairs
    n_inputs = len(plant.input_names)
    inputs = [p.input_index for p in pairs]
    outputs = [p.output_index for p in pairs]
    N, fs = controller.samples, controller.fs
    position = np.empty((N + 1, len(pairs)))
    force = np.empty((N + 1, len(pairs)))
    controller.reset()
    y = plant.reset()[outputs]
    u = controller.initial_output()
    full = np.zeros(n_inputs)
    report_every = max(1, N // 100)
    for k in range(N):
        if progress is not None and k % report_every == 0:
            progress(k / N)
        position[k] = y
        force[k] = u
        u_next, _ = controller.step(k, y)
        full[inputs] = u
        plant.set_input(full)
        plant.advance((k + 1) / fs)
        y = plant.output()[outputs]
        u = u_next
    if progress is not None:
        progress(1.0)
    position[N], force[N] = y, force[N - 1]
    t = np.arange(N + 1) / fs
    return t, controller.reference[: N + 1].copy(), position, force


@blas_threads()
def compiled_loop(model, controller: LoopController, design, *, method: str, rtol: float,
                  progress=None, warn=None, motion_duration=None, ended=None):
    """The in-process loop of `model` as one compiled run; returns t, r, y, u like
    `simulate_loop`, to the bit. The controller's feedback is a state space
    (`controller.compiled`); its encoders' quantum goes to run_sampled_loop and its
    disturbance force rides on the feedforward, as in `LoopController.step`.

    Parameters
    ----------
    model : Model
    controller : LoopController
    design : FeedbackDesign
    method, rtol : str, float
        The integrator (a `flexure.core.METHODS` name) and its relative tolerance.
    progress : callable, optional
        Called with the fraction of samples done.
    warn : callable, optional
        Called with the simulator's range-of-validity warning of each kind (strain,
        distance) the first time the run's state leaves the range, while it runs (checked
        with each progress report, about 100 times).
    motion_duration : float, optional
        s: a model with kinematic inputs moves each along the scene's quintic from its
        `start` to its `value` in this time from t = 0 (`Simulator(..., motion_duration=)`),
        a known motion the loop rides on.
    ended : callable, optional
        Called with the Simulator at t_N after the run (e.g. for the inputs' efforts).
    """
    from flexure.core import Simulator, run_sampled_loop  # the models (numba) on first use

    if not controller.compiled:
        raise LoopError("the compiled loop runs a state-space feedback; a callable "
                        "controller takes simulate_loop")
    sim = Simulator(model, method=method, rtol=rtol, motion_duration=motion_duration)
    feedback = controller.controller
    said = set()

    def report(fraction):  # the progress, and the range of validity as the run leaves it
        if progress is not None:
            progress(fraction)
        for kind, message in sim.range_warnings().items() if warn is not None else ():
            if kind not in said:
                said.add(kind)
                warn(message)

    with sim:  # closed at the end: its solver's memory now, not when the collector runs
        t, position, force = run_sampled_loop(
            sim, fs=controller.fs, samples=controller.samples, reference=controller.reference,
            feedforward=controller.open_loop_forces,  # u_ff (+ the disturbance d)
            controller=(feedback.A, feedback.B, feedback.C, feedback.D),
            loop_inputs=[pair.input_index for pair in design.pairs],
            loop_outputs=[pair.output_index for pair in design.pairs],
            quantum=controller.quantum,
            progress=report if progress is not None or warn is not None else None)
        if ended is not None:
            ended(sim)
    return t, controller.reference[: len(t)].copy(), position, force


def prepare_linear_loop(plant, controller: LoopController) -> bool:
    """Whether `linear_loop` runs `controller` around `plant` compiled (a state-space feedback
    on a modal LinearSimulator); if so its compiled code is loaded (compiled on first use)
    now, before a timed run.

    Parameters
    ----------
    plant : LinearPlant
    controller : LoopController
    """
    if not (controller.compiled and plant.simulator.modal):
        return False
    from flexure.core.simulation.linear_loop_kernels import prepare_linear_loop as load

    load()
    return True


@blas_threads()
def linear_loop(plant, controller: LoopController, design, *, progress=None):
    """The loop around the linear plant; returns t, r, y, u like `simulate_loop` around it,
    within round-off (tests/test_linear_loop.py). Compiled (`prepare_linear_loop`): the
    controller's state-space feedback with its encoders' quantum and disturbance force (on
    the feedforward array), as `compiled_loop` runs it; else (a callable feedback, or
    eigenvectors too ill-conditioned for the modal step) `simulate_loop`.

    Parameters
    ----------
    plant : LinearPlant
    controller : LoopController
    design : FeedbackDesign
        Its `pairs` say which plant inputs and outputs the loops use.
    progress : callable, optional
        Called with the fraction of samples done, about 100 times.
    """
    if not (controller.compiled and plant.simulator.modal):
        return simulate_loop(plant, controller, design, progress=progress)
    from flexure.core.simulation.linear_loop import run_linear_loop

    controller.reset()
    plant.reset()
    feedback = controller.controller
    t, position, force = run_linear_loop(
        plant.simulator, fs=controller.fs, samples=controller.samples,
        reference=controller.reference,
        feedforward=controller.open_loop_forces,  # u_ff (+ the disturbance d)
        controller=(feedback.A, feedback.B, feedback.C, feedback.D),
        loop_inputs=[pair.input_index for pair in design.pairs],
        loop_outputs=[pair.output_index for pair in design.pairs],
        quantum=controller.quantum, progress=progress)
    return t, controller.reference[: len(t)].copy(), position, force
