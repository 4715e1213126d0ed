"""Displacement-driven FMUs: a scene's kinematic inputs as FMU inputs in m (the position at the
end of each step), their efforts as outputs in N (`flexure.core.simulation.stepwise_motion`'s
path rule, docs/fmu.md).

Checked in fmpy: the model description; the FMU against the in-process Simulator given the
same positions, and the path against the rule worked out here with numpy's polynomials; the
rule's order in the communication step h against a closed-form-driven reference (scipy);
states that carry the path; the refusals; and a force-driven FMU and a displacement-driven
one coupled by a master, against the one-scene model of the same chain.
"""

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy_slave import Slave
from kinematic_scenes import C1, C2, K1, K2, M1, M2, chain
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
X0, STROKE, PERIOD = 0.1, 1e-3, 0.04  # node 1's start (m), the motion's stroke (m), period (s)


def motion(t):
    """A smooth motion of node 1 that starts at rest (its first three derivatives zero):
    u = X0 + STROKE / 4 (1 - cos w t)^2; (u, u', u'') in m, m/s, m/s^2."""
    w = 2 * np.pi / PERIOD
    c, s = np.cos(w * t), np.sin(w * t)
    return (X0 + STROKE / 4 * (1 - c) ** 2, STROKE / 2 * (1 - c) * w * s,
            STROKE / 2 * w**2 * (s**2 + (1 - c) * c))


# node 1's mass M1 split: the follower carries some of it, since the prescribed form solves
# with the mass matrix of every DOF, the moved node's too (a massless one is singular); a
# small part, since a coupling by positions and forces is stable only while the mass the
# follower moves is small against the leader's (`test_the_added_mass_limit`)
FOLLOWER_MASS = M1 / 10


def leader():
    """The chain's first half, force-driven: ground -k1, c1- node 1 (M1 - FOLLOWER_MASS), the
    force F on 1.x; its position and velocity out."""
    data = chain()
    data["scene"]["name"] = "leader"
    data["nodes"] = {"0": data["nodes"]["0"],
                     "1": data["nodes"]["1"] | {"dof": ["x"], "mass": M1 - FOLLOWER_MASS}}
    data["elements"] = {"a": data["elements"]["a"]}
    data["sections"] = {"a": data["sections"]["a"]}
    data["inputs"] = {"F": {"node": "1", "coordinate": "x"}}
    data["outputs"] = {"x1": {"node": "1", "coordinate": "x"},
                       "v1": {"node": "1", "coordinate": "x", "quantity": "velocity"}}
    return data


def follower():
    """The chain's second half, displacement-driven: node 1 (FOLLOWER_MASS) moved (u), -k2,
    c2- m2 (node 2); the force that moves node 1 is u.effort."""
    data = chain()
    data["scene"]["name"] = "follower"
    data["nodes"] = {"1": {"position": [X0, 0.0], "fixed": ["y"], "mass": FOLLOWER_MASS},
                     "2": data["nodes"]["2"]}
    data["elements"] = {"b": data["elements"]["b"]}
    data["sections"] = {"b": data["sections"]["b"]}
    return data


def whole():
    """The chain in one scene: the force F on m1, both masses free."""
    data = chain()
    data["scene"]["name"] = "whole"
    data["nodes"]["1"]["dof"] = ["x"]
    data["inputs"] = {"F": {"node": "1", "coordinate": "x"}}
    data["outputs"] = {"x1": {"node": "1", "coordinate": "x"},
                       "x2": {"node": "2", "coordinate": "x"}}
    return data


@pytest.fixture(scope="module")
def motion_fmus(tmp_path_factory):
    """{name: FMU path} of the chain moved at node 1, the leader and the follower."""
    folder = tmp_path_factory.mktemp("motion_fmus")
    paths = {}
    for data in (chain(), leader(), follower()):
        name = data["scene"]["name"]
        scene = folder / f"{name}.toml"
        scene.write_text(scene_toml(data, "a test of displacement-driven FMUs"))
        paths[name] = build_scene_fmu(scene, folder / f"{name}.fmu")
    return paths


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
    """The engine's `path_point` and numpy's `path_values` on a step's piece (`next_piece`):
    at the step's start, the rate and acceleration the piece starts with (not the held
    path's zeros: the step's first evaluation is there); at its end (and an ulp past it,
    where a stage time t + c h may round), the position set and the cubic's rate and
    acceleration, to round-off (1e-12 of the stroke, stroke / h, stroke / h^2)."""
    from flexure.core.engine.prescribed import path_point
    from flexure.core.simulation.simulator_motion import path_values

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

def do_step(slave, t, h=1e-3):
    """fmi2DoStep's status: 0 OK, 2 Discard (fmpy raises on any status but OK)."""
    try:
        slave.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        return 0
    except FMICallException as error:
        return error.status


def test_ida_and_a_position_that_is_not_finite_are_refused(motion_fmus):
    """IDA cannot integrate kinematic inputs: setting it is refused naming the method, the
    inputs and the methods that can, and the next doStep is discarded. A NaN position is
    discarded naming the input; the instance stays where it was and steps on once the
    position is finite."""
    slave = Slave(motion_fmus["chain"], strings={"integrator.method": "ida"})
    try:
        assert do_step(slave, 0.0) == 2
        refusals = [m for s, m in slave.logs if s == FMI2_ERROR]
        assert any("integrator.method = 'ida' cannot integrate the kinematic inputs (u) of "
                   "'chain'; expected one of esdirk" in m for m in refusals), refusals
    finally:
        slave.close()
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


# -- a coupled pair ------------------------------------------------------------------------------

def coupled_pair(paths, h, t_end, force):
    """The leader (force-driven) and the follower (displacement-driven) coupled by a
    Gauss-Seidel master at step h: the leader steps with `force` minus the follower's last
    effort held; its position at the end of the step is the follower's position to reach.
    x1 and x2 (m) after each step."""
    parameters = {"integrator.rtol": 1e-10}
    first = Slave(paths["leader"], "leader", parameters=parameters)
    second = Slave(paths["follower"], "follower", parameters=parameters)
    rows = []
    try:
        effort = second.y()[second.outputs.index("u.effort")]
        for k in range(round(t_end / h)):
            first.set(force - effort)
            x1 = first.step(k * h, h)[0]
            second.fmu.setReal([second.vr["u"]], [x1])
            x2, _, effort = second.step(k * h, h)
            rows.append((x1, x2))
    finally:
        first.close()
        second.close()
    return np.array(rows)


def whole_reference(times, force):
    """x1, x2 (m) of the one-scene chain under `force` (N) from rest at times (CVODE BDF,
    rtol 1e-10, in process)."""
    sim = Simulator(build_model(whole()), method="cvode-bdf", rtol=1e-10)
    sim.set_inputs([force])
    reference = []
    for t in times:
        sim.advance_to(t)
        reference.append(sim.outputs())
    return np.array(reference)


def test_a_force_driven_and_a_displacement_driven_fmu_make_the_chain(motion_fmus):
    """1 N on m1 from rest: the pair, coupled at h = 1, 0.5 and 0.25 ms, against the chain in
    one scene in process (CVODE BDF, rtol 1e-10), every 10 ms over 0.1 s: the error shrinks at
    order 1 in h (the leader holds the follower's effort over a step; measured 1.00 and
    1.00), to 5e-3 of the largest displacement at 0.25 ms (measured 4.9e-6 m of 3.1 mm)."""
    t_end, force, common = 0.1, 1.0, np.linspace(0.01, 0.1, 10)
    reference = whole_reference(common, force)
    errors = []
    for h in (1e-3, 5e-4, 2.5e-4):
        rows = coupled_pair(motion_fmus, h, t_end, force)
        at = np.rint(common / h).astype(int) - 1
        errors.append(np.max(np.abs(rows[at] - reference)))
    errors = np.array(errors)
    orders = np.log2(errors[:-1] / errors[1:])
    moved = np.max(np.abs(reference - [X0, 2 * X0]))  # m, the largest displacement
    print("pair errors (m):", errors.tolist(), "orders:", orders.tolist(), "moved", moved)
    assert np.all((0.9 <= orders) & (orders <= 1.1)), orders
    assert errors[-1] <= 5e-3 * moved


NS = 1_000_000_000  # libcosim counts time in integer nanoseconds


def libcosim_pair(paths, h, t_end, force):
    """The pair in libcosim, which steps its slaves side by side (Jacobi): before each step
    the master sets the leader's force minus the follower's effort, and the follower's
    position to reach, predicted from the leader's position and velocity now (x1 + h v1).
    x1 and x2 (m) after each step."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(step_size=round(h * NS))
    first = execution.add_local_slave(CosimLocalSlave(fmu_path=str(paths["leader"]),
                                                      instance_name="leader"))
    second = execution.add_local_slave(CosimLocalSlave(fmu_path=str(paths["follower"]),
                                                       instance_name="follower"))
    vr = {slave: {v.name.decode(): v.reference for v in execution.slave_variables(slave)}
          for slave in (first, second)}
    for slave in (first, second):
        execution.real_initial_value(slave, vr[slave]["integrator.rtol"], 1e-10)
    manipulator = CosimManipulator.create_override()
    execution.add_manipulator(manipulator=manipulator)
    last = CosimObserver.create_last_value()
    execution.add_observer(observer=last)
    x1, v1, effort = X0, 0.0, 0.0  # at rest at the start
    rows = []
    for _ in range(round(t_end / h)):
        manipulator.slave_real_values(first, [vr[first]["F"]], [force - effort])
        manipulator.slave_real_values(second, [vr[second]["u"]], [x1 + h * v1])
        assert execution.step()
        x1, v1 = last.last_real_values(first, [vr[first]["x1"], vr[first]["v1"]])
        x2, effort = last.last_real_values(second, [vr[second]["x2"], vr[second]["u.effort"]])
        rows.append((x1, x2))
    execution.stop()
    return np.array(rows)


def test_the_pair_in_libcosim_side_by_side(motion_fmus):
    """The same pair stepped side by side in libcosim, the follower's position predicted from
    the leader's (x1 + h v1): against the one-scene chain every 10 ms, order 1 in h as well
    (measured 1.01 and 1.01), to 5e-3 of the largest displacement at 0.25 ms (measured
    5.0e-6 m of 3.1 mm)."""
    t_end, force, common = 0.1, 1.0, np.linspace(0.01, 0.1, 10)
    reference = whole_reference(common, force)
    errors = []
    for h in (1e-3, 5e-4, 2.5e-4):
        rows = libcosim_pair(motion_fmus, h, t_end, force)
        at = np.rint(common / h).astype(int) - 1
        errors.append(np.max(np.abs(rows[at] - reference)))
    errors = np.array(errors)
    orders = np.log2(errors[:-1] / errors[1:])
    moved = np.max(np.abs(reference - [X0, 2 * X0]))
    print("libcosim pair errors (m):", errors.tolist(), "orders:", orders.tolist())
    assert np.all((0.9 <= orders) & (orders <= 1.1)), orders
    assert errors[-1] <= 5e-3 * moved


def in_process_pair(ratio, h, *, predict, t_end=0.1, force=1.0):
    """The pair coupled in process (the FMUs' simulators), the follower moving `ratio` times
    the leader's mass at node 1 (M1 in all): Gauss-Seidel, or side by side with the position
    predicted (`predict`). The largest displacement of node 1 (m), or inf once beyond 1 m."""
    follower_mass = M1 * ratio / (1 + ratio)
    first_scene, second_scene = leader(), follower()
    first_scene["nodes"]["1"]["mass"] = M1 - follower_mass
    second_scene["nodes"]["1"]["mass"] = follower_mass
    first = Simulator(build_model(first_scene), method="esdirk", rtol=1e-9)
    second = Simulator(build_model(second_scene), method="esdirk", rtol=1e-9,
                       stepwise_motion=True)
    x1, v1, effort, largest = X0, 0.0, 0.0, 0.0
    for k in range(round(t_end / h)):
        target = x1 + h * v1
        first.set_inputs([force - effort])
        first.advance_to((k + 1) * h)
        x1, v1 = first.outputs()
        second.move_to([target if predict else x1], (k + 1) * h)
        effort = second.efforts()[0]
        largest = max(largest, abs(x1 - X0))
        if largest > 1.0:
            return np.inf
    return largest


def test_the_added_mass_limit():
    """A coupling by positions and forces is stable while the mass the displacement-driven
    side moves at its input is small against the force-driven side's (the added-mass limit
    of explicit coupling, whatever h): at h = 1 ms, Gauss-Seidel up to the same mass (0.8
    times: node 1 moves at most 1.738 mm, the one-scene chain's 1.744 mm; 1.5 times:
    diverges), side by side with the position predicted up to a third of it (0.2 times:
    1.741 mm; 0.5 times: diverges). docs/fmu.md says so."""
    largest = np.max(np.abs(whole_reference(np.linspace(1e-3, 0.1, 100), 1.0)[:, 0] - X0))
    assert in_process_pair(0.8, 1e-3, predict=False) == pytest.approx(largest, rel=0.01)
    assert in_process_pair(1.5, 1e-3, predict=False) == np.inf
    assert in_process_pair(0.2, 1e-3, predict=True) == pytest.approx(largest, rel=0.01)
    assert in_process_pair(0.5, 1e-3, predict=True) == np.inf


def test_an_angle_is_set_in_rad_and_its_effort_is_a_moment(tmp_path):
    """A pendulum (0.3 kg at 0.25 m under gravity) turned at its pivot by a kinematic input on
    the hinge's angle: the FMU's input is in rad, its effort in N.m; turned to 0.8 rad in the
    first 1 ms step and held, after 5 steps (the last four angles equal: at rest) the effort
    is m g l sin(0.8) to 1e-12."""
    mass, length, g = 0.3, 0.25, 9.81
    data = {"scene": {"name": "turned", "gravity": [0.0, -g]},
            "sections": {"link": {"EA": 1e6, "EI": 1e3}},
            "nodes": {"pivot": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                      "hinge": {"angle": 0.0},
                      "bob": {"position": [0.0, -length], "mass": mass},
                      "bob_r": {"angle": 0.0}},
            "elements": {"link": {"type": "PLBEAM", "nodes": ["pivot", "hinge", "bob", "bob_r"],
                                  "section": "link"}},
            "inputs": {"A": {"kind": "motion", "node": "hinge", "coordinate": "phi"}},
            "outputs": {"bob_x": {"node": "bob", "coordinate": "x"}}}
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
    """Built with its compiled engine: the build's child host steps the FMU with each method
    that integrates kinematic inputs (IDA would be refused), its inputs at their start (the
    position where the input is, not 0 m), and the engine it carries holds the prescribed
    form's entries, every function cached."""
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
                                                         "engine/prescribed.")]
    assert {name.split(".")[1].split("-")[0] for name in carried} == {
        "prescribed_rhs_entry", "prescribed_jacobian_entry"}
