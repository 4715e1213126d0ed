"""The loop of a scene: its feedback (feedback.py) and feedforward (feedforward.py) designed
on the scene's linear model and put together in a `LoopController` (`build_loop`).

The feedforward is one of
- "modal": the inverse of the low-frequency model, u = m a + c v + k x (`low_frequency_model`);
- "inverse": the stable approximate inverse of the full linear model sampled with a zero-order
  hold (`StableInverse`, one loop only);
- none: feedback alone.
"""

import numpy as np

from flexure.core import FlexureError

from .feedback import DiscreteController, design_feedback
from .feedforward import StableInverse, drive_signals, low_frequency_model
from .loop_controller import LoopController
from .profiles import ThirdOrderProfile


class LoopError(FlexureError, ValueError):
    """A closed-loop run was asked for with impossible settings."""


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


def build_loop(model, *, stroke: float = 1e-3, duration: float = 1.0, fs: float = 4000.0,
               crossover: float = 300.0, feedforward=True, settle: float = 0.25, axis: int = 0,
               feedforward_model=None, path=None, design=None, **design_options):
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
    **design_options
        Passed on to `design_feedback`.

    Returns
    -------
    (LoopController, FeedbackDesign)
    """
    if not np.isfinite(stroke) or stroke == 0:
        raise LoopError(f"stroke must be a finite, non-zero distance (m), got {stroke}")
    for name, value in (("duration", duration), ("fs", fs), ("settle", settle)):
        if not np.isfinite(value) or (value <= 0 if name != "settle" else value < 0):
            raise LoopError(f"{name} must be a positive finite number, got {value}")
    if design is None:
        design = design_feedback(model, crossover=crossover, fs=fs, **design_options)
    n = len(design.pairs)
    if not 0 <= axis < n:
        raise LoopError(f"axis {axis} out of range: {model.name} has {n} loop(s)")
    kind = feedforward_kind(feedforward)
    if path is not None:
        if path.displacements.shape[1] != n:
            raise LoopError(f"the move path has {path.displacements.shape[1]} loop(s), "
                            f"{model.name} has {n}")
        if kind == "inverse":
            raise LoopError("a move path takes the 'modal' feedforward or none, not 'inverse'")
        stroke = 1.0  # the profile is the progress s along the path
    profile = ThirdOrderProfile(stroke, duration)
    samples = int(round((duration + settle) * fs))
    from flexure.core import output_value  # the models (numba, scipy) on first use

    offsets = [output_value(model, model.outputs[p.output_index], model.initial_coordinates)
               for p in design.pairs]
    lf, explicit = None, None
    if kind == "modal":
        lf = feedforward_model if feedforward_model is not None else low_frequency_model(model)
    elif kind == "inverse":
        explicit = _inverse_forces(model, design, profile, fs, samples, offsets)
    controller = LoopController(DiscreteController(design.controller), profile, fs=fs,
                                samples=samples, offsets=offsets, feedforward=lf, axis=axis,
                                feedforward_forces=explicit, path=path)
    driven = {actuator.input for actuator in model.actuators}
    if kind is not None and driven & {pair.input_index for pair in design.pairs}:
        # voice coils take drive signals: the feedforward forces through their coils
        signals = drive_signals(model, design.pairs, controller.feedforward,
                                controller.reference, fs)
        controller = LoopController(DiscreteController(design.controller), profile, fs=fs,
                                    samples=samples, offsets=offsets, axis=axis,
                                    feedforward_forces=signals, path=path)
    return controller, design


def _inverse_forces(model, design, profile, fs, samples, offsets):
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
    reference = offsets[0] - equilibrium + profile.position(k / fs)
    return inverse.apply(reference)[:, None]
