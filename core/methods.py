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
# its relative tolerance unless one is chosen. The sample period bounds the step: at 4 kHz the
# loops of stage_planar_1dof, stage_planar_3dof and stage_spatial_19dof take one step per
# sample from rtol 1e-7 up, and their measured positions stay within 6e-11, 1.8e-8 and 5e-10 of
# the stroke of a rtol 1e-11 run at rtol 1e-6 (the loop's target is 1e-3, `flexure loop`'s
# 1e-7); at 1e-8 the spatial stage needs four steps per sample for no visible gain
LOOP_RTOL = 1e-6

__all__ = ["LOOP_METHOD", "LOOP_RTOL", "METHODS", "ONE_STEP_METHODS", "SUNDIALS_METHODS"]
