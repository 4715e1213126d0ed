"""A feedback controller of your own in place of the designed PID-like one.

`run_loop(..., controller=C)` and `build_loop(..., controller=C)` take for C

- **a discrete python-control system** (`StateSpace` or `TransferFunction`) with
  dt = 1 / fs, from the loops' errors e = r - y (m, rad) to their forces (N, N m):
  n_loops x n_loops (inputs and outputs in the loops' order, `FeedbackDesign.pairs`), or a
  list of SISO systems, one per loop (a decentralised controller). It runs as the designed
  controller does, as the state-space recursion of its realisation (`control.ss`; a MIMO
  transfer function entry by entry): compiled in the in-process loop, serialised into the
  controller FMU. Its loops are checked on the scene's linear model as the designed ones are
  (robustness.check_robustness: parasitic modes included, a zero-order hold, one sample of
  computation delay): the margins of each loop with the others open and closed, the peak of
  the sensitivity, the closed-loop poles. A closed loop with a pole on or outside the unit
  circle is refused (LoopError naming the pole). The cross-over reported is the measured
  gain cross-over of the first loop (the others open); `crossover` only places the dense part
  of the frequency grid.
- **a callable** per loop: a list of n_loops functions f(k, e) -> u, each given the sample
  index k (int; t_k = k / fs) and its loop's error e_k (float, m or rad, as the controller
  sees it: quantised when the encoders are) and returning the feedback force (float, N or
  N m) for the interval [t_k+1, t_k+2): the loop's one sample of computation delay, as for
  the designed controller (loop_controller.py); the feedforward and the disturbance are added
  to it. One callable for every loop, f(k, e) -> u with arrays (n_loops,), is a MIMO
  controller (with one loop it takes and returns floats, as a list's entry does). A callable
  with a `reset()` method is reset before each run (e.g. an object keeping an integrator's
  state). It runs in Python once per sample: the in-process plant is then stepped from Python
  (sample_loop.simulate_loop) instead of by the compiled loop, and the controller FMU
  (plant "libcosim") cannot carry it. It has no linear model, so its closed loop is not
  checked: no margins (nan), `robustness_checked` false in the summary.
"""

from __future__ import annotations

import sys

import numpy as np

from .errors import LoopError
from .feedback import FeedbackDesign
from .lti import LinearSystem
from .robustness import check_robustness


def is_system(value) -> bool:
    """Whether `value` is a python-control LTI system (which is callable too). Without
    python-control imported nothing is one: a callable alone does not import it."""
    control = sys.modules.get("control")
    return control is not None and isinstance(value, control.LTI)


class CallableFeedback:
    """Feedback from Python callables, stepped as `DiscreteController` is (`step(e, k)`)."""

    kind = "callable"

    def __init__(self, functions, names):
        self.functions = list(functions)
        self.names = list(names)
        self.vector = len(self.functions) == 1 and len(self.names) > 1

    def reset(self):
        for function in self.functions:
            reset = getattr(function, "reset", None)
            if callable(reset):
                reset()

    def step(self, e, k: int) -> np.ndarray:
        """The feedback forces (N, N m), (n_loops,), for the errors e_k (m, rad) at sample k."""
        n = len(self.names)
        if self.vector:
            value = self.functions[0](k, np.array(e, float))
            u = _finite(value, n, k, "the controller")
        else:
            u = np.empty(n)
            for i, function in enumerate(self.functions):
                u[i] = _finite(function(k, float(e[i])), 1, k, f"the controller of loop "
                               f"{self.names[i]}")[0]
        return u

    def to_dict(self):
        raise LoopError("a callable controller cannot be serialised into the controller FMU "
                        "(plant 'libcosim'); run it on plant 'inprocess' or 'fmu', or give a "
                        "discrete python-control system")


def _finite(value, n, k, what):
    try:
        u = np.asarray(value, float).reshape(-1)
    except (TypeError, ValueError):
        u = np.array([])
    if u.size != n or not np.all(np.isfinite(u)):
        raise LoopError(f"{what} returned {value!r} at sample {k}; expected "
                        f"{'a finite number' if n == 1 else f'{n} finite numbers'} (N)")
    return u


def discrete_system(controller, *, fs: float, names) -> object:
    """The controller as one discrete control.StateSpace (n_loops x n_loops, dt = 1 / fs);
    LoopError for a continuous system, another dt, a wrong shape or an improper one."""
    import control

    n = len(names)
    if isinstance(controller, (list, tuple)):
        if len(controller) != n:
            raise LoopError(f"a list of controllers needs one per loop ({', '.join(names)}): "
                            f"expected {n}, got {len(controller)}")
        parts = [_realised(c, fs, f"the controller of loop {name}", (1, 1))
                 for c, name in zip(controller, names, strict=True)]
        return control.append(*parts) if n > 1 else parts[0]
    return _realised(controller, fs, "the controller", (n, n))


def _realised(system, fs, what, shape):
    import control

    if not is_system(system):
        raise LoopError(f"{what} must be a discrete python-control system (StateSpace or "
                        f"TransferFunction) or a callable, got {type(system).__name__}")
    if (system.noutputs, system.ninputs) != shape:
        raise LoopError(f"{what}: expected a {shape[0]} x {shape[1]} system (outputs x "
                        f"inputs: a force per loop from the errors of the loops), got "
                        f"{system.noutputs} x {system.ninputs}")
    dt = system.dt
    if dt is True:
        raise LoopError(f"{what} has an unspecified sample time (dt = True); expected "
                        f"dt = 1/fs = {1 / fs:.9g} s")
    if not dt:
        raise LoopError(f"{what} is continuous (dt = 0); expected a discrete one with "
                        f"dt = 1/fs = {1 / fs:.9g} s, e.g. control.c2d(C, {1 / fs:.9g})")
    if abs(float(dt) * fs - 1.0) > 1e-9:
        raise LoopError(f"{what}: expected dt = 1/fs = {1 / fs:.9g} s, got dt = {dt:.9g} s")
    try:
        realised = _state_space(system)
    except ValueError as error:
        raise LoopError(f"{what}: {error}") from None
    matrices = (realised.A, realised.B, realised.C, realised.D)
    if not all(np.all(np.isfinite(np.asarray(m, float))) for m in matrices):
        raise LoopError(f"{what} has non-finite coefficients")
    return control.ss(*matrices, 1.0 / fs)


def _state_space(system):
    """control.ss of a system; a MIMO transfer function (which python-control converts only
    with slycot) entry by entry: the entries side by side, each output summing its row."""
    import control

    if isinstance(system, control.StateSpace) or (system.ninputs, system.noutputs) == (1, 1):
        return control.ss(system)
    n_out, n_in = system.noutputs, system.ninputs
    entries = [control.ss(system[i, j]) for i in range(n_out) for j in range(n_in)]
    block = control.append(*entries)
    pick = np.zeros((n_out * n_in, n_in))  # entry (i, j) reads input j
    add = np.zeros((n_out, n_out * n_in))  # output i sums entries (i, .)
    for i in range(n_out):
        for j in range(n_in):
            pick[i * n_in + j, j] = 1.0
            add[i, i * n_in + j] = 1.0
    return control.ss(block.A, block.B @ pick, add @ block.C, add @ block.D @ pick, system.dt)


def user_design(model, controller, *, fs: float, crossover: float, plant=None,
                linear_model=None):
    """The feedback of one's own controller and its checked design: (DiscreteController or
    CallableFeedback, FeedbackDesign).

    Parameters
    ----------
    model : Model
    controller : control system, list of them, callable or list of callables
    fs : float
        Sample rate (Hz).
    crossover : float
        Where to refine the frequency grid of the margins (rad/s).
    plant, linear_model : optional
        As for `design_feedback`: the continuous model the loops are checked on.
    """
    from flexure.core import state_space_matrices  # the models (numba, scipy) on first use

    from .feedback import DiscreteController, colocated_pairs

    if not (np.isfinite(fs) and fs > 0):
        raise LoopError(f"sample rate must be a positive number of Hz, got {fs}")
    if not (np.isfinite(crossover) and 0 < crossover < np.pi * fs):
        raise LoopError(f"crossover, where the margins' frequency grid is refined, must lie "
                        f"between 0 and the Nyquist frequency pi fs = {np.pi * fs:g} rad/s, "
                        f"got {crossover}")
    pairs = colocated_pairs(model)
    names = [p.input_name for p in pairs]
    entries = controller if isinstance(controller, (list, tuple)) else [controller]
    functions = [c for c in entries if callable(c) and not is_system(c)]
    design = FeedbackDesign(
        pairs=pairs, crossover_rad_s=float(crossover), sample_rate_hz=float(fs),
        delay_samples=1, shapes=[], feedback=None, first_loop=None,
        phase_margin_deg=np.nan, gain_margin=np.nan, modulus_margin=np.nan,
        closed_loop_poles=np.zeros(0), kind="callable")
    if functions:
        if len(functions) != len(entries):
            raise LoopError("a list of controllers is all python-control systems or all "
                            "callables, not a mix")
        if len(entries) not in (1, len(pairs)):
            raise LoopError(f"a list of callables needs one per loop ({', '.join(names)}): "
                            f"expected {len(pairs)}, got {len(entries)}")
        design.crossover_rad_s = float("nan")  # not known without a linear model
        return CallableFeedback(functions, names), design
    system = discrete_system(controller, fs=fs, names=names)
    full = (LinearSystem.of(plant) if plant is not None
            else LinearSystem(*state_space_matrices(model, linear_model=linear_model)))
    sub = full.subsystem([p.output_index for p in pairs], [p.input_index for p in pairs])
    design.feedback, design.kind = LinearSystem.of(system), "state space"
    robust = check_robustness(design, sub, name=model.name)
    gm, pm, sm = robust.open_margins.min(axis=0)
    poles = robust.closed_loop_poles
    design.phase_margin_deg, design.gain_margin, design.modulus_margin = (
        float(pm), float(gm), float(sm))
    design.closed_loop_poles, design.robustness = poles, robust
    design.crossover_rad_s = float(robust.crossovers_rad_s[0])
    if not np.all(np.abs(poles) < 1.0):
        worst = poles[np.argmax(np.abs(poles))]
        raise LoopError(
            f"{model.name}: the closed loop with the given controller at {fs:g} Hz is "
            f"unstable: pole z = {worst:.6g} (|z| = {abs(worst):.6f} >= 1); phase margin "
            f"{pm:.1f} deg, gain margin {gm:.3g} (loops {', '.join(names)}, one sample of "
            "computation delay, the scene's linear model)")
    return DiscreteController(design.feedback), design
