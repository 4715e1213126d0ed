"""Tutorial 2: a scene as an FMI 2.0 co-simulation FMU, stepped by fmpy, against the same run
in flexure itself.

    python examples/tutorials/fmu_in_fmpy.py

`flexure.fmu.build_scene_fmu` packs the built-in scene truss_1dof_x (a 0.2 kg mass on a truss
spring, 1 N of constant load in the scene) with its own copy of flexure into truss.fmu. fmpy
then steps it at 1 ms for 0.2 s with 0.5 N more on its input F; the FMU's output x (m) is
compared with `flexure.core.simulate` on the same grid, with the FMU's integrator settings
(its parameters integrator.method and integrator.rtol: esdirk at 1e-6 unless a host sets
them). The FMU's first instantiation on a machine compiles its engine once (tens of seconds);
later ones load the cache.
"""

import tempfile
from pathlib import Path

import numpy as np
from fmpy import read_model_description, simulate_fmu

from flexure.core import load_scene, simulate
from flexure.fmu import build_scene_fmu

STEP, STOP, FORCE = 1e-3, 0.2, 0.5  # s, s, N
METHOD, RTOL = "esdirk", 1e-6  # the scene FMU's default integrator (docs/fmu.md)


def main():
    """Build, step in fmpy, compare; print and return the largest difference (m)."""
    with tempfile.TemporaryDirectory() as folder:
        fmu = build_scene_fmu("truss_1dof_x", Path(folder) / "truss.fmu")
        variables = [v.name for v in read_model_description(str(fmu)).modelVariables]
        print(f"{fmu.name}: variables {', '.join(variables)}")
        inputs = np.array([(0.0, FORCE), (STOP, FORCE)], dtype=[("time", float), ("F", float)])
        by_fmpy = simulate_fmu(str(fmu), stop_time=STOP, step_size=STEP,
                               output_interval=STEP, input=inputs, output=["x"])
    by_flexure = simulate(load_scene("truss_1dof_x"), STOP, inputs={"F": FORCE},
                          method=METHOD, rtol=RTOL, output_times=by_fmpy["time"])
    difference = np.max(np.abs(by_fmpy["x"] - by_flexure.outputs["x"]))
    last = by_flexure.outputs["x"][-1]
    print(f"x at {STOP} s: fmpy {by_fmpy['x'][-1]:.9f} m, flexure {last:.9f} m")
    print(f"largest difference over {by_fmpy['time'].size} samples: {difference:.2e} m")
    return difference


if __name__ == "__main__":
    main()
