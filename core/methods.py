"""The names of the integration methods, in one place (no numerical imports: the command
line registers its options from here without loading numba or SUNDIALS).

SUNDIALS_METHODS run SUNDIALS' multistep integrators (`flexure.core.sundials`) and take a
largest order; ONE_STEP_METHODS are the compiled one-step ESDIRKs (`flexure.core.esdirk`),
which take a held input's change without a restart.
"""

SUNDIALS_METHODS = ("cvode-bdf", "cvode-adams", "ida")
ONE_STEP_METHODS = ("esdirk", "esdirk3")
METHODS = SUNDIALS_METHODS + ONE_STEP_METHODS
# the plant integrator of a sampled loop unless one is chosen: a changed force at every sample
# costs it one evaluation, and the sample period, not its order, limits its step
LOOP_METHOD = "esdirk3"

__all__ = ["LOOP_METHOD", "METHODS", "ONE_STEP_METHODS", "SUNDIALS_METHODS"]
