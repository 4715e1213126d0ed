"""The error of the closed loop's settings, in a module of its own so that every module of the
loop (the controller, the references, the disturbances, the design) can raise it."""

from flexure.core import FlexureError


class LoopError(FlexureError, ValueError):
    """A closed-loop run was asked for with impossible settings."""
