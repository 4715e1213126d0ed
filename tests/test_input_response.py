"""The engine's input response (`engine.input_response`)."""

import numpy as np
import pytest

from flexure.core import Mechanics, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from tests.test_engine import close, evaluate, random_states
from tests.test_rotation_ports import build_model, cantilever


def response(data, u):
    """The engine's d qddot for the inputs u, against those of its last evaluation; status."""
    data.float_array("inputs")[:] = u
    out = np.full(data.int_array("dims")[ed.NDOF], np.nan)
    return engine.call(data, engine.OP_INPUT_RESPONSE, out), out


CASES = [("stage_planar_3dof", {}), ("stage_planar_3dof", {"rigid": False}),
         ("stage_spatial_19dof", {"sparse": True}), ("stage_spatial_19dof", {"sparse": False}),
         ("moments", {})]


@pytest.mark.parametrize("name, options", CASES)
def test_the_response_is_the_change_of_qddot_between_two_evaluations(name, options):
    """At random states, d qddot of a change of the inputs (forces, or moments about global
    axes, whose forces depend on x) equals qddot(u1) - qddot(u0) of two evaluations at the
    same state to 1e-12 of qddot (the difference of two evaluations keeps the round-off of
    the elastic terms that cancel in it), banded and sparse, with and without the rigid
    clusters."""
    model = (build_model(cantilever(rotation=(0.3, -0.2, 0.4))) if name == "moments"
             else load_scene(name))
    data = EngineData(model, augmented=True, **options)
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    for (q, qdot, u0), (_, _, u1) in zip(random_states(model, q0, seed=3),
                                         random_states(model, q0, seed=4), strict=True):
        before = evaluate(data, q, qdot, u0)
        status, change = response(data, u1)
        assert status == ed.OK
        after = evaluate(data, q, qdot, u1)
        size = max(np.max(np.abs(before)), np.max(np.abs(after)))
        assert np.max(np.abs(after - before)) > 1e4 * 1e-12 * size  # resolved to 1e-4
        close(change, after - before, 1e-12, scale=size)
        status, unchanged = response(data, u1)  # the inputs of the last evaluation
        assert status == ed.OK and not np.any(unchanged)


def test_the_response_needs_the_factors_of_the_last_evaluation():
    """NOT_AVAILABLE in the reduced form, after the kinematics moved x, and before any
    evaluation."""
    model = load_scene("stage_planar_3dof")
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    (q, qdot, u), = random_states(model, q0, seed=5, count=1)
    data = EngineData(model, augmented=True)
    assert response(data, u)[0] == ed.NOT_AVAILABLE
    evaluate(data, q, qdot, u)
    assert response(data, 2 * u)[0] == ed.OK
    assert engine.call(data, engine.OP_KINEMATICS, q + 1e-5) == ed.OK
    assert response(data, 3 * u)[0] == ed.NOT_AVAILABLE
    reduced = EngineData(model, augmented=False)
    evaluate(reduced, q, qdot, u)
    assert response(reduced, 2 * u)[0] == ed.NOT_AVAILABLE
