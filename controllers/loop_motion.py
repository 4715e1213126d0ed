"""A scene's kinematic inputs in the closed loop: a known motion the loop rides on.

Each kinematic input (`[inputs.NAME] kind = "motion"`, `Model.kinematic_inputs`) follows the
scene's own move, the rest-to-rest quintic from its `start` to its `value`
(`Simulator.set_motion`), from t = 0 over the loop's `motion_duration` (default the loop's
move duration, so that the base moves while the loop moves); held at its value after. The
controller drives the force inputs as on any scene: its design linearises the model with the
kinematic inputs held (`flexure.core.analysis.linearization`), and the motion reaches the
loop as a disturbance it does not know of (no feedforward of it). The in-process plants take
it (the compiled loop and the Python loop around the Simulator); the linearised plant and the
FMU plants refuse it, naming the inputs and the plant.
"""

import math
from numbers import Real

from .errors import LoopError

# the plants that move the kinematic inputs along the scene's quintic
MOTION_PLANTS = ("inprocess",)


def motion_duration_of(model, plant, motion_duration, duration):
    """The duration (s) of the kinematic inputs' move in the loop, or None for a scene
    without them.

    Parameters
    ----------
    model : Model
    plant : str
        The loop's plant (`runner.PLANTS`).
    motion_duration : float or None
        s, > 0: as asked; None: `duration`.
    duration : float
        The loop's move duration, s.

    Raises
    ------
    LoopError
        A motion_duration for a scene without kinematic inputs, one that is not a finite
        number > 0, or a plant that does not move them (naming the inputs and the plant).
    """
    names = ", ".join(port.name for port in model.kinematic_inputs)
    if not model.kinematic_inputs:
        if motion_duration is not None:
            raise LoopError(f"motion_duration {motion_duration!r}: {model.name!r} has no "
                            "kinematic input to move ([inputs.NAME] kind = \"motion\")")
        return None
    if plant not in MOTION_PLANTS:
        raise LoopError(f"plant {plant!r} does not move the kinematic inputs ({names}) of "
                        f"{model.name!r}; the loop moves them on plant "
                        f"{' or '.join(repr(p) for p in MOTION_PLANTS)}")
    value = duration if motion_duration is None else motion_duration
    if isinstance(value, bool) or not (isinstance(value, Real) and math.isfinite(value)
                                       and value > 0):
        raise LoopError(f"motion_duration must be a finite number of seconds > 0, got "
                        f"{motion_duration!r}")
    return float(value)


def motion_report(model, motion_duration, simulator):
    """{name: {"start", "value" (m, rad), "motion_duration" (s), "effort_end" (N, N m)}} of
    each kinematic input, its effort the Simulator's at the loop's last sample
    (`Simulator.efforts`)."""
    efforts = simulator.efforts()
    return {port.name: {"start": float(start), "value": float(value),
                        "motion_duration": motion_duration, "effort_end": float(effort)}
            for port, start, value, effort in zip(
                model.kinematic_inputs, model.motion_starts, model.motion_values, efforts,
                strict=True)}
