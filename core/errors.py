"""The exceptions flexure raises for a user's mistake or a failed computation.

Every one carries a message that names the place (file, key, element, load step, time) and
what was expected against what was found; the CLI prints it without a traceback.
"""


class FlexureError(Exception):
    """Base class of every error flexure reports to a user."""


class SceneError(FlexureError, ValueError):
    """A scene file or scene dictionary is malformed: wrong key, unknown node, bad value."""


class ConstraintError(FlexureError, ValueError):
    """The model is over- or under-constrained, or its DOF count does not match."""


class ConvergenceError(FlexureError, RuntimeError):
    """A Newton iteration (kinematics or statics) or an integrator failed to converge."""


class SimulationError(FlexureError, RuntimeError):
    """A time-domain simulation cannot go on: non-finite input, singular configuration, ..."""


class StepBudgetSpent(SimulationError):
    """An integrator took the step budget it was given for one call without reaching its end
    time; `last_good` is (t, y) of its last step."""


class UsageError(FlexureError, ValueError):
    """A command-line option or an output path cannot be used (checked before a run)."""


class OutputError(FlexureError, OSError):
    """A result could not be written (the file system refused it)."""
