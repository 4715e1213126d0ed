"""The engine's operations that a model does not use are not compiled for it, and a model that
uses one gets it on first use in the same process and cache: the demo stage of `flexure
loop` (planar, rigid clusters, no coils, no kinematic inputs, dense, small) connects neither
the coils' operation nor the sparse factors', the sparse Newton matrix's, the kinematic
inputs' or the large models' tangent product; a voltage-driven actuator's model after it
runs on the coils' operation and follows the exact solution of its linear ODE.

In a fresh interpreter (the process's table of operations is shared by every model of a
process: another test's model would have connected them), on the session's cache."""

import json
import subprocess
import sys
from pathlib import Path

PROBE = """
import json, sys
import numpy as np
sys.path.insert(0, {tests!r})
from flexure.core import build_model, load_scene, simulate
from flexure.core.engine import engine, operations
from test_actuators import exact_response, truss

def compiled():
    return {{op: engine.ENTRIES[op].is_compiled for op in range(len(engine.ENTRIES))}}

demo = load_scene("stage_planar_1dof")
for method in ("esdirk", "cvode-bdf", "ida"):
    simulate(demo, 2e-3, inputs={{"F": 1.0}}, method=method, rtol=1e-8)
after_demo = compiled()
times = np.linspace(0.0, 0.2, 41)
result = simulate(build_model(truss()), 0.2, inputs={{"F": 1.0}}, method="esdirk",
                  rtol=1e-8, output_times=times)
exact = exact_response(1.0, times)
error = float(np.max(np.abs(result.currents[:, 0] - exact[:, 2])) / np.max(exact[:, 2]))
print(json.dumps({{"after_demo": after_demo, "after_coils": compiled(), "error": error}}))
"""


def test_the_demo_compiles_no_unused_operation_and_a_coil_model_gets_its_own_after_it():
    from flexure.core.engine import engine, operations, sparse_factors  # noqa: F401

    tests = str(Path(__file__).resolve().parent)
    done = subprocess.run([sys.executable, "-c", PROBE.format(tests=tests)],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    found = json.loads(done.stdout.splitlines()[-1])
    after_demo = {int(op): flag for op, flag in found["after_demo"].items()}
    after_coils = {int(op): flag for op, flag in found["after_coils"].items()}
    unused = [engine.OP_COILS, operations.OP_SPARSE_FACTOR, operations.OP_SPARSE_SOLVE,
              *operations.NEWTON_OPERATIONS, operations.OP_PRESCRIBED_RHS,
              operations.OP_PRESCRIBED_JACOBIAN, operations.OP_PRESCRIBED_RESIDUAL,
              operations.OP_PRESCRIBED_RESIDUAL_JACOBIAN, operations.OP_ROW_PRODUCTS]
    assert not any(after_demo[op] for op in unused), {op: after_demo[op] for op in unused}
    # what the demo does use: its forms, and its rigid clusters' kernels
    for op in (engine.OP_RHS, engine.OP_JACOBIAN, engine.OP_RESIDUAL,
               engine.OP_RESIDUAL_JACOBIAN, operations.OP_RIGID_FILL):
        assert after_demo[op], op
    assert after_coils[engine.OP_COILS]
    # the coil current of a 1 V step (`test_actuators`): ESDIRK's global error at rtol 1e-8
    # measured a few rtol; 1e-6 of the peak
    assert found["error"] <= 1e-6
