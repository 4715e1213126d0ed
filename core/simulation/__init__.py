"""Time-domain simulation on the DOFs: the Simulator, the integrators (SUNDIALS CVODE and IDA,
ESDIRK), tolerances, the sampled loop, the work-precision study, the range-of-validity checks."""
