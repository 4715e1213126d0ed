"""Outputs on elements (SPACAR's OUTE, OUTF) in a simulation (`element_readings`): at a static
equilibrium against the static solution; at states of a transient against the numpy
mechanics (e and S e + D edot at the same coordinates and rates); a prescribed deformation's
stress against its effort and its node's balance; `flexure simulate`'s columns; the refusals.
Planar (stage_planar_3dof) and spatial (stage_spatial_1dof) scenes; the FMU's:
test_fmu_element_outputs.py."""

import numpy as np
import pytest
from element_output_scenes import pushed_chain, stage_planar, stage_spatial
from kinematic_scenes import M1, pendulum

from flexure.core import (
    Mechanics,
    Simulator,
    build_model,
    scene_toml,
    simulate,
    static_equilibrium,
)
from flexure.core.cli import main
from flexure.core.engine import data as ed
from flexure.core.errors import SimulationError
from flexure.core.mechanics.element_outputs import element_output_values
from flexure.core.simulation import element_readings

SCENES = {"planar": stage_planar, "spatial": stage_spatial}


def numpy_outputs(model, states):
    """The element outputs at absolute states [q, qdot] from the numpy mechanics: e of its
    own kinematics at q, sigma = S e + D edot with edot = De DF qdot."""
    mechanics, n = Mechanics(model), model.declared_dof_count
    x, rows = model.initial_coordinates, []
    for state in states:
        config = mechanics.kinematics.solve(state[:n], x)
        x = config.x
        edot = config.De @ (config.DF @ state[n: 2 * n])
        sigma = mechanics.constitutive_stress(config, edot)
        rows.append(element_output_values(model, config.e, sigma))
    return np.array(rows)


def unit_scale(model, values):
    """Per column, the largest |value| among the columns of its unit (m or N)."""
    units = np.array([port.unit for port in model.element_outputs])
    return np.array([np.max(np.abs(values[..., units == unit])) for unit in units])


@pytest.mark.parametrize("kind", SCENES)
def test_at_a_static_equilibrium_the_simulation_gives_the_static_solution(kind):
    """Started at the equilibrium under F = 1 N, the simulator's element outputs are the
    static solution's (`StaticSolution.element_outputs`, numpy) within 1e-9 of the largest
    of their unit (measured: 4.9e-13 planar, 1.3e-14 spatial), and after 20 ms held there
    within 1e-6 (the integrator's rtol 1e-10 on a state that stays put; measured 5.3e-10,
    2.7e-15)."""
    model = build_model(SCENES[kind]())
    static = static_equilibrium(model, inputs=[1.0])
    expected = np.array(list(static.element_outputs().values()))
    sim = Simulator(model, rtol=1e-10)
    sim.set_inputs([1.0])
    sim.reset(q0=static.q)
    n = len(model.outputs)
    assert sim.output_names[n:] == list(static.element_outputs())
    assert sim.output_units[n:] == [port.unit for port in model.element_outputs]
    scale = unit_scale(model, expected)
    assert np.all(np.abs(sim.outputs()[n:] - expected) <= 1e-9 * scale)
    sim.advance_to(0.02)
    assert np.all(np.abs(sim.outputs()[n:] - expected) <= 1e-6 * scale)
    assert sim.output_values()[n:] == pytest.approx(sim.outputs()[n:].tolist(), rel=0, abs=0)


@pytest.mark.parametrize("kind", SCENES)
def test_along_a_transient_the_simulation_gives_the_numpy_mechanics(kind):
    """A step of F = 1 N from rest: at 40 states of the ringing transient (velocities far
    from zero) the simulation's element outputs are numpy's e and S e + D edot at the same
    q and qdot within 1e-10 of the largest of their unit (measured 1.3e-12 planar, 1.4e-16
    spatial). The viscous term is in it: S e alone differs by more than 1e-4 of the largest
    stress resultant (measured 1.6e-3, 3.3e-3)."""
    model = build_model(SCENES[kind]())
    result = simulate(model, 0.02, inputs={"F": 1.0}, output_times=np.linspace(0, 0.02, 41))
    states = np.column_stack([result.q, result.qdot])
    n = len(model.outputs)
    ours = result.output_array[:, n:]
    theirs = numpy_outputs(model, states)
    scale = unit_scale(model, theirs)
    assert np.all(np.abs(ours - theirs) <= 1e-10 * scale)
    assert np.max(np.abs(result.qdot)) > 1e-3  # moving: the dampers act
    elastic = numpy_outputs(model, np.column_stack([result.q, 0 * result.qdot]))
    stress = [port.quantity == "stress" for port in model.element_outputs]
    assert np.max(np.abs(ours - elastic)[:, stress]) > 1e-4 * np.max(scale[stress])


def test_a_prescribed_deformations_stress_is_minus_its_effort():
    """The pushed chain: the truss act's force is minus the effort of its elongation L
    (the same evaluation: within 1e-12 of the largest; measured 0), its elongation the
    path's, and node 1's balance holds, sigma_act = sigma_b - M1 u''(t) (node 1 moves as
    act stretches; within 1e-9 of the largest force, measured 1.2e-16), at rest after the
    move sigma_act = sigma_b; b's force is numpy's S e + D edot (measured 7e-15)."""
    model = build_model(pushed_chain())
    times = np.linspace(0.0, 0.2, 81)
    result = simulate(model, 0.2, motion_duration=0.05, output_times=times, rtol=1e-10)
    push, stretch = result.outputs["push"], result.outputs["stretch"]
    effort, fb = result.outputs["L.effort"], result.outputs["fb"]
    scale = np.max(np.abs(push))
    assert scale > 0.1  # N: the move costs something
    assert np.all(np.abs(push + effort) <= 1e-12 * scale)
    sim = Simulator(model, motion_duration=0.05)
    path = np.array([sim.prescribed_values(t) for t in times])  # (n, 3, 1): u, u', u''
    np.testing.assert_allclose(stretch, path[:, 0, 0], rtol=0, atol=1e-15)
    assert np.all(np.abs(push - (fb - M1 * path[:, 2, 0])) <= 1e-9 * scale)
    # the released spring's force against numpy, with its damper
    theirs = numpy_outputs(model, np.column_stack([result.q, result.qdot]))
    np.testing.assert_allclose(result.outputs["fb"], theirs[:, 3], rtol=0, atol=1e-10 * scale)


def test_flexure_simulate_writes_the_element_outputs(tmp_path):
    """`flexure simulate` writes one column per element output, named and in its unit, the
    values simulate()'s to the CSV's 12 digits."""
    scene = tmp_path / "stage.toml"
    scene.write_text(scene_toml(stage_planar(), "a test of outputs on elements"))
    out = tmp_path / "run.csv"
    main(["simulate", str(scene), "--t-end", "0.01", "--input", "F=1", "--out", str(out)])
    header = out.read_text().splitlines()[0].split(",")
    assert header[3:] == ["e1_left [m]", "e2_left [m]", "N_left [N]", "M2_left [N]",
                          "M3_right [N]"]
    written = np.loadtxt(out, delimiter=",", skiprows=1)
    result = simulate(build_model(stage_planar()), 0.01, inputs={"F": 1.0})
    np.testing.assert_allclose(written[-1, 3:], result.output_array[-1, 2:], rtol=1e-11,
                               atol=1e-300)


# -- refusals ----------------------------------------------------------------------------------

def test_a_rigid_deformations_stress_is_refused_by_name():
    """The pendulum's link tension is a rigid elongation's reaction: the simulator and
    simulate() refuse it, naming the output and where to read it, before compiling."""
    model = pendulum(0.3, 0.25, 9.81)
    words = ("outputs.tension: the stress resultant of link.e1 is the reaction of a rigid "
             "deformation")
    with pytest.raises(SimulationError, match=words) as error:
        Simulator(model)
    assert "static solution or inverse dynamics" in str(error.value)
    with pytest.raises(SimulationError, match=words):
        simulate(model, 0.1)
    assert element_readings.refused_element_outputs(build_model(stage_planar())) is None


def test_a_stress_of_a_moved_model_needs_the_times():
    """With kinematic inputs a stress output is evaluated on their path at each state's
    time: outputs_along without times says so."""
    sim = Simulator(build_model(pushed_chain()), motion_duration=0.05)
    with pytest.raises(SimulationError, match=r"a state \(state 1 of 1 along the path\): the "
                                              "stress outputs of a model with kinematic "
                                              "inputs need the time of each state"):
        sim.outputs_along([np.r_[sim.q, sim.qdot]])
    sim.outputs_along([np.r_[sim.q, sim.qdot]], times=[0.0])  # with them it is fine


def test_an_evaluation_that_fails_names_the_state(monkeypatch):
    """An engine evaluation that fails at a state (here made to fail) is a SimulationError
    naming the state's time and the engine's reason."""
    sim = Simulator(build_model(stage_planar()))
    call = element_readings.engine.call

    def failing(data, op, *args, **kwargs):
        if op == element_readings.engine.OP_RHS:
            return ed.SINGULAR_MASS
        return call(data, op, *args, **kwargs)

    monkeypatch.setattr(element_readings.engine, "call", failing)
    with pytest.raises(SimulationError, match=r"t = 0 s \(state 1 of 1 along the path\): the "
                                              "stress outputs: .*singular"):
        sim.outputs()
