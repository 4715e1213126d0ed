"""The names of the integration methods, in one place (no numerical imports: the command
line registers its options from here without loading numba or SUNDIALS).

SUNDIALS_METHODS run SUNDIALS' multistep integrators (`flexure.core.simulation.sundials`) and
take a largest order; ONE_STEP_METHODS are the compiled one-step ESDIRKs
(`flexure.core.simulation.esdirk`), which take a held input's change without a restart.
"""

SUNDIALS_METHODS = ("cvode-bdf", "cvode-adams", "ida")
ONE_STEP_METHODS = ("esdirk", "esdirk3", "esdirk2")
METHODS = SUNDIALS_METHODS + ONE_STEP_METHODS
# The plant integrator of a sampled loop, and its relative tolerance, unless chosen. A changed
# force at every sample costs a one-step method one evaluation, and the sample period, not the
# order, bounds its step; TR-BDF2 has two implicit stages where esdirk3 has three. Measured
# at 4 kHz (1 mm in 1 s + 0.25 s; docs/decisions.md), against the loop on esdirk3 at 1e-11:
# esdirk2 at rtol 1e-5 takes one step per sample on stage_planar_1dof, stage_planar_3dof and
# stage_spatial_19dof, and their measured positions stay within 1.3e-9, 6.0e-9 and 1.3e-9 of the
# stroke (the loop's target is 1e-3, `flexure loop`'s 1e-7); esdirk3 at rtol 1e-6 stays within
# 6e-11, 1.8e-8 and 5e-10 in 1.2, 1.3 and 1.5 times the time. Tighter tolerances subdivide the
# samples for no visible gain (esdirk2 at 1e-6: two steps per sample on the spatial stage).
LOOP_METHOD = "esdirk2"
LOOP_RTOL = 1e-5

__all__ = ["LOOP_METHOD", "LOOP_RTOL", "METHODS", "ONE_STEP_METHODS", "SUNDIALS_METHODS"]
