"""What the engine's status codes mean, in words for a SimulationError.

Kept out of the integrators' modules that report them (`sundials.py`, `esdirk.py`), so that
naming a failure does not load SUNDIALS' compiled callbacks, which a loop stepped by an
ESDIRK method never needs.
"""

from ..engine import data as ed

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
