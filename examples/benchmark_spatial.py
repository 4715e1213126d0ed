"""Speed of the spatial stage: 1 s of the 19-DOF model under a VCM force, CVODE and IDA.

The scene `stage_spatial_19dof` starts at rest in its static equilibrium under its own 1 N
sideways; the VCM adds a force rising from 0 to 1 N in 0.5 s (the smooth step
s^3 (10 - 15 s + 6 s^2)) and holds it. The table gives, per integrator and tolerance, the
integrator steps, right-hand-side and Jacobian evaluations, the wall time (s) and the bar's
position at the end against its static value under the scene's load plus 1 N (2 N for the
19-DOF scene, 1 N for the 1-DOF ones). The 1-DOF spatial and planar stages are there for
comparison: the same equations, the spatial one through Euler parameters.

Run `python examples/benchmark_spatial.py`; the speed targets live here, not in the tests.
"""

import time

import numpy as np

from flexure.core import load_scene, static_equilibrium
from flexure.core.reporting.tables import format_table
from flexure.core.simulation.simulation import simulate

METHODS = ("cvode-bdf", "ida")


def vcm(t):
    """The VCM force (N): a smooth step from 0 to 1 N over 0.5 s."""
    s = min(max(t / 0.5, 0.0), 1.0)
    return s**3 * (10 - 15 * s + 6 * s * s)


def run(scene, method, *, t_end=1.0, rtol=1e-8):
    """One simulation from the static equilibrium; a row of the table."""
    model = load_scene(scene)
    start = static_equilibrium(model)
    loads = model.loads.copy()
    loads[model.coordinate_index("3.x")] += 1.0
    target = static_equilibrium(model, loads=loads).x[model.coordinate_index("3.x")]
    clock = time.perf_counter()
    result = simulate(model, t_end, inputs={"F": vcm}, method=method, rtol=rtol, q0=start.q,
                      output_times=np.linspace(0.0, t_end, 11))
    wall = time.perf_counter() - clock
    stats = result.statistics
    return (scene, method, rtol, stats["steps"], stats["rhs_evaluations"],
            stats["jacobian_evaluations"], wall, result.outputs["x"][-1] * 1e3, target * 1e3)


def benchmark(*, t_end=1.0, scenes=("stage_spatial_19dof", "stage_spatial_1dof",
                                     "stage_planar_1dof"), rtols=(1e-6, 1e-8)):
    """All rows: every scene, integrator and tolerance."""
    return [run(scene, method, t_end=t_end, rtol=rtol)
            for scene in scenes for method in METHODS for rtol in rtols]


HEADER = ["scene", "method", "rtol", "steps", "f evals", "J evals", "wall (s)",
          "x(t_end) (mm)", "x static (mm)"]

if __name__ == "__main__":
    print(format_table(HEADER, benchmark(),
                       title="1 s under a VCM force (a smooth 1 N step in 0.5 s)"))
