"""Stiff and extreme cases of the nonlinear simulation: each runs stably or stops with a
clear SimulationError that names the time and the cause (no hang, no NaN in the output)."""

import tomllib

import numpy as np
import pytest

from flexure.core import (
    SimulationError,
    Simulator,
    build_model,
    linearize,
    load_scene,
    natural_frequencies,
    scene_path,
    simulate,
    static_equilibrium,
)


def truss_pendulum(length=0.5):
    """A truss pendulum with its elongation prescribed zero and the mass's y as the DOF: the
    constraint Jacobian is singular where the truss hangs vertically (y = -length)."""
    return build_model({
        "scene": {"name": "truss_pendulum", "gravity": [0.0, -9.81]},
        "sections": {"rod": {"EA": 1.0}},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"position": [length, 0.0], "mass": 1.0, "dof": ["y"]}},
        "elements": {"rod": {"type": "PLTRUSS", "nodes": ["1", "2"], "section": "rod"}},
        "outputs": {"y": {"node": "2", "coordinate": "y"}},
    })


def test_stiffness_ratio_above_1e5_with_bdf():
    model = load_scene("stage_planar_3dof")
    f = natural_frequencies(model).frequencies_hz
    assert (f[-1] / f[0]) ** 2 > 1e5
    times = np.linspace(0.0, 0.05, 26)
    bdf = simulate(model, 0.05, inputs={"F": 1.0}, method="cvode-bdf", rtol=1e-6,
                   output_times=times)
    reference = simulate(model, 0.05, inputs={"F": 1.0}, method="cvode-adams", rtol=1e-10,
                         output_times=times)
    assert np.all(np.isfinite(bdf.output_array))
    stroke = np.max(np.abs(reference.outputs["x"]))
    assert np.max(np.abs(bdf.outputs["x"] - reference.outputs["x"])) < 2e-3 * stroke
    assert bdf.statistics["steps"] < reference.statistics["steps"]


def test_large_stroke_over_20_percent_of_the_spring_length():
    model = load_scene("stage_planar_1dof")
    port = model.inputs[0].coordinate
    F_max, T = 19.0, 1.5
    ramp = lambda t: F_max * 0.5 * (1 - np.cos(np.pi * min(t, T) / T))  # noqa: E731
    result = simulate(model, T, inputs={"F": ramp}, rtol=1e-7, output_times=[T])
    loads = model.loads.copy()
    loads[port] += F_max
    static = static_equilibrium(model, loads=loads)
    x, y = result.outputs["x"][-1], result.outputs["y"][-1]
    assert x > 0.2 * 0.1  # 20 % of the 0.1 m leaf springs
    assert abs(x - static.x[port]) < 2e-3 * x
    assert abs(y - static.x[port + 1]) < 2e-3 * abs(static.x[port + 1] - 0.1)


def test_vertical_preload_at_95_percent_of_the_buckling_load():
    data = tomllib.loads(scene_path("stage_planar_1dof").read_text())
    data["nodes"]["3"]["force"] = [0.0, -0.95 * 78.75]
    model = build_model(data, source="stage_planar_1dof + preload")
    lin = linearize(model)
    k_eff, mass = lin.K[0, 0], lin.M0[0, 0]
    assert k_eff < 0.06 * 945.0  # 5 % of the unloaded stiffness remains
    x_static = lin.solution.x[model.inputs[0].coordinate]
    sim = Simulator(model, rtol=1e-9)
    sim.reset(q0=lin.solution.q)  # at rest in the preloaded equilibrium
    sim.set_inputs([0.02])  # then a 20 mN sideways step
    period = 2 * np.pi * np.sqrt(mass / k_eff)
    xs = []
    for t in np.linspace(0, period, 41)[1:]:
        sim.advance_to(t)
        xs.append(sim.outputs()[0] - x_static)
    xs = np.array(xs)
    # the step response of the softened stage: 0 .. 2 F / k_eff and back within one period
    assert np.all(np.isfinite(xs))
    assert abs(np.max(xs) - 2 * 0.02 / k_eff) < 0.03 * 2 * 0.02 / k_eff
    assert abs(xs[-1]) < 0.03 * 2 * 0.02 / k_eff


def test_100_seconds_undamped():
    data = tomllib.loads(scene_path("truss_1dof_x").read_text())
    data["sections"]["springs"].pop("EdA")
    model = build_model(data, source="truss_1dof_x (undamped)")
    m, k = 0.206 + 0.1413 * 0.1 / 3.0, 945.0
    w = np.sqrt(k / m)
    times = np.linspace(99.0, 100.0, 51)
    result = simulate(model, 100.0, method="cvode-adams", rtol=1e-9, output_times=times)
    exact = 0.1 + (1 - np.cos(w * times)) / k
    assert np.all(np.isfinite(result.output_array))
    assert np.max(np.abs(result.outputs["x"] - exact)) < 0.01 * (2 / k)


def test_tolerances_from_1e_3_to_1e_12():
    model = load_scene("stage_planar_1dof")
    times = np.linspace(0.0, 0.05, 11)
    reference = simulate(model, 0.05, inputs={"F": 1.0}, method="cvode-adams", rtol=1e-13,
                         output_times=times).outputs["x"]
    errors = []
    for rtol in (1e-3, 1e-6, 1e-9, 1e-12):
        result = simulate(model, 0.05, inputs={"F": 1.0}, rtol=rtol, output_times=times)
        assert np.all(np.isfinite(result.output_array))
        errors.append(np.max(np.abs(result.outputs["x"] - reference)))
    assert errors[0] < 0.05 * np.max(np.abs(reference))
    assert errors[0] > errors[1] > errors[2] > errors[3]
    assert errors[3] < 1e-11


def test_a_singular_configuration_stops_with_the_time_and_the_cause():
    """y turns around at the bottom, where the DOF is singular: whether a run comes within
    the singular tolerance there depends on its steps. At rtol 1e-6 it does (t = 0.4186 s);
    at rtol 1e-8 with the default atol (since the deviation state) it turns 1.2e-4 m (in x)
    before it and goes on: y(t) is the same on either branch of x."""
    model = truss_pendulum()
    sim = Simulator(model, rtol=1e-6)
    with pytest.raises(SimulationError, match=r"t = 0\.\d+ s.*singular") as error:
        sim.advance_to(1.0)
    assert "truss_pendulum" in str(error.value)
    # left at the last good state: finite, before the bottom (y = -0.5 m) at t ~ 0.37 s
    assert 0.3 < sim.time < 0.45
    assert np.all(np.isfinite(sim.q)) and np.all(np.isfinite(sim.qdot))
    assert -0.5 < sim.q[0] < -0.45


def test_non_finite_inputs_are_refused_with_the_input_and_the_time():
    model = load_scene("stage_planar_1dof")
    sim = Simulator(model)
    sim.advance_to(0.01)
    for bad in (np.nan, np.inf):
        with pytest.raises(SimulationError, match=r"t = 0\.01 s: input 'F' is not finite"):
            sim.set_inputs([bad])
    sim.advance_to(0.02)  # still usable
    with pytest.raises(SimulationError, match=r"t = 0\.0[34]\d* s: input 'F' is not finite"):
        simulate(model, 0.1, inputs={"F": lambda t: 1.0 if t < 0.03 else np.nan})
    with pytest.raises(SimulationError, match=r"t = 0\.02 s: input 'F' is not finite"):
        simulate(model, 0.1, inputs={"F": ([0.0, 0.02], [1.0, np.inf])})
    with pytest.raises(SimulationError, match="unknown input 'G'.*inputs: F"):
        simulate(model, 0.1, inputs={"G": 1.0})


def test_simulator_misuse_is_a_clear_error():
    model = load_scene("stage_planar_1dof")
    with pytest.raises(SimulationError, match="unknown method 'rk4'"):
        Simulator(model, method="rk4")
    sim = Simulator(model)
    sim.advance_to(0.01)
    with pytest.raises(SimulationError, match="expected a finite time after"):
        sim.advance_to(0.005)
    with pytest.raises(SimulationError, match="expected 1 inputs"):
        sim.set_inputs([1.0, 2.0])
    with pytest.raises(SimulationError, match="atol"):
        Simulator(model, atol=[1.0, 2.0, 3.0])
    with pytest.raises(SimulationError, match="max_order: expected an integer from 1 to 5 "
                                              "for cvode-bdf, got 6"):
        Simulator(model, max_order=6)
    with pytest.raises(SimulationError, match="max_order.*1 to 12 for cvode-adams"):
        Simulator(model, method="cvode-adams", max_order=0)
    with pytest.raises(SimulationError, match="state is of model"):
        sim.set_state(dict(sim.get_state(), q_ref=[0.0, 0.0]))


def test_a_state_beyond_the_range_of_validity_is_reported_not_silent(capsys):
    """1e9 N for 1 ms drives the 3-DOF stage's bar metres away on 0.1 m leaf springs: the
    run completes, and the result, the command's output and the simulator say so; a 1 N
    step stays within the range, without warnings."""
    from flexure.core.cli import main
    from flexure.core.simulation.plausibility import DISTANCE_LIMIT, STRAIN_LIMIT

    model = load_scene("stage_planar_3dof")
    wild = simulate(model, 1e-3, inputs={"F": 1e9}, rtol=1e-6, output_times=[0.0, 1e-3])
    assert any("beyond the model's range of validity" in w and "axial strain" in w
               for w in wild.warnings)
    assert any(f"({DISTANCE_LIMIT:g} x its size 0.141 m)" in w for w in wild.warnings)
    assert f"|strain| <= {STRAIN_LIMIT:g}" in " ".join(wild.warnings)
    calm = simulate(model, 0.05, inputs={"F": 1.0}, rtol=1e-6)
    assert calm.warnings == []
    sim = Simulator(model, rtol=1e-6)
    sim.set_inputs([1e9])
    sim.advance_to(1e-3)
    assert set(sim.range_warnings()) == {"strain", "distance"}
    assert main(["simulate", "stage_planar_3dof", "--t-end", "1e-3", "--input", "F=1e9",
                 "--rtol", "1e-6"]) == 0
    assert "warning: axial strain" in capsys.readouterr().out


@pytest.mark.parametrize("scene", ["stage_planar_3dof", "stage_spatial_19dof"])
def test_the_compiled_range_test_agrees_with_the_warnings(scene):
    """RangeCheck.within (compiled, run after every FMU doStep) is True exactly when
    `warnings` finds nothing: random states spread across both limits, and each limit
    crossed alone by 1 % on one element or coordinate."""
    from flexure.core.simulation.plausibility import DISTANCE_LIMIT, RangeCheck

    model = load_scene(scene)
    check = RangeCheck(model)
    rng = np.random.default_rng(7)
    x0 = np.asarray(model.initial_coordinates, float)
    e0 = np.zeros(len(model.deformation_names))
    # `watch` reads these two arrays in place at each call: they are overwritten below
    x, e = x0.copy(), e0.copy()
    watched = check.watch(x, e)
    seen = set()
    for _ in range(400):
        x[:], e[:] = x0, e0
        x[check.translational] += rng.uniform(-1.2, 1.2, check.translational.size) * (
            DISTANCE_LIMIT * check.scale) * rng.uniform(0, 1)
        e[check.elongation] = rng.uniform(-1.2, 1.2, check.elongation.size) * check.strain_bound
        within = check.within(x, e)
        assert within == (check.warnings(x, e) == {}) == watched()
        seen.add(within)
    assert seen == {True, False}
    for which in ("strain", "distance"):
        x[:], e[:] = x0, e0
        if which == "strain":
            e[check.elongation[-1]] = -1.01 * check.strain_bound[-1]
        else:
            x[check.translational[-1]] += 1.01 * DISTANCE_LIMIT * check.scale
        assert not check.within(x, e) and not watched()
        assert set(check.warnings(x, e)) == {which}


def test_a_range_watch_needs_arrays_it_can_read_in_place():
    """RangeCheck.watch refuses a strided view: its compiled check reads x and e by address."""
    from flexure.core.simulation.plausibility import RangeCheck

    model = load_scene("stage_planar_3dof")
    x = np.repeat(np.asarray(model.initial_coordinates, float), 2)[::2]
    with pytest.raises(TypeError, match="C-contiguous"):
        RangeCheck(model).watch(x, np.zeros(len(model.deformation_names)))
