"""The engine's operations that a model does not use are not compiled for it, and a model that
uses one gets it on first use in the same process and cache: the demo stage of `flexure
loop` (planar, rigid clusters, no coils, no kinematic inputs, dense, small) connects neither
the coils' operation nor the sparse factors', the sparse Newton matrix's, the kinematic
inputs', the large models' tangent product or the folded clusters' rigid bodies; a
voltage-driven actuator's model after it runs on the coils' operation and follows the exact
solution of its linear ODE, and a spatial model with a folded cluster (stage_spatial_1dof
under gravity, augmented form) runs on the rigid bodies' operation and its accelerations and
tangent match the numpy reference (`test_engine`'s plain formulas and tolerances).

In a fresh interpreter (the process's table of operations is shared by every model of a
process: another test's model would have connected them), on the session's cache."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
from test_engine import MODELS, close, plain_dynamics, plain_tangent

from flexure.core import Mechanics

PROBE = """
import json, sys
import numpy as np
sys.path.insert(0, {tests!r})
from flexure.core import Mechanics, build_model, load_scene, simulate
from flexure.core.engine import engine, operations
from flexure.core.engine.data import EngineData
from test_actuators import exact_response, truss
from test_engine import MODELS, evaluate, random_states

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
after_coils = compiled()
# a folded cluster's model: qddot and the tangent at two states (`test_engine`'s)
model = MODELS["stage_spatial_1dof_gravity"]()
data = EngineData(model, augmented=True)
q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
folded = []
for q, qdot, u in random_states(model, q0, seed=2):
    qddot = evaluate(data, q, qdot, u)
    tangents = []
    for acc in (qddot, 0.5 * qddot + 1.0):
        assert engine.call(data, engine.OP_TANGENT, np.array(acc)) == 0
        tangents.append([data.float_array(name).tolist() for name in ("stiffness", "damping")])
    folded.append({{"q": q.tolist(), "qdot": qdot.tolist(), "u": u.tolist(),
                    "qddot": qddot.tolist(), "tangents": tangents}})
print(json.dumps({{"after_demo": after_demo, "after_coils": after_coils, "error": error,
                  "bodies": len(data.rigid.bodies.per_cluster), "after_folded": compiled(),
                  "folded": folded}}))
"""


def test_the_demo_compiles_no_unused_operation_and_a_coil_model_gets_its_own_after_it():
    from flexure.core.engine import engine, operations, sparse_factors  # noqa: F401

    tests = str(Path(__file__).resolve().parent)
    # the tests' folder for their modules, the repository's for `tests.compiled_loops`
    done = subprocess.run([sys.executable, "-c", PROBE.format(tests=tests)],
                          capture_output=True, text=True, check=False,
                          cwd=str(Path(tests).parent))
    assert done.returncode == 0, done.stderr[-3000:]
    found = json.loads(done.stdout.splitlines()[-1])
    after_demo = {int(op): flag for op, flag in found["after_demo"].items()}
    after_coils = {int(op): flag for op, flag in found["after_coils"].items()}
    unused = [engine.OP_COILS, operations.OP_SPARSE_FACTOR, operations.OP_SPARSE_SOLVE,
              *operations.NEWTON_OPERATIONS, operations.OP_PRESCRIBED_RHS,
              operations.OP_PRESCRIBED_JACOBIAN, operations.OP_PRESCRIBED_RESIDUAL,
              operations.OP_PRESCRIBED_RESIDUAL_JACOBIAN, operations.OP_ROW_PRODUCTS,
              operations.OP_RIGID_BODIES]
    assert not any(after_demo[op] for op in unused), {op: after_demo[op] for op in unused}
    # what the demo does use: its forms, and its rigid clusters' kernels
    for op in (engine.OP_RHS, engine.OP_JACOBIAN, engine.OP_RESIDUAL,
               engine.OP_RESIDUAL_JACOBIAN, operations.OP_RIGID_FILL):
        assert after_demo[op], op
    assert after_coils[engine.OP_COILS]
    # the coil current of a 1 V step (`test_actuators`): ESDIRK's global error at rtol 1e-8
    # measured a few rtol; 1e-6 of the peak
    assert found["error"] <= 1e-6
    # the folded cluster's model: its operation compiled on first use, after the demo's
    assert found["bodies"] == 1
    assert not found["after_coils"][str(operations.OP_RIGID_BODIES)]
    assert found["after_folded"][str(operations.OP_RIGID_BODIES)]
    model = MODELS["stage_spatial_1dof_gravity"]()
    mechanics = Mechanics(model)
    n = mechanics.kinematics.dofs_of(model.initial_coordinates).size
    for state in found["folded"]:
        q, qdot, u, qddot = (np.array(state[key]) for key in ("q", "qdot", "u", "qddot"))
        plain = plain_dynamics(model, mechanics, q, qdot, u)
        DF, mass = plain["config"].DF, plain["mass"]
        size = np.max(plain["size"])
        # as test_engine's test_accelerations_match_the_plain_equations_of_motion
        close(mass @ qddot, DF.T @ plain["r"], 1e-14, scale=size)
        close(qddot, plain["qddot"], 1.0, scale=1e-14 * size / np.linalg.eigvalsh(mass)[0])
        # as its test_tangent_matches_the_plain_stiffness_and_damping
        for acc, (stiffness, damping) in zip((qddot, 0.5 * qddot + 1.0), state["tangents"],
                                             strict=True):
            K, C = plain_tangent(mechanics, plain, acc)
            close(np.reshape(stiffness, (n, n)), K, 1e-10)
            close(np.reshape(damping, (n, n)), C, 1e-12, scale=max(np.max(np.abs(C)), 1e-300))
