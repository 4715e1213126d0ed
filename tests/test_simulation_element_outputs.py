"""Outputs on elements (SPACAR's OUTE, OUTF) in a simulation (`element_readings`): at a static
equilibrium against the static solution; at states of a transient against the numpy
mechanics (e, S e + D edot and the rigid deformations' reactions at the same coordinates and
rates); a pendulum's link tension against the closed form; a prescribed deformation's stress
against its effort and its node's balance; `flexure simulate`'s columns; what cannot be
evaluated.
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
from flexure.core.analysis.stresses import dynamic_stress_resultants
from flexure.core.cli import main
from flexure.core.engine import data as ed
from flexure.core.errors import SimulationError
from flexure.core.mechanics.element_outputs import element_output_values
from flexure.core.mechanics.ports import input_forces
from flexure.core.simulation import element_readings

SCENES = {"planar": stage_planar, "spatial": stage_spatial}


def numpy_outputs(model, states, inputs=None):
    """The element outputs at absolute states [q, qdot] from the numpy mechanics: e of its
    own kinematics at q; sigma = S e + D edot with edot = De DF qdot, and on the rigid
    deformations the multipliers of the dynamic balance with numpy's own accelerations
    (`dynamic_stress_resultants`, the force inputs `inputs` (n, n_inputs) N held)."""
    mechanics, n = Mechanics(model), model.declared_dof_count
    x, rows = model.initial_coordinates, []
    for k, state in enumerate(states):
        config = mechanics.kinematics.solve(state[:n], x)
        x = config.x
        force = input_forces(model, x, np.zeros(len(model.inputs)) if inputs is None
                             else inputs[k])
        sigma = dynamic_stress_resultants(mechanics, config, state[n: 2 * n],
                                          input_force=force)
        rows.append(element_output_values(model, config.e, sigma))
    return np.array(rows)


def unit_scale(model, values):
    """Per column, the largest |value| among the columns of its unit (m or N)."""
    units = np.array([port.unit for port in model.element_outputs])
    return np.array([np.max(np.abs(values[..., units == unit])) for unit in units])


@pytest.mark.parametrize("kind", SCENES)
def test_at_a_static_equilibrium_the_simulation_gives_the_static_solution(kind):
    """Started at the equilibrium under F = 1 N, the simulator's element outputs are the
    static solution's (`StaticSolution.element_outputs`, numpy) within 1e-8 of the largest
    of their unit (the rigid bar's reactions carry the static solution's leftover
    imbalance, which the simulation takes as an acceleration; measured 8.5e-10 planar, on
    the bar's moment, 4.9e-13 on the others; 1.3e-14 spatial), and after 20 ms held there
    within 1e-6 (the integrator's rtol 1e-10 on a state that stays put; measured 7.8e-10,
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
    assert np.all(np.abs(sim.outputs()[n:] - expected) <= 1e-8 * scale)
    sim.advance_to(0.02)
    assert np.all(np.abs(sim.outputs()[n:] - expected) <= 1e-6 * scale)
    assert sim.output_values()[n:] == pytest.approx(sim.outputs()[n:].tolist(), rel=0, abs=0)


@pytest.mark.parametrize("kind", SCENES)
def test_along_a_transient_the_simulation_gives_the_numpy_mechanics(kind):
    """A step of F = 1 N from rest: at 40 states of the ringing transient (velocities far
    from zero) the simulation's element outputs are numpy's at the same q and qdot (its own
    kinematics; e and S e + D edot, and the rigid deformations' reactions with its own
    accelerations) within 1e-10 of the largest of their unit (measured 1.0e-12 planar,
    7e-17 spatial), the reactions within 1e-9 (they carry the accelerations, the engine's
    against numpy's; measured 3.9e-11 planar, 2.8e-16 spatial). The viscous term is in the
    constitutive ones: S e alone differs by more than 1e-4 of the largest stress resultant
    (measured 1.6e-3, 3.3e-3)."""
    model = build_model(SCENES[kind]())
    result = simulate(model, 0.02, inputs={"F": 1.0}, output_times=np.linspace(0, 0.02, 41))
    states = np.column_stack([result.q, result.qdot])
    n = len(model.outputs)
    ours = result.output_array[:, n:]
    theirs = numpy_outputs(model, states, result.inputs)
    scale = unit_scale(model, theirs)
    rigid = np.array([port.quantity == "stress" and port.deformation in
                      model.rigid_deformations for port in model.element_outputs])
    assert rigid.any()
    assert np.all(np.abs(ours - theirs)[:, ~rigid] <= 1e-10 * scale[~rigid])
    assert np.all(np.abs(ours - theirs)[:, rigid] <= 1e-9 * scale[rigid])
    assert np.max(np.abs(result.qdot)) > 1e-3  # moving: the dampers act
    elastic = numpy_outputs(model, np.column_stack([result.q, 0 * result.qdot]))
    stress = [port.quantity == "stress" and port.deformation in model.stressed_deformations
              for port in model.element_outputs]
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
                          "M3_right [N]", "N_bar [N]", "M2_bar [N]"]
    written = np.loadtxt(out, delimiter=",", skiprows=1)
    result = simulate(build_model(stage_planar()), 0.01, inputs={"F": 1.0})
    np.testing.assert_allclose(written[-1, 3:], result.output_array[-1, 2:], rtol=1e-11,
                               atol=1e-300)


def test_a_rigid_links_tension_is_the_pendulums():
    """The pendulum (a point mass m on a rigid link l, released at 0.5 rad): the link's
    tension, a rigid elongation's reaction, is m (g cos(theta) + l theta'^2) at the
    simulation's own theta and theta' within 1e-12 of m g (measured 3e-16)."""
    mass, length, g = 0.3, 0.25, 9.81
    result = simulate(pendulum(mass, length, g), 0.5, q0=[0.5],
                      output_times=np.linspace(0.0, 0.5, 21))
    theta, rate = result.q[:, 0], result.qdot[:, 0]
    assert np.max(np.abs(rate)) > 1.0  # rad/s: swinging
    exact = mass * (g * np.cos(theta) + length * rate ** 2)
    assert np.all(np.abs(result.outputs["tension"] - exact) <= 1e-12 * mass * g)


# -- what cannot be evaluated --------------------------------------------------------------

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


def test_reactions_that_cannot_be_formed_name_the_state(monkeypatch):
    """The engine's stress resultants failing at the state (here made to fail) is a
    SimulationError naming the state's time and the reactions."""
    from flexure.core.simulation import element_reactions

    call = element_reactions.engine.call

    def failing(data, op, *args, **kwargs):
        if op == element_reactions.engine.OP_STRESS_RESULTANTS:
            return ed.NONFINITE_RESULT
        return call(data, op, *args, **kwargs)

    sim = Simulator(build_model(stage_planar()))
    monkeypatch.setattr(element_reactions.engine, "call", failing)
    with pytest.raises(SimulationError, match=r"t = 0 s \(state 1 of 1 along the path\): the "
                                              "reactions of the rigid deformations: .*finite"):
        sim.outputs()
