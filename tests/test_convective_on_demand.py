"""The convective accelerations conv = (D2F qdot) qdot (slot conv) formed where they are read
(`core/engine/convective.py`): the augmented form's evaluation leaves J's right-hand side
pending (dims conv_pending), the tangent and the stress resultants solve it, and a reader
outside the compiled code sets dims conv_wanted. Checked: the pending, the on-demand and the
wanted conv are bitwise one; conv is the second difference of the kinematics x(q + t qdot)
over t; at rest it is zero and nothing is pending; the simulator's acceleration outputs (a
Python reader) leave the flag as they found it and equal DF qddot + conv.
"""

import numpy as np
import pytest

from flexure.core import Mechanics, Simulator, build_model, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.scene.building import parse_toml, scene_path

# the scene, whether its rigid clusters are eliminated (conv then on z, T conv_z + c)
CASES = [("wire_tripod", True), ("wire_tripod", False), ("stage_planar_3dof", True)]
T = 1e-3  # s: the step of the second difference along q + t qdot


def state(model, seed=3):
    """(q, qdot): 1e-4 (m or rad) from the scene's DOFs, velocities of 0.05 m/s (rad/s)."""
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    rng = np.random.default_rng(seed)
    return q0 + 1e-4 * rng.standard_normal(q0.size), 0.05 * rng.standard_normal(q0.size)


def evaluated(data, q, qdot, wanted):
    """Slot conv (a copy) and dims[CONV_PENDING] after OP_ACCELERATIONS at (q, qdot)."""
    dims = data.int_array("dims")
    dims[ed.CONV_WANTED] = 1 if wanted else 0
    assert engine.call(data, engine.OP_ACCELERATIONS, q, qdot) == ed.OK
    return data.float_array("conv").copy(), int(dims[ed.CONV_PENDING])


@pytest.mark.parametrize(("name", "rigid"), CASES)
def test_the_tangent_forms_the_pending_conv_as_the_evaluation_did(name, rigid):
    """Pending after a plain evaluation; after OP_TANGENT slot conv is bitwise the conv an
    evaluation with conv_wanted forms, and within 1e-6 of its largest entry (plus the
    difference's round-off) the second difference of x(q + t qdot)."""
    model = load_scene(name)
    data = EngineData(model, augmented=True, rigid=rigid)
    dims = data.int_array("dims")
    assert (dims[ed.NSLAVES] > 0) == rigid
    q, qdot = state(model)
    _, pending = evaluated(data, q, qdot, False)
    assert pending == 1
    assert engine.call(data, engine.OP_TANGENT, data.float_array("qddot").copy()) == ed.OK
    assert dims[ed.CONV_PENDING] == 0
    on_demand = data.float_array("conv").copy()
    wanted, pending = evaluated(data, q, qdot, True)
    assert pending == 0
    assert np.array_equal(on_demand, wanted)
    xs = []
    for t in (-T, 0.0, T):
        assert engine.call(data, engine.OP_KINEMATICS, q + t * qdot) == ed.OK
        xs.append(data.float_array("x").copy())
    difference = (xs[0] - 2.0 * xs[1] + xs[2]) / T ** 2
    size = np.max(np.abs(wanted))
    assert size > 1e-6
    # the difference's round-off: 100 eps of x over T^2 (1.4e-11 measured against a conv of
    # 1.2e-5 on stage_planar_3dof)
    bound = 1e-6 * size + 1e-14 * np.max(np.abs(xs[1])) / T ** 2
    assert np.max(np.abs(difference - wanted)) <= bound


@pytest.mark.parametrize(("name", "rigid"), CASES[:2])
def test_at_rest_conv_is_zero_and_not_pending(name, rigid):
    model = load_scene(name)
    data = EngineData(model, augmented=True, rigid=rigid)
    q, qdot = state(model)
    data.float_array("conv")[:] = 1.0
    conv, pending = evaluated(data, q, np.zeros_like(qdot), False)
    assert pending == 0
    assert not conv.any()


def test_the_acceleration_outputs_read_conv_formed_and_restore_the_flag():
    """stage_spatial_19dof (augmented, rigid clusters) with an acceleration output: after the
    outputs slot conv is formed (nothing pending, not the right-hand side a plain evaluation
    leaves) and within 1e-9 of its largest entry the conv of a separate evaluation with
    conv_wanted at the same state; dims conv_wanted is 0 again."""
    scene = parse_toml(scene_path("stage_spatial_19dof"))
    first = next(iter(scene["outputs"].values()))
    scene["outputs"]["acc"] = dict(first, quantity="acceleration")
    model = build_model(scene)
    sim = Simulator(model, rtol=1e-8)
    sim.set_inputs(np.ones(len(model.inputs)))
    sim.advance_to(0.005)
    data, n = sim._output_data, model.declared_dof_count  # the outputs' own packed model
    dims = data.int_array("dims")
    assert dims[ed.AUGMENTED] == 1 and dims[ed.NSLAVES] > 0
    state = np.array(sim.state, dtype=float)
    assert np.any(state[n: 2 * n] != 0.0)
    sim.outputs()
    assert dims[ed.CONV_WANTED] == 0 and dims[ed.CONV_PENDING] == 0
    read = data.float_array("conv").copy()
    fresh = EngineData(model)
    fresh.float_array("q_ref")[:] = state[:n]
    fresh.float_array("inputs")[:] = data.float_array("inputs")
    fresh.int_array("dims")[ed.CONV_WANTED] = 1
    y = np.zeros(data.float_array("q_ref").size * 2)
    y[n: 2 * n] = state[n: 2 * n]
    assert engine.call(fresh, engine.OP_RHS, y) == ed.OK
    expected = fresh.float_array("conv")
    size = np.max(np.abs(expected))
    assert size > 0.0
    assert np.max(np.abs(read - expected)) <= 1e-9 * size
    assert engine.call(data, engine.OP_RHS, y) == ed.OK  # a plain evaluation: pending
    assert dims[ed.CONV_PENDING] == 1


def test_the_inverse_dynamics_read_conv_formed_by_their_reduced_form():
    """`inverse_engine.EngineMotion.motion` returns slot conv: its packing is the reduced
    form, whose evaluation forms conv itself (nothing left pending), equal to the conv an
    evaluation with conv_wanted forms on the augmented form at the same state, within 1e-9
    of its largest entry."""
    from flexure.core.analysis.inverse_engine import engine_motion

    model = load_scene("stage_spatial_19dof")
    motion = engine_motion(model)
    dims = motion.data.int_array("dims")
    assert dims[ed.AUGMENTED] == 0
    n = model.declared_dof_count
    rng = np.random.default_rng(7)
    q, qdot = 1e-4 * rng.standard_normal(n), rng.standard_normal(n)
    conv, _, _ = motion.motion(motion.solve(q, None), qdot)
    assert dims[ed.CONV_PENDING] == 0
    augmented = EngineData(model, augmented=True, rigid=False)
    augmented.float_array("q_ref")[:] = q
    with augmented.evaluating(convective=True):
        status = engine.call(augmented, engine.OP_RHS, np.concatenate([np.zeros(n), qdot]))
    assert status == ed.OK
    expected = augmented.float_array("conv")
    size = np.max(np.abs(expected))
    assert size > 0.0 and np.max(np.abs(conv - expected)) <= 1e-9 * size

