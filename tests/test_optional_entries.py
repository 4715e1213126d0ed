"""The engine's operations that a model does not use are not compiled for it, and a model that
uses one gets it on first use in the same process and cache: the demo stage of `flexure
loop` (planar, rigid clusters, no coils, no kinematic inputs, dense, small) connects neither
the coils' operation nor the sparse factors', the sparse Newton matrix's, the kinematic
inputs', the large models' tangent product, the folded clusters' rigid bodies or the BEAMs'
directional rates; a voltage-driven actuator's model after it runs on the coils' operation
and follows the exact solution of its linear ODE, and a spatial model with a folded cluster
(stage_spatial_1dof under gravity, augmented form) runs on the rigid bodies' operation (and
its BEAMs on their directional rates') and its accelerations and tangent match the numpy
reference (`test_engine`'s plain formulas and tolerances); a model with a moment input
(wire_tripod) runs on the moment inputs' load stiffness operation and its tangent matches
the plain one; and the demo's closed loop (`flexure loop`, its output a DOF) compiles
neither the sampled loop's measuring entry nor the deformations' operation (its DOF is a
coordinate), which a loop on an output that is not a DOF (truss_1dof_e's x, its DOF the
elongation) then gets, giving the Python loop's positions and forces to the bit and the
plain kinematics' DOFs at the scene's configuration.

In a fresh interpreter (the process's table of operations is shared by every model of a
process: another test's model would have connected them), on the session's cache."""

import json
import sys
from pathlib import Path

import children
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

from flexure.core.cli import main
from flexure.core.simulation.sampled_measure import measure_entry
demo = load_scene("stage_planar_1dof")
for method in ("esdirk", "cvode-bdf", "ida"):
    simulate(demo, 2e-3, inputs={{"F": 1.0}}, method=method, rtol=1e-8)
main(["loop", "--no-plot"])  # README command 1, the demo's closed loop
after_demo = compiled()
measuring_after_demo = measure_entry.is_compiled
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
data_folded_bodies = data.rigid.bodies.per_cluster
folded = []
for q, qdot, u in random_states(model, q0, seed=2):
    qddot = evaluate(data, q, qdot, u)
    tangents = []
    for acc in (qddot, 0.5 * qddot + 1.0):
        assert engine.call(data, engine.OP_TANGENT, np.array(acc)) == 0
        tangents.append([data.float_array(name).tolist() for name in ("stiffness", "damping")])
    folded.append({{"q": q.tolist(), "qdot": qdot.tolist(), "u": u.tolist(),
                    "qddot": qddot.tolist(), "tangents": tangents}})
after_folded = compiled()
# a moment input's model: the tangent at two states, with their moments not zero
model = MODELS["wire_tripod"]()
data = EngineData(model)
q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
moments = []
for q, qdot, u in random_states(model, q0, seed=3):
    qddot = evaluate(data, q, qdot, u)
    assert engine.call(data, engine.OP_TANGENT, np.array(qddot)) == 0
    moments.append({{"q": q.tolist(), "qdot": qdot.tolist(), "u": u.tolist(),
                     "qddot": qddot.tolist(),
                     "stiffness": data.float_array("stiffness").tolist()}})
after_moments = compiled()
# a loop whose output is not a DOF (truss_1dof_e's x; its DOF the elongation): the compiled
# loop (ESDIRK, as the demo's) against the Python loop of Simulator calls
from flexure.controllers import build_loop
from flexure.controllers.plants import InProcessPlant
from flexure.controllers.runner import simulate_loop
from flexure.core import Simulator
from tests.compiled_loops import run_compiled_loop
model = load_scene("truss_1dof_e")
controller, design = build_loop(model, stroke=1e-4, duration=0.02, settle=0.005, fs=4000.0)
t, _, position, force = simulate_loop(InProcessPlant(model, method="esdirk", rtol=1e-7),
                                      controller, design)
sim = Simulator(model, method="esdirk", rtol=1e-7)
t_c, position_c, force_c = run_compiled_loop(sim, controller, design)
config = Mechanics(model).kinematics.solve(sim.absolute(sim.state)[:sim.ndof],
                                           model.initial_coordinates.copy())
output = model.outputs[design.pairs[0].output_index].coordinate
loop = {{"same": bool(np.array_equal(t_c, t) and np.array_equal(position_c, position)
                      and np.array_equal(force_c, force)),
        "moved": float(np.ptp(position)), "last": float(position_c[-1, 0]),
        "plain": float(config.x[output]), "compiled": measure_entry.is_compiled,
        "deformations": engine.ENTRIES[engine.OP_DEFORMATIONS].is_compiled}}
# its DOF is a deformation (the elongation): the scene's DOFs through the engine and plain
from flexure.core.simulation.start import scene_dofs
loop["start"] = scene_dofs(model, EngineData(model)).tolist()
loop["start_plain"] = Mechanics(model).kinematics.dofs_of(model.initial_coordinates).tolist()
print(json.dumps({{"after_demo": after_demo, "after_coils": after_coils, "error": error,
                  "bodies": len(data_folded_bodies), "after_folded": after_folded,
                  "folded": folded, "after_moments": after_moments, "moments": moments,
                  "measuring_after_demo": measuring_after_demo, "loop": loop}}))
"""


def _probe():
    """The probe's findings, from a fresh interpreter."""
    tests = str(Path(__file__).resolve().parent)
    # the tests' folder for their modules, the repository's for `tests.compiled_loops`
    done = children.run([sys.executable, "-c", PROBE.format(tests=tests)],
                        capture_output=True, text=True, check=False,
                        cwd=str(Path(tests).parent))
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


def test_the_demo_compiles_no_unused_operation_and_a_model_that_uses_one_gets_it_after_it():
    from flexure.core.engine import engine, operations, sparse_factors  # noqa: F401

    found = _probe()
    after_demo = {int(op): flag for op, flag in found["after_demo"].items()}
    after_coils = {int(op): flag for op, flag in found["after_coils"].items()}
    unused = [engine.OP_COILS, operations.OP_SPARSE_FACTOR, operations.OP_SPARSE_SOLVE,
              *operations.NEWTON_OPERATIONS, operations.OP_PRESCRIBED_RHS,
              operations.OP_PRESCRIBED_JACOBIAN, operations.OP_PRESCRIBED_RESIDUAL,
              operations.OP_PRESCRIBED_RESIDUAL_JACOBIAN, operations.OP_ROW_PRODUCTS,
              operations.OP_RIGID_BODIES, operations.OP_INPUT_STIFFNESS,
              operations.OP_FORMED_RATES,
              engine.OP_DEFORMATIONS]  # the demo's DOF is a coordinate: no deformation needed
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
    # its BEAMs form their quadratic forms (`formed_rates`): that operation too, after the demo
    assert not found["after_coils"][str(operations.OP_FORMED_RATES)]
    assert found["after_folded"][str(operations.OP_FORMED_RATES)]
    for state, mechanics, plain, n in _with_plain("stage_spatial_1dof_gravity", found["folded"]):
        qddot = np.array(state["qddot"])
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
    # the moment input's model: its load stiffness compiled on first use, after the others';
    # K as test_engine's test_tangent_matches_the_plain_stiffness_and_damping (1e-10)
    assert not found["after_folded"][str(operations.OP_INPUT_STIFFNESS)]
    assert found["after_moments"][str(operations.OP_INPUT_STIFFNESS)]
    for state, mechanics, plain, n in _with_plain("wire_tripod", found["moments"]):
        assert state["u"][2] != 0.0  # the moment M
        K, _ = plain_tangent(mechanics, plain, np.array(state["qddot"]))
        close(np.reshape(state["stiffness"], (n, n)), K, 1e-10)
    _check_the_measuring_loop(found)


def _with_plain(name, states):
    """Each of the probe's `states` of model `name` (MODELS) with the plain equations of
    motion there (`test_engine.plain_dynamics`): (state, mechanics, plain, NDOF)."""
    model = MODELS[name]()
    mechanics = Mechanics(model)
    n = mechanics.kinematics.dofs_of(model.initial_coordinates).size
    for state in states:
        q, qdot, u = (np.array(state[key]) for key in ("q", "qdot", "u"))
        yield state, mechanics, plain_dynamics(model, mechanics, q, qdot, u), n


def _check_the_measuring_loop(found):
    """The demo's loop reads its output from the state; a loop on an output that is not a
    DOF gets the measuring entry in the same process and cache after it: its positions and
    forces are the Python loop's (Simulator.outputs by Newton) to the bit, it moved by the
    stroke, and its last position is the plain kinematics' x at the last DOFs within 1e-12 m
    (the truss is 0.1 m long; measured 0)."""
    assert not found["measuring_after_demo"]
    loop = found["loop"]
    assert loop["compiled"]
    assert loop["same"]
    assert loop["moved"] > 0.9e-4
    assert abs(loop["last"] - loop["plain"]) <= 1e-12
    # its DOF is the truss's elongation: the scene's DOFs need the deformations, whose
    # operation it got after the demo; they are the plain kinematics' within 1e-15 m (the
    # truss is 0.1 m long)
    assert loop["deformations"]
    assert len(loop["start"]) == len(loop["start_plain"]) == 1
    assert np.max(np.abs(np.subtract(loop["start"], loop["start_plain"]))) <= 1e-15
