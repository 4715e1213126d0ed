"""Spatial models with short elements (issue 31): a 0.1 m strip in 16 BEAMs of 6.25 mm with a
tip mass under a 3 N step simulates, as cheaply as in 8; a state whose constraints cannot be
solved is named by its own time.

Before the tolerances had units (`flexure.core.mechanics.scales`), the kinematics' Newton
stopped at 1e-14 times the longest element for every row: below 11 mm that is below the
round-off of the Euler parameters' normalisation rows (1.1e-16), so the 16-segment strip's
output kinematics failed at t = 0.05 s and its integration took 2398 Jacobians against 34 at 8
segments (measured on this strip, cvode-bdf, rtol 1e-6).
"""

import numpy as np
import pytest

from flexure.core import build_model, load_scene, simulate, static_equilibrium
from flexure.core.errors import SimulationError
from flexure.core.simulation.simulator import Simulator

E, WIDTH, HEIGHT, LENGTH = 2.1e11, 0.01, 0.001, 0.1  # Pa, m, m, m
FORCE, T_END = 3.0, 0.05  # N, s


def strip(segments):
    """A steel strip 100 x 10 x 1 mm clamped at node 1, a 0.1 kg mass at its tip (node 3),
    the input F a force along z (the thin direction), every deformation released and
    stiffness-proportional damping beta = 1e-5 s; meshed into `segments` BEAMs."""
    return {"scene": {"name": f"strip{segments}", "dimension": 3},
            "sections": {"strip": {"E": E, "nu": 0.3, "rho": 7850.0, "width": WIDTH,
                                   "height": HEIGHT, "beta": 1e-5}},
            "nodes": {"1": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
                      "2": {"rotation": [0.0, 0.0, 0.0], "fixed": True},
                      "3": {"position": [LENGTH, 0.0, 0.0], "mass": 0.1},
                      "4": {"rotation": [0.0, 0.0, 0.0]}},
            "elements": {"strip": {"type": "BEAM", "nodes": ["1", "2", "3", "4"],
                                   "section": "strip", "y_axis": [0.0, 0.0, 1.0],
                                   "released": ["e1", "e2", "e3", "e4", "e5", "e6"],
                                   "segments": segments}},
            "inputs": {"F": {"node": "3", "coordinate": "z"}},
            "outputs": {"z": {"node": "3", "coordinate": "z", "quantity": "position"}}}


@pytest.fixture(scope="module")
def runs():
    """{segments: (static tip deflection m, SimulationResult of the 3 N step)}."""
    out = {}
    for segments in (8, 16):
        model = build_model(strip(segments))
        static = static_equilibrium(model, inputs={"F": FORCE}).coordinates()["3.z"]
        out[segments] = static, simulate(model, T_END, inputs={"F": FORCE}, rtol=1e-6)
    return out


def test_sixteen_segments_simulate_and_agree_with_eight(runs):
    """Both meshes run to the end with their outputs solved at every recorded state; the tip
    moves as in 8 segments within 1e-3 (the meshes differ in their mass discretisation:
    2.5e-4 measured) and its static deflection is Euler-Bernoulli's F L^3 / (3 E I) within
    1 % (the geometric nonlinearity at a deflection of 5.7 % of the length shortens it by
    0.3 %), the two meshes within 1e-4 (cubic beams hold the linear tip-load solution
    exactly: what remains is the nonlinear part's discretisation, 7e-5 measured)."""
    linear = FORCE * LENGTH ** 3 / (3.0 * E * WIDTH * HEIGHT ** 3 / 12.0)
    for segments, (static, result) in runs.items():
        assert result.times[-1] == pytest.approx(T_END)
        assert np.all(np.isfinite(result.outputs["z"]))
        assert static == pytest.approx(linear, rel=1e-2), segments
    assert runs[16][0] == pytest.approx(runs[8][0], rel=1e-4)
    tip8, tip16 = runs[8][1].outputs["z"], runs[16][1].outputs["z"]
    assert tip16[-1] == pytest.approx(tip8[-1], rel=1e-3)
    assert np.max(np.abs(tip16)) == pytest.approx(np.max(np.abs(tip8)), rel=1e-3)


def test_sixteen_segments_cost_no_more_jacobians_than_eight(runs):
    """The Jacobians follow the slow dynamics (the tip mass on the strip's bending, the same
    in both meshes); the finer mesh adds stiffer modes, which BDF damps. Bound: 2 x the count
    at 8 segments (measured 28 against 31); the kinematics below round-off took 70 x."""
    jacobians = {n: result.statistics["jacobian_evaluations"] for n, (_, result) in
                 runs.items()}
    assert jacobians[16] <= 2 * jacobians[8], jacobians


def test_an_unsolvable_state_is_named_by_its_own_time(monkeypatch):
    """outputs_along / outputs_and_warnings name the time of the state whose kinematics
    fail (the leaf springs of stage_planar_1dof, 0.1 m long, cannot put node 3 at x = 0.15 m),
    not the simulator's; simulate hands them its recorded times."""
    model = load_scene("stage_planar_1dof")
    sim = Simulator(model)
    n = sim.ndof
    states = np.zeros((3, 2 * n))
    states[:, :n] = sim.q_ref
    states[1, 0] += 1e-3  # m: within reach
    states[2, 0] = 0.15  # m: beyond the leaves' reach
    times = [0.0, 0.01, 0.0237]
    with pytest.raises(SimulationError, match=r"^t = 0\.0237 s \(state 3 of 3 .*\): outputs: "):
        sim.outputs_and_warnings(states, times=times)
    with pytest.raises(SimulationError, match=r"^a state \(state 3 of 3 .*\): outputs: "):
        sim.outputs_along(states)
    assert sim.outputs_along(states[:2], times=times[:2]).shape == (2, len(model.outputs))
    # simulate passes each recorded state's time
    seen = {}
    original = Simulator.outputs_and_warnings

    def spy(self, states, *, times=None, **held):
        seen["times"] = None if times is None else np.array(times)
        return original(self, states, times=times, **held)

    monkeypatch.setattr(Simulator, "outputs_and_warnings", spy)
    result = simulate(model, 0.01, inputs={"F": 1.0}, rtol=1e-6)
    assert np.array_equal(seen["times"], result.times)
