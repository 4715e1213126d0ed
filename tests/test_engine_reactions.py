"""The stress resultants of the full dynamic balance from the engine's own evaluation
(OP_STRESS_RESULTANTS, core/engine/reactions.py; `stress_engine`, `stresses_along`) against
the numpy reference `dynamic_stress_resultants` at states of a run: the planar stage with its
rigid bar read (element_output_scenes.stage_planar), a rod whose rigid torsion carries a
moment input, and manipulator_control (spatial, rigid clusters).

Tolerances: every stress resultant within 1e-8 of the largest |sigma| of the state. The
two paths solve the kinematics each to round-off, and their coordinates differ by an ulp
(1.4e-17 m measured on the planar stage), which a leaf's axial stiffness EA / l0 turns into
5e-10 of the largest resultant (measured; the bending resultants and the reactions agree to
1e-14 of it). A packing with rigid clusters gives the constitutive ones alone, NaN on the
rigid deformations (`engine.reactions`); one without clusters every one.
"""

import numpy as np
import pytest
from element_output_scenes import stage_planar
from test_rotation_ports import rod_body

from flexure.core import Mechanics, build_model, load_scene, simulate
from flexure.core.analysis.stress_engine import EngineStresses
from flexure.core.analysis.stresses import dynamic_stress_resultants, stresses_along
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.mechanics.ports import input_forces

RTOL = 1e-8


def rod_with_rigid_torsion():
    """The rod of tests/test_rotation_ports.py, its torsion rigid: the moment input M about
    its axis is carried by the multiplier of e2."""
    data = rod_body()
    data["elements"]["rod"]["released"] = ["e1", "e3", "e4", "e5", "e6"]
    return build_model(data)


def run(name):
    """(model, states (n, 2 NDOF), held inputs (n, n_inputs)) of a step response."""
    qdot0 = None  # from rest
    if name == "planar stage":
        model, inputs, duration = build_model(stage_planar()), {"F": 1.0}, 0.02
    elif name == "rod with a moment":
        model, inputs, duration = rod_with_rigid_torsion(), {"M": 0.05}, 0.02
        # the moment about the rod's axis, all carried by its rigid torsion, moves nothing
        # (from rest the run stays at rest but for round-off): the tip starts moving sideways
        qdot0 = np.where(np.isin(model.dof_names, ["3.y", "3.z"]), 1e-3, 0.0)  # m/s
    else:
        model = load_scene("manipulator_control")
        inputs, duration = {"F1": 1.0, "F4": -0.5}, 0.004
    result = simulate(model, duration, inputs=inputs, qdot0=qdot0,
                      output_times=np.linspace(0.0, duration, 9))
    assert np.max(np.abs(result.qdot)) > 0.0  # moving: the inertia forces act
    return model, np.column_stack([result.q, result.qdot]), result.inputs


def numpy_resultants(model, states, inputs):
    """sigma (n, NE) of `dynamic_stress_resultants` at the states (its own accelerations)."""
    mechanics, n = Mechanics(model), model.declared_dof_count
    x, rows = model.initial_coordinates, []
    for state, held in zip(states, inputs, strict=True):
        config = mechanics.kinematics.solve(state[:n], x)
        x = config.x
        rows.append(dynamic_stress_resultants(mechanics, config, state[n:],
                                              input_force=input_forces(model, x, held)))
    return np.array(rows)


def engine_resultants(data, states, inputs):
    """sigma (n, NE) of OP_STRESS_RESULTANTS after OP_RHS at each state on `data`."""
    n, rows = data.model.declared_dof_count, []
    for state, held in zip(states, inputs, strict=True):
        data.float_array("q_ref")[:] = state[:n]
        data.float_array("inputs")[:] = held
        y = np.concatenate([np.zeros(n), state[n:]])
        assert engine.call(data, engine.OP_RHS, y) == ed.OK
        sigma = np.empty(data.int_array("dims")[ed.NE])
        qddot = data.float_array("qddot").copy()
        assert engine.call(data, engine.OP_STRESS_RESULTANTS, qddot, sigma) == ed.OK
        rows.append(sigma)
    return np.array(rows)


def assert_within(difference, bound):
    """|difference| <= bound elementwise (bound broadcast), the worst ratio named."""
    ratio = np.abs(difference) / bound
    assert np.all(ratio <= 1.0), f"worst |difference| / bound = {np.max(ratio):.3g}"


RUNS = ["planar stage", "rod with a moment",
        pytest.param("manipulator_control", marks=pytest.mark.slow)]


@pytest.mark.parametrize("name", RUNS)
def test_the_engines_stress_resultants_are_numpys(name):
    model, states, inputs = run(name)
    expected = numpy_resultants(model, states, inputs)
    scale = np.max(np.abs(expected), axis=1, keepdims=True)
    rigid = np.zeros(expected.shape[1], dtype=bool)
    rigid[model.rigid_deformations] = True
    # reactions to compare: at every state some rigid deformation carries one (others may be
    # zero by symmetry, which round-off leaves exactly zero on one CPU and 1e-17 on another)
    assert np.all(np.max(np.abs(expected[:, rigid]), axis=1) > 1e-6 * scale[:, 0])
    unclustered = engine_resultants(EngineData(model, rigid=False), states, inputs)
    assert_within(unclustered - expected, RTOL * scale)
    clustered = engine_resultants(EngineData(model), states, inputs)
    if model.name == "manipulator_control":  # rigid clusters: the constitutive ones only
        assert np.all(np.isnan(clustered[:, rigid]))
    assert_within((clustered - expected)[:, ~rigid], RTOL * scale)


@pytest.mark.parametrize("name", RUNS[:2])
def test_stresses_along_through_the_engine_are_numpys(name):
    """The von Mises stresses of `stresses_along` (default: the engine) against its numpy
    path, within 1e-8 of the largest (as the resultants); `EngineStresses` against numpy's
    resultants at the same states."""
    model, states, inputs = run(name)
    names, engine_path = stresses_along(model, states, inputs=inputs)
    plain_names, plain = stresses_along(model, states, inputs=inputs, compiled=False)
    assert names == plain_names and len(names) > 0
    assert_within(engine_path - plain, RTOL * np.max(plain))
    evaluator = EngineStresses(model)
    evaluator.restart()
    expected = numpy_resultants(model, states, inputs)
    for state, held, sigma in zip(states, inputs, expected, strict=True):
        _, ours = evaluator.stress_resultants(state, held)
        finite = ~np.isnan(ours)
        assert_within((ours - sigma)[finite], RTOL * np.max(np.abs(sigma)))
