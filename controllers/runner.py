"""`run_loop`: the closed loop on a scene, on one of four plants, timed and summarised.

    scene -> build_loop (loop_design.py) -> a LoopController and its design
          -> the plant:  "inprocess"  the compiled in-process loop (sample_loop.py)
                         "linear"     the linearised model, stepped exactly (plants.py),
                                      the loop compiled (sample_loop.py)
                         "fmu"        the scene FMU under fmpy (plants.py, sample_loop.py)
                         "libcosim"   the controller and scene FMUs in libcosim (cosim.py)
          -> LoopResult (loop_result.py)

Every plant runs the same controller with the same timing (loop_controller.py); the three
nonlinear ones the same integrator and tolerance, so they agree to the integrator's
tolerance. On "inprocess" a callable controller runs the Python loop around the Simulator
(sample_loop.simulate_loop, a Python call per sample); the designed controller and a
python-control system run compiled, with their encoder quantisation and disturbance.
"""

from __future__ import annotations

import contextlib
import tempfile
import time
from collections.abc import Callable, Sequence
from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np

from flexure.core.numerics.blas import blas_threads
from flexure.core.simulation.methods import LOOP_METHOD, LOOP_RTOL

from .loop_controller import LoopController
from .loop_design import LoopError, build_loop, feedforward_kind
from .loop_motion import motion_duration_of, motion_report
from .loop_result import TARGET, LoopResult
from .plants import FmuPlant, InProcessPlant, LinearPlant
from .sample_loop import compiled_loop, linear_loop, prepare_linear_loop, simulate_loop
from .user_reference import reference_stroke
from .validity import loop_coordinates, motion_warnings

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from flexure.core import Model

    from .feedback import FeedbackDesign
    from .feedforward import LowFrequencyModel
    from .move_path import MovePath

PLANTS = ("inprocess", "linear", "fmu", "libcosim")

# What was defined here before the split stays importable from here
# (examples/benchmarks/compare.py imports run_loop, tests simulate_loop).
__all__ = ["PLANTS", "TARGET", "LoopController", "LoopError", "LoopResult", "build_loop",
           "run_loop", "simulate_loop"]


def run_loop(scene: Model | str | PathLike, *, stroke: float = 1e-3, duration: float = 1.0,
             fs: float = 4000.0, crossover: float = 300.0, feedforward: bool | str = True,
             plant: str = "inprocess", settle: float = 0.25, axis: int = 0,
             method: str = LOOP_METHOD, rtol: float = LOOP_RTOL,
             feedforward_model: LowFrequencyModel | None = None,
             workdir: str | PathLike | None = None,
             progress: Callable[[float], None] | None = None,
             overrides: dict | None = None, path: MovePath | None = None,
             design: FeedbackDesign | None = None, controller: object | None = None,
             reference: ArrayLike | Callable[[float], ArrayLike] | None = None,
             quantum: float | Sequence[float] | None = None,
             disturbance: float | Sequence[float] | None = None,
             disturbance_hz: float = 50.0, warn: Callable[[str], None] | None = None,
             feedforward_forces: ArrayLike | None = None,
             motion_duration: float | None = None,
             **design_options: Any) -> LoopResult:
    """Run the closed loop on a scene (a model, a file or a built-in name).

    Parameters
    ----------
    scene : Model, str or path-like
        A built model, a scene file or a built-in scene's name.
    stroke, duration : float
        The third-order move (m, s).
    fs : float
        Sample rate (Hz) of the controller and communication step of the plant.
    crossover : float
        The requested cross-over (rad/s).
    feedforward : bool or str
        True or "modal": the inverse of the low-frequency model; "inverse": the stable
        approximate inverse of the full linear model (see `build_loop`); False: none.
    plant : {"inprocess", "linear", "fmu", "libcosim"}
        The in-process compiled loop, the linearised model (`LinearPlant`: the state space
        at the static equilibrium, stepped exactly; `method` and `rtol` unused), the scene
        FMU under fmpy, or both FMUs in libcosim.
    settle : float
        Time (s) simulated after the move.
    axis : int
        The loop that moves; the others hold their initial position.
    method : str
        The plant's integrator (every plant uses the same): a `flexure.core.METHODS` name.
        The default, the one-step ESDIRK of order 3, takes the change of the held force at
        every sample without a restart (one step per sample at 4 kHz on the built-in stages).
    rtol : float
        Relative tolerance of the plant's integrator (every plant uses the same).
    feedforward_model : LowFrequencyModel, optional
        Use this model for the feedforward instead of the scene's own.
    workdir : path, optional
        Where the FMUs are built and kept (default: a temporary folder, removed after).
    progress : callable, optional
        Called with the fraction of the samples done (0 to 1) as the loop runs, e.g. a
        `flexure.core.reporting.progress.Progress`.
    overrides : dict, optional
        {dotted scene key: value} set on a scene file or name before it is built
        (`flexure.core.load_scene`); the FMU plants are built from the overridden scene.
    path : MovePath, optional
        Every loop follows its displacement along this path (`move_path`) in `duration`;
        `stroke` becomes the largest displacement of a loop at the end of the path.
    design : FeedbackDesign, optional
        A feedback designed before, reused (`design_feedback`).
    controller : python-control system, list of them, callable or list of callables, optional
        One's own feedback (user_controller.py): a discrete system with dt = 1 / fs (n_loops
        x n_loops, or one SISO system per loop), checked for closed-loop stability and run
        compiled; or f(k, e) -> u per loop, run in Python, not checked, not on "libcosim".
    reference : array (N+1,) or (N+1, n_loops), or callable r(t), optional
        The loops' positions (m, rad) instead of the third-order profile
        (user_reference.py); samples set the run's length. The stroke reported is the
        largest excursion of a loop's reference from its first sample.
    quantum : float or sequence, optional
        The encoders' quantum (m, rad): the controller sees the positions rounded to it.
    disturbance : float or sequence, optional
        The amplitude (N, N m) of a sinusoidal force at each loop's actuator
        (disturbances.py).
    disturbance_hz : float
        Its frequency (Hz), default 50.
    warn : callable, optional
        Called with each range-of-validity warning as it is found: before the run for the
        strokes and move targets asked for, after it for the positions recorded
        (validity.py). The summary lists them all ("warnings").
    feedforward_forces : array_like (N+2, n_loops), optional
        Given feedforward forces (N, N m), held from each sample (`build_loop`), e.g. from
        the nonlinear inverse dynamics (`dynamic_feedforward`).
    motion_duration : float, optional
        s: on a scene with kinematic inputs, each moves along the scene's quintic from its
        `start` to its `value` in this time from t = 0 (default `duration`), a known motion
        the loop rides on (loop_motion.py); only on "inprocess". The summary gives each
        input's effort at the end ("kinematic_inputs").
    **design_options
        Passed on to `design_feedback`.

    Returns
    -------
    LoopResult
        The samples (s; m, rad; N, N m) and the summary against the 0.1 % target.

    Raises
    ------
    LoopError
        An unknown plant or method, a bad rtol, overrides on a built Model, a controller
        the chosen plant cannot run, kinematic inputs on a plant that does not move them
        or a bad motion_duration, or a bad loop setting (`build_loop`).
    ControlDesignError
        The feedback or feedforward cannot be designed.
    SceneError
        The scene cannot be loaded.
    SimulationError
        The plant's integration fails.
    """
    if plant not in PLANTS:
        raise LoopError(f"unknown plant {plant!r}; expected one of {', '.join(PLANTS)}")
    if not (isinstance(rtol, (int, float, np.floating)) and np.isfinite(rtol) and 0 < rtol < 1):
        raise LoopError(f"rtol must be a number between 0 and 1, got {rtol!r}")
    # the models (numba, scipy) on first use
    from flexure.core import METHODS, RangeCheck, load_scene, prepare

    if method not in METHODS:
        raise LoopError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")
    named = isinstance(scene, (str, bytes)) or hasattr(scene, "__fspath__")
    if overrides and not named:
        raise LoopError("overrides apply to a scene file or name, not to a built Model: "
                        "build the model with them (build_model(data, overrides=...))")
    model = load_scene(scene, overrides=overrides) if named else scene
    # before anything compiles: the kinematic inputs' move, or the plant's refusal
    moving_for = motion_duration_of(model, plant, motion_duration, duration)
    if plant == "linear" and design is None and "linear_model" not in design_options:
        from flexure.core import linearize  # one linearisation: the plant's and the design's

        design_options["linear_model"] = linearize(model)
    loop, design = build_loop(
        model, stroke=stroke, duration=duration, fs=fs, crossover=crossover,
        feedforward=feedforward, settle=settle, axis=axis,
        feedforward_model=feedforward_model, path=path, design=design, controller=controller,
        reference=reference, quantum=quantum, disturbance=disturbance,
        disturbance_hz=disturbance_hz, feedforward_forces=feedforward_forces,
        **design_options)
    if plant == "libcosim" and loop.sample_indexed:
        loop.controller.to_dict()  # raises the LoopError saying why, before any FMU is built
    if path is not None:
        stroke = float(np.max(np.abs(path.displacement([1.0]))))
    if reference is not None:
        stroke = reference_stroke(loop.reference, loop.samples)
        if not callable(reference):  # the samples set the run
            duration, settle = loop.samples / fs, 0.0
    coordinates = loop_coordinates(model, design)
    planned = {coordinates[axis]: stroke} if path is None else {
        **path.targets, **dict(zip(coordinates, path.displacement([1.0])[0], strict=True))}
    found = _warned(motion_warnings(model, planned), [], warn)

    def warn_during(message):  # the simulator's, while the run goes: once per coordinate
        found[:] = _warned([message], found, warn)
    kind = "given" if feedforward_forces is not None else feedforward_kind(feedforward)
    moving = design.pairs[axis]
    settings = {"scene": model.name, "plant": plant, "feedforward": kind is not None,
                "feedforward_kind": kind or "none",
                "duration": duration, "settle": settle, "axis": axis, "move_end": duration,
                # the linear plant is stepped exactly: no integrator, no tolerance
                "method": "exact" if plant == "linear" else method,
                "rtol": None if plant == "linear" else rtol,
                "path": None if path is None else {"kind": path.kind,
                                                   "targets": dict(path.targets)},
                # the moving loop's units: a force (N) and a position (m), or on a planar
                # angle a moment (N m) and an angle (rad)
                "units": {"force": model.inputs[moving.input_index].unit.replace(".", " "),
                          "position": model.outputs[moving.output_index].unit},
                "loop_units": [{"force": model.inputs[p.input_index].unit.replace(".", " "),
                                "position": model.outputs[p.output_index].unit}
                               for p in design.pairs],
                # m: a held angle's target (loop_result.py)
                "size": RangeCheck(model).scale,
                "reference": ("profile" if path is None else "path") if reference is None
                else ("callable" if callable(reference) else "samples"),
                **_disturbance_settings(loop, quantum, disturbance)}
    if plant == "inprocess":  # the engine's compilation (first use only) is not the loop's
        prepare(model, loop_method=method)
    linear = None
    if plant == "linear":  # nor are the linear plant's eigenvectors, nor its loop's code
        linear = LinearPlant(model, linear_model=design_options.get("linear_model"))
        prepare_linear_loop(linear, loop)
    ended = {}  # the Simulator at t_N, for the kinematic inputs' efforts
    start, cpu_start = time.perf_counter(), time.process_time()
    with contextlib.ExitStack() as stack:
        # every plant's loop with one BLAS thread, the host's limits back after it
        # (sample_loop.py: small per-sample calls; several threads spin under load)
        stack.enter_context(blas_threads())
        if workdir is None and plant in ("fmu", "libcosim"):  # FMUs built for this run only
            workdir = stack.enter_context(tempfile.TemporaryDirectory(
                prefix="flexure_loop_", ignore_cleanup_errors=True))
        if linear is not None:
            t, r, position, force = linear_loop(linear, loop, design, progress=progress)
        else:
            t, r, position, force = _run_plant(plant, model, scene, loop, design,
                                               method=method, rtol=rtol, workdir=workdir,
                                               progress=progress, overrides=overrides,
                                               warn=warn_during, motion_duration=moving_for,
                                               ended=ended)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    recorded = dict(zip(coordinates, np.max(np.abs(position - position[0]), axis=0),
                        strict=True))
    settings["warnings"] = _warned(motion_warnings(model, recorded), found, warn)
    if moving_for is not None:
        settings["kinematic_inputs"] = motion_report(model, moving_for, ended["simulator"])
    return LoopResult(t=t, reference=r, position=position, force=force,
                      feedforward=loop.feedforward[: len(t)].copy(), stroke=stroke,
                      design=design.summary(), settings=settings, wall_time_s=wall,
                      cpu_time_s=cpu,
                      disturbance=None if loop.disturbance is None
                      else loop.disturbance[: len(t)].copy())


def _warned(messages, found, warn):
    """`found` and the `messages` about coordinates it does not name yet, each new one passed
    to `warn` (None: kept only)."""
    named = {message.split(" ", 1)[0] for message in found}
    new = [message for message in messages if message.split(" ", 1)[0] not in named]
    for message in new if warn is not None else ():
        warn(message)
    return [*found, *new]


def _disturbance_settings(loop, quantum, amplitude):
    """The disturbances as the summary reports them: the quantum (m, rad) and the force's
    amplitude (N, N m) per loop as given, and its frequency (Hz)."""
    d = loop.disturbances
    if d is None:
        return {}
    n = loop.offsets.size
    settings = {}
    if quantum is not None:
        settings["quantum"] = d.quantum.tolist()
    if amplitude is not None:
        given = np.broadcast_to(np.asarray(amplitude, float).reshape(-1), (n,))
        settings["disturbance"] = {"amplitude": given.tolist(), "frequency_hz": d.frequency_hz}
    return settings


def _run_plant(plant, model, scene, controller, design, *, method, rtol, workdir, progress,
               overrides, warn=None, motion_duration=None, ended=None):
    """t, reference, position, force of the loop on the plant named `plant`; an in-process
    plant's Simulator at t_N into ended["simulator"]."""
    ended = {} if ended is None else ended
    if plant in ("fmu", "libcosim"):  # the FMU plants' packages (pythonfmu, ...) only here
        from .cosim import run_cosimulation, scene_fmu
    if plant == "libcosim":
        return run_cosimulation(model, scene, controller, design, method=method, rtol=rtol,
                                workdir=workdir, progress=progress, overrides=overrides)
    if plant == "inprocess":
        if controller.compiled:
            return compiled_loop(model, controller, design, method=method, rtol=rtol,
                                 progress=progress, warn=warn, motion_duration=motion_duration,
                                 ended=lambda sim: ended.update(simulator=sim))
        adapter = InProcessPlant(model, method=method, rtol=rtol,
                                 motion_duration=motion_duration)
        ended["simulator"] = adapter.simulator
        return simulate_loop(adapter, controller, design, progress=progress)
    adapter = FmuPlant(scene_fmu(scene, model, workdir, overrides=overrides), method=method,
                       rtol=rtol, inputs=[port.name for port in model.inputs],
                       outputs=[port.name for port in model.outputs])
    try:
        return simulate_loop(adapter, controller, design, progress=progress)
    finally:
        adapter.close()
