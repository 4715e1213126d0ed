"""The move a scene records for its kinematic inputs, as a path in time.

Each kinematic input carries two values ([inputs.NAME] `start` and `value`,
`Model.motion_starts` and `Model.motion_values`): where a run starts and where it ends, the
end being what a static solution holds. A SPACAR file gives them as INPUTX (INPUTE) and its
increment DELINPX (DELINPE) over the run. SPACAR's static run steps through the increment
without time; a simulation needs the move as a function of time, with its rate and
acceleration (the equations of motion take M_fk u''). `increment_path` makes it the
rest-to-rest quintic over a duration T from t0, for each input

    u(t) = u0 + (u1 - u0) s(tau),   s = 10 tau^3 - 15 tau^4 + 6 tau^5,   tau = (t - t0) / T

(held at u0 before t0 and at u1 after t0 + T), whose rate and acceleration start and end at
zero: a ramp's acceleration would be two impulses. It is the path `motion_response` and
`inverse_dynamics` take, and a single piece of the piecewise polynomial the compiled engine
is to evaluate (docs/analyses.md, "What the compiled engine needs").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SceneError

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model
    from .inverse_dynamics import Path


def increment_path(model: Model, duration: float, *, t0: float = 0.0) -> Path:
    """The kinematic inputs' move from their `start` to their `value` (module docstring).

    Parameters
    ----------
    model : Model
        With at least one kinematic input.
    duration : float
        s, > 0: the time the move takes.
    t0 : float
        s: when it starts.

    Returns
    -------
    callable
        path(t) -> (values, rates, accelerations), each (n_kinematic,): m, m/s, m/s^2 (rad,
        rad/s, rad/s^2 on an angle) in the order of `Model.kinematic_inputs`.

    Raises
    ------
    SceneError
        No kinematic input, or a duration that is not a finite number > 0.
    """
    if not model.kinematic_inputs:
        raise SceneError(f"{model.source}: {model.name!r} has no kinematic input to move")
    if not (np.isfinite(duration) and duration > 0.0 and np.isfinite(t0)):
        raise SceneError(f"{model.source}: the move's duration must be a finite number of "
                         f"seconds > 0 from a finite t0, got {duration!r} from {t0!r}")
    start = np.array(model.motion_starts, dtype=float)
    increment = np.array(model.motion_values, dtype=float) - start

    def path(t):
        tau = min(max((t - t0) / duration, 0.0), 1.0)  # held before and after the move
        s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
        ds = 30.0 * tau**2 * (1.0 - tau) ** 2 / duration
        dds = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau) / duration**2
        return start + increment * s, increment * ds, increment * dds

    return path


__all__ = ["increment_path"]
