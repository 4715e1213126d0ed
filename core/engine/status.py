"""What the engine's status codes mean, in words for an error message.

The codes are the engine's (`data.OK`, `data.NOT_CONVERGED`, ...): compiled code never
raises, it returns one of them, and whichever caller turns a failure into an error (an
integrator, the sampled loop, the statics, an FMU's outputs) words it through
`status_message`, so that one failure reads the same wherever it happens. Kept apart from
the integrators' modules, so that naming a failure loads no compiled callback.
"""

from . import data as ed

STATUS_MESSAGES = {
    ed.NOT_CONVERGED: "the constraints could not be solved (Newton did not converge: the DOFs "
                      "may lie beyond the mechanism's reach or at a singular configuration)",
    ed.SINGULAR_CONSTRAINTS: "a singular configuration: the constraint Jacobian is singular, "
                             "the DOFs cannot describe the motion through it",
    ed.SINGULAR_MASS: "the reduced mass matrix M_bar is singular (a DOF without mass)",
    ed.NONFINITE_STATE: "the state became non-finite",
    ed.NONFINITE_RESULT: "non-finite accelerations (a singular configuration or a non-finite "
                         "force)",
    ed.NOT_CONNECTED: "the engine was called before engine.connect gave it its entry's address",
}


def status_message(status: int) -> str:
    """The words for the engine's failure status `status` (an int of `data`'s codes).

    OK and NOT_AVAILABLE (an operation that tells its caller to take another way) are not
    failures and have no message; if one, or a code the engine does not define, reaches an
    error, the words name its number, as a defect of flexure rather than of the scene.
    """
    code = int(status)
    return STATUS_MESSAGES.get(code, f"engine status {code} (not a failure the engine "
                                     "defines: a defect in flexure, please report it)")
