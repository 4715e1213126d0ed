"""Design sweeps: a scene's analyses over a grid of overrides, on dask.distributed, into one
table.

- `grid`: the grid of parameter values, one point's analyses (`evaluate_point`) and the run
  over the grid (`run_sweep`);
- `analyses`: the registry of the analyses a sweep runs by name (a step response here, the
  closed loop registered by flexure.controllers);
- `table`: the table of the points, its CSV and Parquet files, and resuming it.
"""
