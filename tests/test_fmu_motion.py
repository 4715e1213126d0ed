"""Displacement-driven FMUs: a scene's kinematic inputs as FMU inputs in m (the position at the
end of each step), their efforts as outputs in N (`flexure.core.simulation.stepwise_motion`'s
path rule, docs/fmu.md).

Checked in fmpy: the model description; the FMU against the in-process Simulator given the
same positions, and the path against the rule worked out here with numpy's polynomials; the
rule's order in the communication step h against a closed-form-driven reference (scipy);
states that carry the path; IDA; the refusals; an angle's units; the engine it carries. A pair
of FMUs coupled by a master: tests/test_fmu_motion_pair.py.
"""

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy_slave import Slave, do_step
from kinematic_scenes import (
    C1,
    C2,
    K1,
    K2,
    M1,
    M2,
    STROKE,
    X0,
    chain,
    follower,
    motion,
    turned_pendulum,
)
from scipy.integrate import solve_ivp

from flexure.core import Simulator, build_model, scene_toml
from flexure.core.errors import SimulationError
from flexure.core.simulation.stepwise_motion import (
    derivative_weights,
    end_derivatives,
    next_piece,
)
from flexure.fmu import FMUBuildError, build_scene_fmu, validate_fmu_file

FMI2_ERROR = 3
def run(slave, times, positions):
    """Step an FMU from times[0] with the position of each next time set before each step;
    its outputs after each step (rows)."""
    rows = []
    for t, h, u in zip(times[:-1], np.diff(times), positions, strict=True):
        slave.fmu.setReal([slave.vr["u"]], [float(u)])
        rows.append(slave.step(float(t), float(h)))
    return np.array(rows)


# -- the model description ---------------------------------------------------------------------

def test_a_motion_fmu_takes_positions_and_gives_efforts(motion_fmus):
    """fmpy validates it; the kinematic input is an input in m starting at the scene's start,
    its effort an output in N after the scene's outputs, both initial unknowns."""
    path = motion_fmus["chain"]
    assert validate_fmu_file(path) == []
    md = read_model_description(str(path))
    by_name = {v.name: v for v in md.modelVariables}
    assert [v.name for v in md.modelVariables if v.causality == "input"] == ["u"]
    assert [v.name for v in md.modelVariables if v.causality == "output"] == [
        "x2", "v2", "u.effort"]
    u, effort = by_name["u"], by_name["u.effort"]
    assert (u.unit, u.variability, float(u.start)) == ("m", "continuous", X0)
    assert "position of coordinate 1.x at the end of each step" in u.description
    assert (effort.unit, effort.variability) == ("N", "continuous")
    assert [v.variable.name for v in md.initialUnknowns] == ["x2", "v2", "u.effort"]


# -- against the in-process simulator, and the rule --------------------------------------------

def numpy_piece(t0, t1, start, samples):
    """The rule worked out with numpy's polynomials: the cubic (or lower) through the samples
    (times, positions) gives the end's rate and acceleration; the quintic from `start` to
    those is the solution of its six conditions."""
    times, values = samples
    fit = np.polynomial.Polynomial.fit(times, values, deg=len(times) - 1)
    end = (values[-1], fit.deriv(1)(times[-1]), fit.deriv(2)(times[-1]))
    T = t1 - t0
    rows = [[T**j for j in range(6)], [j * T ** max(j - 1, 0) for j in range(6)],
            [j * (j - 1) * T ** max(j - 2, 0) for j in range(6)]]
    A = np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0], *rows], float)
    return np.polynomial.Polynomial(np.linalg.solve(A, [*start, *end]))


def test_the_fmu_follows_the_in_process_simulator_and_the_rule(motion_fmus):
    """On a variable grid, the positions of the smooth motion: the FMU's x2, v2 and effort
    equal the in-process Simulator's (`move_to`, the same code: within 1e-9 of the stroke and
    of the largest effort; measured 0). The simulator's path in each step is the rule worked
    out with numpy's polynomials (`numpy_piece`) within 1e-9 of the stroke in value, of the
    stroke / h in rate and of the stroke / h^2 in acceleration (measured 1.1e-12 at most)."""
    steps = np.array([1e-3, 2.5e-3, 0.4e-3, 1.7e-3, 3e-3, 0.9e-3, 1e-3, 2e-3] * 3)
    times = np.concatenate([[0.0], np.cumsum(steps)])
    positions = motion(times[1:])[0]
    slave = Slave(motion_fmus["chain"], parameters={"integrator.rtol": 1e-9})
    try:
        fmu = run(slave, times, positions)
    finally:
        slave.close()
    sim = Simulator(build_model(chain()), method="esdirk", rtol=1e-9, stepwise_motion=True)
    samples = ([0.0], [X0])
    for k, (t, t1, u) in enumerate(zip(times[:-1], times[1:], positions, strict=True)):
        start = [part[0] for part in sim.prescribed_values(t)]
        sim.move_to([u], t1)
        row = [*sim.outputs(), *sim.efforts()]
        assert np.all(np.abs(fmu[k, :2] - row[:2]) <= 1e-9 * STROKE * np.array([1, 100]))
        assert abs(fmu[k, 2] - row[2]) <= 1e-9 * np.max(np.abs(fmu[:, 2]))
        samples = ([*samples[0], t1][-4:], [*samples[1], u][-4:])
        piece = numpy_piece(t, t1, start, samples)
        h = t1 - t
        for s in np.linspace(0.0, h, 5):
            ours = [part[0] for part in sim.prescribed_values(t + s)]
            theirs = [piece(s), piece.deriv(1)(s), piece.deriv(2)(s)]
            scales = STROKE * np.array([1.0, 1 / h, 1 / h**2])
            assert np.all(np.abs(np.subtract(ours, theirs)) <= 1e-9 * scales), (k, s)


def test_fornbergs_weights_differentiate_cubics_exactly():
    """`derivative_weights` on uneven points: the value, rate and acceleration of a cubic
    at the newest point to round-off (1e-13 of sum |w_i f_i|, the sum's own scale; measured
    3e-15), and a line's acceleration zero."""
    offsets = np.array([-4.1e-3, -2.5e-3, -1.0e-3, 0.0])
    cubic = np.polynomial.Polynomial([0.3, -2.0, 50.0, 7000.0])
    weights = derivative_weights(offsets)
    expected = [cubic(0.0), cubic.deriv(1)(0.0), cubic.deriv(2)(0.0)]
    scale = np.abs(weights) @ np.abs(cubic(offsets))
    assert np.all(np.abs(weights @ cubic(offsets) - expected) <= 1e-13 * scale)
    line = derivative_weights(offsets[-2:]) @ (1.0 + 3.0 * offsets[-2:])
    np.testing.assert_allclose(line, [1.0, 3.0, 0.0], rtol=1e-12, atol=1e-12)


def test_a_piece_moves_at_both_its_ends_in_the_compiled_path():
    """The engine's `path_point`, numpy's `path_values` and the simulator's plain-Python
    `path_point_now` on a step's piece (`next_piece`):
    at the step's start, the rate and acceleration the piece starts with (not the held
    path's zeros: the step's first evaluation is there); at its end (and an ulp past it,
    where a stage time t + c h may round), the position set and the cubic's rate and
    acceleration, to round-off (1e-12 of the stroke, stroke / h, stroke / h^2)."""
    from flexure.core.engine.prescribed import path_point
    from flexure.core.simulation.simulator_motion import path_point_now, path_values

    t, t_end = 0.003, 0.004
    times = np.array([0.0, 0.001, 0.002, t])
    start = tuple(np.array([part]) for part in (X0 + 2e-4, 0.3, -40.0))
    path, _ = next_piece((times, motion(times)[0][:, None]), start, t, t_end, [X0 + 5e-4])
    rate, acceleration = end_derivatives([*times[1:], t_end],
                                         [*motion(times[1:])[0], X0 + 5e-4])
    h = t_end - t
    scales = STROKE * np.array([1.0, 1 / h, 1 / h**2])
    for when, expected in [(t, [X0 + 2e-4, 0.3, -40.0]),
                           (t_end, [X0 + 5e-4, rate[0], acceleration[0]]),
                           (np.nextafter(t_end, 1.0), [X0 + 5e-4, rate[0], acceleration[0]])]:
        compiled = np.array(path_point(path, 0, when))
        numpy = np.array([part[0] for part in path_values(path, when)])
        assert np.all(np.abs(compiled - expected) <= 1e-12 * scales), (when, compiled)
        assert np.all(np.abs(numpy - expected) <= 1e-12 * scales), (when, numpy)
        now = np.array([part[0] for part in path_point_now(path, when)])
        assert np.all(np.abs(now - compiled) <= 1e-15 * scales), (when, now)


# -- the rule's order in h ----------------------------------------------------------------------

def closed_form_chain(times):
    """m2 driven through k2, c2 by node 1 on `motion` (scipy, rtol 1e-12): x2 (m) and the
    effort F = m1 u'' + k1 (u - X0) + c1 u' - k2 (x2 - u - X0) - c2 (x2' - u') (N) at times."""
    def rhs(t, y):
        u, v, _ = motion(t)
        return [y[1], (-K2 * (y[0] - u - X0) - C2 * (y[1] - v)) / M2]

    solution = solve_ivp(rhs, (0.0, times[-1]), [2 * X0, 0.0], method="DOP853", rtol=1e-12,
                         atol=1e-15, t_eval=times, dense_output=False)
    x2, v2 = solution.y
    u, v, a = motion(times)
    effort = M1 * a + K1 * (u - X0) + C1 * v - K2 * (x2 - u - X0) - C2 * (v2 - v)
    return x2, effort


def test_the_path_rule_converges_at_order_two_in_the_efforts(motion_fmus):
    """The chain's node 1 moved by positions set at steps h = 1, 0.5, 0.25 ms (25 to 100 per
    period of the motion), against the motion driven in closed form: the efforts converge
    at order 2 (measured 1.93 and 1.98: the cubic's acceleration at its newest point; 0.035 N
    of 8.9 N at 0.25 ms), the driven mass's position at order 4 or so (measured 4.3 and 3.9,
    down to 2.9e-12 m of its 0.7 mm) at the common times, every 10 ms."""
    common = np.linspace(0.01, 0.06, 6)
    x2_exact, effort_exact = closed_form_chain(common)
    errors = []
    for h in (1e-3, 5e-4, 2.5e-4):
        times = h * np.arange(round(0.06 / h) + 1)
        slave = Slave(motion_fmus["chain"], parameters={"integrator.rtol": 1e-11})
        try:
            rows = run(slave, times, motion(times[1:])[0])
        finally:
            slave.close()
        at = np.searchsorted(times[1:], common - h / 2)
        errors.append((np.max(np.abs(rows[at, 0] - x2_exact)),
                       np.max(np.abs(rows[at, 2] - effort_exact))))
    errors = np.array(errors)
    orders = np.log2(errors[:-1] / errors[1:])
    print("errors (x2 m, effort N):", errors.tolist(), "orders:", orders.tolist())
    assert np.all((1.8 <= orders[:, 1]) & (orders[:, 1] <= 2.2)), orders
    assert np.all(orders[:, 0] >= 3.5), orders
    assert errors[-1, 1] <= 0.05 * np.max(np.abs(effort_exact))


# -- states --------------------------------------------------------------------------------------

def test_a_state_carries_the_path(motion_fmus):
    """Stepped to 5 ms, its state taken and serialised; stepped on 5 ms with new positions.
    The state restored into the same instance, and deserialised into a fresh instance that
    has moved nothing, steps on with the same positions to the same outputs and efforts bit
    for bit: the path and the positions it is taken from travel with the state."""
    h = 1e-3
    times = h * np.arange(11)
    positions = motion(times[1:])[0]
    first = Slave(motion_fmus["chain"], "first")
    fresh = Slave(motion_fmus["chain"], "fresh")
    try:
        run(first, times[:6], positions[:5])
        state = first.fmu.getFMUstate()
        data = first.fmu.serializeFMUstate(state)
        original = run(first, times[5:], positions[5:])
        first.fmu.setFMUstate(state)
        again = run(first, times[5:], positions[5:])
        fresh.fmu.setFMUstate(fresh.fmu.deSerializeFMUstate(data))
        restored = run(fresh, times[5:], positions[5:])
        first.fmu.freeFMUstate(state)
        assert not [m for s, m in first.logs + fresh.logs if s == FMI2_ERROR]
    finally:
        first.close()
        fresh.close()
    assert np.ptp(original[:, 2]) > 1.0  # the efforts change over the steps compared
    np.testing.assert_array_equal(again, original)
    np.testing.assert_array_equal(restored, original)


def test_the_simulator_refuses_a_state_whose_motion_does_not_fit():
    """`Simulator.set_state` names what is wrong with a snapshot's motion: a path of the
    wrong size, positions whose times do not increase, a non-finite number."""
    sim = Simulator(build_model(chain()), method="esdirk", stepwise_motion=True)
    sim.move_to([X0 + 1e-5], 1e-3)
    state = sim.get_state()
    for change, message in [
            (lambda s: s.update(motion_path=s["motion_path"][:-1]),
             "the state's motion holds 7 path numbers and 2 times of 2 positions; expected 8"),
            (lambda s: s.update(motion_times=s["motion_times"][::-1]),
             r"the times of its positions \[0.001, 0.0\] s do not increase"),
            (lambda s: s["motion_positions"].__setitem__(0, np.nan),
             "the state's motion holds non-finite numbers")]:
        forged = {key: np.array(value, copy=True) if isinstance(value, np.ndarray) else value
                  for key, value in state.items()}
        change(forged)
        with pytest.raises(SimulationError, match=message):
            sim.set_state(forged)


# -- refusals ------------------------------------------------------------------------------------

def test_an_fmu_on_ida_follows_the_in_process_simulators(motion_fmus):
    """integrator.method = "ida" is taken with kinematic inputs: on a variable grid of the
    smooth motion's positions, the FMU's x2, v2 and effort equal the in-process Simulator's
    on IDA (the same code: within 1e-12 of the stroke, of 100 x the stroke per second and of
    the largest effort; measured 0) and agree with the in-process ESDIRK's at rtol 1e-9
    within 1e-8 of the same scales (measured 5.3e-10, 6.5e-10 and 3.0e-11)."""
    steps = np.array([1e-3, 2.5e-3, 0.4e-3, 1.7e-3, 3e-3, 0.9e-3] * 2)
    times = np.concatenate([[0.0], np.cumsum(steps)])
    positions = motion(times[1:])[0]
    slave = Slave(motion_fmus["chain"], parameters={"integrator.rtol": 1e-9},
                  strings={"integrator.method": "ida"})
    try:
        fmu = run(slave, times, positions)
        assert not [m for s, m in slave.logs if s == FMI2_ERROR]
    finally:
        slave.close()
    for method, bound in (("ida", 1e-12), ("esdirk", 1e-8)):
        sim = Simulator(build_model(chain()), method=method, rtol=1e-9, stepwise_motion=True)
        for k, (t1, u) in enumerate(zip(times[1:], positions, strict=True)):
            sim.move_to([u], t1)
            row = np.array([*sim.outputs(), *sim.efforts()])
            scales = np.array([STROKE, 100 * STROKE, np.max(np.abs(fmu[:, 2]))])
            assert np.all(np.abs(fmu[k] - row) <= bound * scales), (method, k)


def test_a_position_that_is_not_finite_is_refused(motion_fmus):
    """A NaN position is discarded naming the input; the instance stays where it was and
    steps on once the position is finite."""
    slave = Slave(motion_fmus["chain"])
    try:
        slave.fmu.setReal([slave.vr["u"]], [float("nan")])
        assert do_step(slave, 0.0) == 2
        assert any("kinematic input 'u' = nan m: expected a finite position" in m
                   for s, m in slave.logs if s == FMI2_ERROR), slave.logs
        slave.fmu.setReal([slave.vr["u"]], [X0 + 1e-6])
        assert do_step(slave, 0.0) == 0
        assert slave.y()[0] > 2 * X0  # m2 pulled along +x
    finally:
        slave.close()


def test_a_scene_with_kinematic_inputs_and_actuators_is_refused_at_build(tmp_path):
    data = chain()
    data["inputs"]["F"] = {"node": "2", "coordinate": "x"}
    data["actuators"] = {"VCM1": {"input": "F", "force_constant": 2.0, "resistance": 2.0,
                                  "inductance": 0.01}}
    scene = tmp_path / "actuated.toml"
    scene.write_text(scene_toml(data, "kinematic inputs with an actuator"))
    with pytest.raises(FMUBuildError, match=r"the kinematic inputs u and the actuators VCM1: "
                                            r"a time simulation takes kinematic inputs only "
                                            r"without actuators"):
        build_scene_fmu(scene, tmp_path / "actuated.fmu")


def test_a_moved_node_without_mass_is_refused_naming_the_input(tmp_path):
    """The follower with no mass at its moved node: the FMU's build (and any simulation) is
    refused, naming the scene (as the FMU embeds it), the singular mass matrix and the
    kinematic input."""
    data = follower()
    del data["nodes"]["1"]["mass"]
    scene = tmp_path / "massless.toml"
    scene.write_text(scene_toml(data, "a moved node without mass"))
    with pytest.raises(SimulationError, match=r"follower.fmu \(embedded scene\): the start "
                                              r"configuration .* "
                                              r"M_bar is singular .* the kinematic inputs \(u\) "
                                              r"are DOFs of the mass matrix too"):
        build_scene_fmu(scene, tmp_path / "massless.fmu")


def test_an_angle_is_set_in_rad_and_its_effort_is_a_moment(tmp_path):
    """A pendulum (0.3 kg at 0.25 m under gravity) turned at its pivot by a kinematic input on
    the hinge's angle: the FMU's input is in rad, its effort in N.m; turned to 0.8 rad in the
    first 1 ms step and held, after 5 steps (the last four angles equal: at rest) the effort
    is m g l sin(0.8) to 1e-12."""
    mass, length, g = 0.3, 0.25, 9.81
    data = turned_pendulum(mass, length, g, name="turned")
    data["outputs"] = {"bob_x": {"node": "bob", "coordinate": "x"}}
    scene = tmp_path / "turned.toml"
    scene.write_text(scene_toml(data, "a pendulum turned at its pivot"))
    slave = Slave(build_scene_fmu(scene, tmp_path / "turned.fmu"))
    try:
        units = {v.name: v.unit for v in slave.md.modelVariables}
        assert (units["A"], units["A.effort"]) == ("rad", "N.m")
        for k in range(5):
            slave.fmu.setReal([slave.vr["A"]], [0.8])
            bob_x, effort = slave.step(k * 1e-3, 1e-3)
    finally:
        slave.close()
    assert effort == pytest.approx(mass * g * length * np.sin(0.8), rel=1e-12)
    assert bob_x == pytest.approx(length * np.sin(0.8), rel=1e-9)


@pytest.mark.slow  # a portable compilation of the engine: a minute of CPU on an empty cache
def test_a_motion_fmu_carries_the_prescribed_engine(tmp_path):
    """Built with its compiled engine: the build's child host steps the FMU with each method,
    its inputs at their start (the position where the input is, not 0 m), and the engine it
    carries holds the prescribed forms' entries (the first-order form's and IDA's), every
    function cached."""
    import json
    import zipfile

    scene = tmp_path / "chain.toml"
    scene.write_text(scene_toml(chain(), "a test of displacement-driven FMUs"))
    fmu = build_scene_fmu(scene, tmp_path / "chain.fmu", engine=True)
    with zipfile.ZipFile(fmu) as archive:
        names = archive.namelist()
        manifest = json.loads(archive.read("resources/flexure-engine/manifest.json"))
    assert manifest["not_cached"] == []
    carried = [name for name in names if name.startswith("resources/flexure-engine/core/"
                                                         "engine/prescribed")]
    assert {name.split(".")[1].split("-")[0] for name in carried} == {
        "prescribed_rhs_entry", "prescribed_jacobian_entry", "prescribed_residual_entry",
        "prescribed_residual_jacobian_entry"}
