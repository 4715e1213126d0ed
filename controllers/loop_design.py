"""The loop of a scene: its feedback (feedback.py) and feedforward (feedforward.py) designed
on the scene's linear model and put together in a `LoopController` (`build_loop`).

The feedforward is one of
- "modal": the inverse of the low-frequency model, u = m a + c v + k x (`low_frequency_model`);
- "inverse": the stable approximate inverse of the full linear model sampled with a zero-order
  hold (`StableInverse`, one loop only);
- none: feedback alone.

The feedback is designed here (feedback.py) unless one's own is given (`controller`,
user_controller.py); the reference is the third-order profile of one loop, a move path of
every loop, or given as samples or a callable (`reference`, user_reference.py). Encoder
quantisation and a sinusoidal force at the actuators (disturbances.py) are optional.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .disturbances import MAINS_HZ, Disturbances, loop_disturbances
from .errors import LoopError
from .feedback import DiscreteController, design_feedback
from .feedforward import StableInverse, drive_signals, low_frequency_model
from .loop_controller import LoopController
from .profiles import ThirdOrderProfile
from .user_controller import user_design
from .user_reference import reference_samples

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from flexure.core import Model

    from .feedback import FeedbackDesign
    from .feedforward import LowFrequencyModel
    from .move_path import MovePath


def feedforward_kind(feedforward) -> str | None:
    """"modal", "inverse" or None (feedback alone) for a `feedforward` setting.

    True and "modal" mean "modal"; False, None and "none" mean None; LoopError otherwise.
    """
    if feedforward is True or feedforward == "modal":
        return "modal"
    if feedforward is False or feedforward is None or feedforward == "none":
        return None
    if feedforward == "inverse":
        return "inverse"
    raise LoopError(f"feedforward must be 'modal', 'inverse' or False, got {feedforward!r}")


def build_loop(model: Model, *, stroke: float = 1e-3, duration: float = 1.0,
               fs: float = 4000.0, crossover: float = 300.0, feedforward: bool | str = True,
               settle: float = 0.25, axis: int = 0,
               feedforward_model: LowFrequencyModel | None = None,
               path: MovePath | None = None, design: FeedbackDesign | None = None,
               controller: object | None = None,
               reference: ArrayLike | Callable[[float], ArrayLike] | None = None,
               quantum: float | Sequence[float] | None = None,
               disturbance: float | Sequence[float] | None = None,
               disturbance_hz: float = MAINS_HZ,
               feedforward_forces: ArrayLike | None = None, **design_options: Any,
               ) -> tuple[LoopController, FeedbackDesign]:
    """Design the feedback and the feedforward of `model`; returns (LoopController, design).

    Parameters
    ----------
    model : Model
        The scene (flexure.core.load_scene).
    stroke, duration : float
        The third-order move of loop `axis` (m, s).
    fs : float
        Sample rate (Hz).
    crossover : float
        The requested cross-over (rad/s).
    feedforward : bool or str
        True or "modal" (the inverse of the low-frequency model, m a + c v + k x), "inverse"
        (the stable approximate inverse of the full linear model sampled with a zero-order
        hold, `StableInverse`: one loop only), or False for feedback alone.
    settle : float
        Time (s) after the move the controller runs for.
    axis : int
        The loop that moves; the others hold their initial position.
    feedforward_model : LowFrequencyModel, optional
        Replaces the low-frequency model derived from `model` (e.g. a deliberately wrong one,
        `low_frequency_model(model).scaled(mass=1.1, stiffness=1.1)`).
    path : MovePath, optional
        Every loop follows its displacement along this path (move_path.py) in `duration`;
        `stroke` and `axis` are then unused; the feedforward is "modal" or none.
    design : FeedbackDesign, optional
        A feedback designed before (`design_feedback`), reused instead of designing again.
    controller : python-control system, list of them, callable or list of callables, optional
        One's own feedback instead of the designed one (user_controller.py): a discrete
        system with dt = 1 / fs from the errors (m, rad) to the forces (N, N m), n_loops x
        n_loops or one SISO system per loop, checked for closed-loop stability on the scene's
        linear model; or f(k, e) -> u per loop (not checked).
    reference : array or callable, optional
        The loops' positions (m, rad) instead of the profile (user_reference.py): samples
        (N+1,) or (N+1, n_loops) at fs, which set the run's length (`duration`, `settle`,
        `stroke` and `axis` then unused), or r(t) called at each sample time of
        `duration` + `settle`. The modal feedforward differentiates its cubic spline.
    quantum : float or sequence, optional
        The encoders' quantum (m, rad): the controller sees the positions rounded to it.
    disturbance : float or sequence, optional
        The amplitude (N, N m) of a sinusoidal force added at each loop's actuator,
        d_k = a sin(2 pi f t_k) held with the force (disturbances.py); on an input a voice
        coil drives by current it enters as the drive signal d / (Km G).
    disturbance_hz : float
        Its frequency f (Hz), below fs / 2; default 50 Hz (the mains).
    feedforward_forces : array_like (N+2, n_loops), optional
        The feedforward forces (N, N m) held from each sample k = 0 .. N+1, given instead of
        designed (e.g. `dynamic_feedforward`'s, from the nonlinear inverse dynamics);
        `feedforward` is then unused. Through voice coils they become drive signals.
    **design_options
        Passed on to `design_feedback` (with `controller`: only `plant` and
        `linear_model`, the model the loops are checked on). A `linear_model` also serves
        the modal feedforward, unless `feedforward_model` is given; `loops` ("INPUT:OUTPUT"
        pairs, `colocated_pairs`) chooses the loops, the other inputs held open.

    Returns
    -------
    (LoopController, FeedbackDesign)
        The controller, ready to run at fs, and the feedback's design with its margins.

    Raises
    ------
    LoopError
        A bad stroke, duration, settle, axis, feedforward setting, reference, quantum or
        disturbance; design options with one's own controller; a path together with a
        reference or the "inverse" feedforward.
    ControlDesignError
        The feedback or feedforward cannot be designed (no colocated output, an unstable
        closed loop, a sample rate or cross-over out of range).
    """
    if not np.isfinite(stroke) or stroke == 0:
        raise LoopError(f"stroke must be a finite, non-zero distance (m), got {stroke}")
    for name, value in (("duration", duration), ("fs", fs), ("settle", settle)):
        if not np.isfinite(value) or (value <= 0 if name != "settle" else value < 0):
            raise LoopError(f"{name} must be a positive finite number, got {value}")
    if path is not None and design_options.get("loops") is not None:
        raise LoopError("loops: a move path is planned on every input's colocated loop; "
                        "choose the loops without --move")
    if controller is not None:
        if design is not None:
            raise LoopError("give a designed feedback (design) or a controller of one's own "
                            "(controller), not both")
        if design_options.pop("loops", None) is not None:
            raise LoopError("loops: a controller of one's own closes every input's colocated "
                            "loop; choosing the loops takes the built-in feedback")
        unused = sorted(set(design_options) - {"plant", "linear_model"})
        if unused:
            raise LoopError(f"{', '.join(unused)}: design options of the built-in feedback, "
                            "not used with a controller of one's own")
        feedback, design = user_design(model, controller, fs=fs, crossover=crossover,
                                       **design_options)
    else:
        if design is None:
            design = design_feedback(model, crossover=crossover, fs=fs, **design_options)
        feedback = DiscreteController(design.feedback)
    n = len(design.pairs)
    if not 0 <= axis < n:
        raise LoopError(f"axis {axis} out of range: {model.name} has {n} loop(s)")
    kind = feedforward_kind(feedforward)
    units = loop_units(model, design.pairs)
    samples = int(round((duration + settle) * fs))
    profile, given = None, None
    if reference is not None:
        if path is not None:
            raise LoopError("a move path and a given reference are two references: give one")
        given, samples, _ = reference_samples(reference, n_loops=n, fs=fs, samples=samples,
                                              unit=units[0][0])
    elif path is not None:
        if path.displacements.shape[1] != n:
            raise LoopError(f"the move path has {path.displacements.shape[1]} loop(s), "
                            f"{model.name} has {n}")
        if kind == "inverse":
            raise LoopError("a move path takes the 'modal' feedforward or none, not 'inverse'")
        profile = ThirdOrderProfile(1.0, duration)  # the progress s along the path
    else:
        profile = ThirdOrderProfile(stroke, duration)
    disturbances = coil_disturbances(model, design.pairs, loop_disturbances(
        n, fs=fs, quantum=quantum, amplitude=disturbance, frequency_hz=disturbance_hz,
        units=units[0]))
    from flexure.core import output_value  # the models (numba, scipy) on first use

    offsets = [output_value(model, model.outputs[p.output_index], model.initial_coordinates)
               for p in design.pairs]
    lf, explicit = None, None
    if feedforward_forces is not None:
        explicit = np.asarray(feedforward_forces, float)
        if explicit.shape != (samples + 2, n) or not np.all(np.isfinite(explicit)):
            raise LoopError(f"feedforward_forces: expected finite forces of shape "
                            f"({samples + 2}, {n}) (the samples k = 0 .. N+1, one column per "
                            f"loop), got shape {explicit.shape}")
        kind = "given"
    elif kind == "modal":
        lf = feedforward_model if feedforward_model is not None else low_frequency_model(
            model, linear_model=design_options.get("linear_model"), pairs=design.pairs)
    elif kind == "inverse":
        explicit = _inverse_forces(model, design, profile, fs, samples, offsets, given)
    options = {"fs": fs, "samples": samples, "offsets": offsets, "axis": axis, "path": path,
               "reference": given, "disturbances": disturbances}
    loop = LoopController(feedback, profile, feedforward=lf, feedforward_forces=explicit,
                          **options)
    driven = {actuator.input for actuator in model.actuators}
    if kind is not None and driven & {pair.input_index for pair in design.pairs}:
        # voice coils take drive signals: the feedforward forces through their coils
        signals = drive_signals(model, design.pairs, loop.feedforward, loop.reference, fs)
        loop = LoopController(feedback, profile, feedforward_forces=signals, **options)
    return loop, design


def loop_units(model, pairs) -> list[tuple[str, str]]:
    """Each loop's (position unit, force unit): m and N, or rad and N m on an angle (the
    force's, also where a voice coil's drive signal (V) is the input)."""
    units = []
    for pair in pairs:
        position = model.outputs[pair.output_index].unit
        units.append((position, "N m" if position == "rad" else "N"))
    return units


def coil_disturbances(model, pairs, disturbances: Disturbances | None):
    """The disturbance on the plant's inputs: a force (N, N m) where the input is one, the
    drive signal d / (Km G) (V) where a voice coil driven by current takes it (its force is
    Km G u below the amplifier's saturation, so the force added is d exactly). LoopError on
    a voltage-driven coil, whose current lags its drive signal."""
    if disturbances is None or disturbances.amplitude is None or not model.actuators:
        return disturbances
    amplitude = disturbances.amplitude.copy()
    for actuator in model.actuators:
        loops = [k for k, pair in enumerate(pairs) if pair.input_index == actuator.input]
        if not loops:
            continue
        if actuator.drive != "current":
            raise LoopError(f"{model.source}: actuator {actuator.name!r} drives input "
                            f"{pairs[loops[0]].input_name!r} by voltage: a disturbance force "
                            "through its coil would lag the drive signal; a disturbance "
                            "needs a force input or a current drive")
        amplitude[loops[0]] /= actuator.force_constant * actuator.amplifier_gain
    return Disturbances(disturbances.quantum, amplitude, disturbances.frequency_hz)


def _inverse_forces(model, design, profile, fs, samples, offsets, given=None):
    """Feedforward from the stable inverse of the sampled full linear model (one loop)."""
    import control  # 0.5 s to import: only where it is used

    # the models (numba, scipy) on first use
    from flexure.core import linearize, output_value, state_space

    if len(design.pairs) != 1:
        raise LoopError(f"{model.name}: the 'inverse' feedforward handles one loop, the scene "
                        f"has {len(design.pairs)}; use the 'modal' feedforward")
    pair = design.pairs[0]
    lin = linearize(model)
    plant = state_space(model, linear_model=lin)[pair.output_index, pair.input_index]
    inverse = StableInverse(control.c2d(plant, 1.0 / fs, method="zoh"))
    equilibrium = output_value(model, model.outputs[pair.output_index], lin.solution.config.x)
    k = np.arange(samples + 2)
    # u_k, held on [t_k, t_k+1), makes the sampled linear output follow r_k (deviations
    # from the linearisation point, which carries the scene's constant loads).
    if given is None:
        reference = offsets[0] - equilibrium + profile.position(k / fs)
    else:
        reference = given[:, 0] - equilibrium
    return inverse.apply(reference)[:, None]
