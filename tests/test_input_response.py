"""The engine's input response (`engine.input_response`) and the one-step integrator's first
stage after an input change that takes it instead of an evaluation."""

import numpy as np
import pytest

from flexure.core import Mechanics, Simulator, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from tests.compiled_loops import run_compiled_loop
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


def loop_run(model, method, rtol, controller, design):
    """The compiled loop of `controller` on a Simulator: position, force, rhs evaluations."""
    sim = Simulator(model, method=method, rtol=rtol)
    assert sim.data.int_array("dims")[ed.AUGMENTED] == 1
    _, position, force = run_compiled_loop(sim, controller, design)
    return position, force, sim.statistics["rhs_evaluations"]


@pytest.fixture
def augmented_form(monkeypatch):
    """Simulators pack their models in the augmented form (the one the input response
    serves), as the large models take it."""
    cost = ed.evaluation_cost
    monkeypatch.setattr(ed, "evaluation_cost",
                        lambda *args, **kwargs: {**cost(*args, **kwargs), "reduced": np.inf})


def test_a_loop_on_the_response_equals_the_python_loop_and_keeps_its_accuracy(augmented_form):
    """A 1 mm move of stage_planar_3dof at 4 kHz on esdirk3 at rtol 1e-7 in the augmented form
    (whose first stages after the 100 input changes take the input response): the compiled
    loop equals the Python loop bit for bit, and the positions stay within 1 rtol of the
    stroke of a run at rtol 1e-11 (measured: 0.11 rtol; 0.19 with f(y) evaluated there)."""
    from flexure.controllers import build_loop
    from flexure.controllers.plants import InProcessPlant
    from flexure.controllers.runner import simulate_loop

    model = load_scene("stage_planar_3dof")
    controller, design = build_loop(model, stroke=1e-3, duration=0.02, settle=0.005,
                                    fs=4000.0)
    position, force, _ = loop_run(model, "esdirk3", 1e-7, controller, design)
    _, _, python_position, python_force = simulate_loop(
        InProcessPlant(model, method="esdirk3", rtol=1e-7), controller, design)
    assert np.array_equal(position, python_position) and np.array_equal(force, python_force)
    reference, _, _ = loop_run(model, "esdirk", 1e-11, controller, design)
    stroke = np.ptp(reference)
    assert stroke > 5e-4
    assert np.max(np.abs(position - reference)) <= 1e-7 * stroke


@pytest.mark.parametrize("method", ["esdirk", "esdirk3", "esdirk2"])
def test_an_input_change_costs_one_evaluation_less_than_a_restart(augmented_form, method):
    """Two simulators of stage_spatial_19dof step alike to 1 ms under 1 N; then the input
    changes, on one as a mere change (the first stage from the input response), on the other
    after its own state was set again (the first stage evaluated): on to 1.25 ms,
    the first with one evaluation less and the same state to the Newton tolerance (1e-6 of the
    step's change of y)."""
    model = load_scene("stage_spatial_19dof")
    sims = [Simulator(model, method=method, rtol=1e-6) for _ in range(2)]
    n = len(model.inputs)
    for sim in sims:
        sim.set_inputs(np.ones(n))
        sim.advance_to(1e-3)
    sims[1].set_state(sims[1].get_state())
    counts, states = [], []
    for sim in sims:
        before, start = sim.statistics["rhs_evaluations"], sim.state.copy()
        sim.set_inputs(np.full(n, -2.0))
        sim.advance_to(1.25e-3)
        counts.append(sim.statistics["rhs_evaluations"] - before)
        states.append(sim.state - start)
    assert counts[0] == counts[1] - 1
    close(states[0], states[1], 1e-6)
