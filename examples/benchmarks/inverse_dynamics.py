"""Inverse dynamics through the compiled engine against the numpy reference: CPU per time.

`inverse_dynamics(..., compiled=True)` and `free_inverse_dynamics(..., compiled=True)`
(the evaluations from the engine's operations, core/analysis/inverse_engine.py) over
`compiled=False` (the numpy `Mechanics`), the same path, in one process, alternating, medians
of CPU seconds (time.process_time), each model's engine packed by a first run before the
timed ones (as a second call on the same model finds it). The cases:

- `truss_1dof_x` (1 free coordinate), `stage_planar_3dof` with forces on y and phi (6) and
  `wire_tripod` (28), every DOF prescribed: 101 times of a sine path;
- `stage_spatial_19dof` with x prescribed by F, 18 DOFs free: 16 Radau IIA steps of 2.5 ms;
- `manipulator_control`'s end effector moved 6 mm in xy (the move in 1 s), 69 DOFs free:
  the first 50 ms at 5 ms steps (`move_inverse_dynamics`).

What a process pays to start the engine is not in these figures (the whole-process
comparisons in docs/benchmarks.md, 2026-11-30, are; they set the default's threshold,
`inverse_evaluation.ENGINE_MIN_WORK`).

Run alone: python -m examples.benchmarks.inverse_dynamics [--quick]
"""

import sys
import time

import numpy as np

from .measure import alternate, log
from .table import Row


def _wave(start, amplitude, omega):
    start, amplitude = np.asarray(start, float), np.asarray(amplitude, float)
    return lambda t: (start + amplitude * np.sin(omega * t),
                      amplitude * omega * np.cos(omega * t),
                      -amplitude * omega ** 2 * np.sin(omega * t))


def _stage_3dof():
    from flexure.core import build_model
    from flexure.core.scene.building import parse_toml, scene_path

    data = parse_toml(scene_path("stage_planar_3dof"))
    data["inputs"]["Fy"] = {"node": "3", "coordinate": "y"}
    data["inputs"]["M"] = {"node": "4", "coordinate": "phi"}
    data["outputs"]["phi"] = {"node": "4", "coordinate": "phi"}
    return build_model(data)


def _cases(quick):
    """{label: (times counted, run(compiled))}."""
    from flexure.core import load_scene, output_value, static_equilibrium
    from flexure.core.analysis.inverse_dynamics import inverse_dynamics
    from flexure.core.analysis.inverse_dynamics_free import free_inverse_dynamics

    t = np.linspace(0.0, 0.2, 101)
    truss, stage, tripod = load_scene("truss_1dof_x"), _stage_3dof(), load_scene("wire_tripod")
    spatial = load_scene("stage_spatial_19dof")
    x0 = output_value(spatial, spatial.outputs[0], static_equilibrium(spatial).x)
    steps = np.linspace(0.0, 0.04, 17)
    cases = {
        "truss_1dof_x, 101 times": (t.size, lambda c: inverse_dynamics(
            truss, t, _wave([0.1], [1e-3], 7.0), compiled=c)),
        "stage_planar_3dof, 101 times": (t.size, lambda c: inverse_dynamics(
            stage, t, _wave([0.0, 0.1, 0.0], [1e-3, 2e-6, 1e-4], 20.0), compiled=c)),
        "wire_tripod, 101 times": (t.size, lambda c: inverse_dynamics(
            tripod, t, _wave([0.0, 0.0, 0.0], [1e-3, 5e-4, 1e-2], 20.0),
            outputs=["x", "y", "rz"], compiled=c)),
        "stage_spatial_19dof free, 16 steps": (steps.size - 1, lambda c: free_inverse_dynamics(
            spatial, steps, _wave([x0], [1e-5], 50.0), outputs=["x"], compiled=c)),
    }
    if not quick:
        cases["manipulator_control free, 6 mm xy, 10 steps"] = (10, _manipulator())
    return cases


def _manipulator():
    """run(compiled): the 6 mm xy move's first 50 ms (`move_inverse_dynamics`)."""
    import flexure.core
    from examples.manipulator_loop import targets
    from flexure.controllers.dynamic_feedforward import move_inverse_dynamics
    from flexure.core import load_scene
    from flexure.core.analysis.inverse_dynamics_free import free_inverse_dynamics

    model = load_scene("manipulator_control")
    stroke = 6e-3 / np.sqrt(2)

    def run(compiled):
        flexure.core.free_inverse_dynamics = lambda *a, **k: free_inverse_dynamics(
            *a, compiled=compiled, **k)
        try:
            return move_inverse_dynamics(model, targets(stroke, stroke), duration=1.0,
                                         end=0.05, step=5e-3)
        finally:
            flexure.core.free_inverse_dynamics = free_inverse_dynamics
    return run


def inverse_dynamics(*, repeat=5, quick=False):
    """Rows: per case, the engine's CPU per time (or step) over the numpy path's."""
    rows = []
    for label, (count, run) in _cases(quick).items():
        engine_result, numpy_result = run(True), run(False)  # packs, warms
        scale = np.abs(numpy_result.forces).max()
        agreement = np.abs(engine_result.forces - numpy_result.forces).max() / scale

        def timed(compiled, run=run):
            start = time.process_time()
            run(compiled)
            return time.process_time() - start, None

        t = alternate({"engine": lambda: timed(True), "numpy": lambda: timed(False)},
                      repeat, f"inverse dynamics {label} (CPU s)")
        ratio = t["engine"].median / t["numpy"].median
        log(f"inverse dynamics {label}: engine/numpy {ratio:.3g}, forces agree to "
            f"{agreement:.2g} of their largest")
        rows.append(Row(f"inverse dynamics, {label}, engine per time",
                        f"{1e3 * t['engine'].median / count:.3f} ms",
                        f"numpy {1e3 * t['numpy'].median / count:.3f} ms", ratio,
                        ratio <= 1.0))
    return rows


if __name__ == "__main__":
    from .table import text_table

    print(text_table(inverse_dynamics(repeat=3, quick="--quick" in sys.argv),
                     "inverse dynamics, engine over numpy (CPU s per time)"))
