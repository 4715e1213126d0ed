"""Design sweeps: a scene's analyses (statics, modes, buckling, and those registered by name,
a step response or the closed loop) over a grid of overrides, on dask.distributed, into one
table."""
