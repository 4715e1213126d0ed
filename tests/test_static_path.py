"""The load steps of `static_equilibrium` start on the quadratic through the path so far
(core/analysis/statics.py, `curvature_step`).

- on a quadratic path q(s) the step lands on q(s2) exactly (to round-off);
- on a cantilever bent to a quarter of its length by a tip force, the quadratic start is
  much closer to the next equilibrium than the tangent predictor (error O(h^3) against
  O(h^2)): within a fifth of the tangent's error;
- the equilibrium does not depend on it: load steps of 1, 2 and 5 give the same DOFs within
  1e-10 of the length scale;
- nor on where on its path of loads the stepping starts (`path`: equilibria under s times
  the loads), which saves the iterations of the part of the path already solved.
"""

import numpy as np
import pytest
from test_rotation_ports import cantilever

from flexure.core import build_model, static_equilibrium
from flexure.core.analysis.statics import curvature_step
from flexure.core.errors import ConvergenceError
from flexure.core.mechanics.mechanics import Mechanics

TIP_FORCE = 40.0  # N on 3.y: the tip of the 0.2 m cantilever moves about 0.05 m


@pytest.mark.parametrize("ratio", [0.5, 1.0, 2.0])
def test_on_a_quadratic_path_the_step_is_exact(ratio):
    a, b, c = np.array([0.1, -2.0]), np.array([0.3, 0.7]), np.array([-1.5, 4.0])

    def path(s):
        return a + b * s + c * s**2

    s0, s1 = 0.2, 0.5
    s2 = s1 + ratio * (s1 - s0)
    tangent_step = (s2 - s1) * (b + 2.0 * c * s1)
    step = curvature_step(path(s0), path(s1), tangent_step, ratio)
    np.testing.assert_allclose(path(s1) + step, path(s2), rtol=0, atol=1e-14)


def bent_cantilever():
    model = build_model(cantilever(inputs={}, outputs={}))
    loads = np.zeros(model.nx)
    loads[model.coordinate_index("3.y")] = TIP_FORCE
    return model, loads


def test_the_quadratic_start_is_closer_than_the_tangent():
    model, loads = bent_cantilever()
    s0, s1, s2 = 0.5, 0.75, 1.0
    q0, q1, q2 = (static_equilibrium(model, loads=s * loads).q for s in (s0, s1, s2))
    mech = Mechanics(model)
    config = mech.kinematics.solve(q1, model.initial_coordinates)
    Q, _, sigma = mech.static_balance(config, s2, loads)
    tangent_step = np.linalg.solve(mech.tangent_stiffness(config, sigma, s2), Q)
    tangent_error = np.max(np.abs(q1 + tangent_step - q2))
    quadratic = q1 + curvature_step(q0, q1, tangent_step, (s2 - s1) / (s1 - s0))
    assert tangent_error > 1e-4 * np.max(np.abs(q2 - q1))  # the path is curved
    assert np.max(np.abs(quadratic - q2)) < 0.2 * tangent_error


def test_the_equilibrium_does_not_depend_on_the_load_steps():
    model, loads = bent_cantilever()
    solutions = [static_equilibrium(model, loads=loads, load_steps=n) for n in (1, 2, 5)]
    length = 0.2  # m, the cantilever (its length scale)
    assert np.max(np.abs(solutions[0].x - solutions[0].model.initial_coordinates)) > 0.04
    for other in solutions[1:]:
        np.testing.assert_allclose(other.q, solutions[0].q, rtol=0, atol=1e-10 * length)


def test_a_path_of_equilibria_gives_the_same_equilibrium_in_fewer_iterations():
    model, loads = bent_cantilever()
    plain = static_equilibrium(model, loads=loads, load_steps=4)
    half = static_equilibrium(model, loads=0.5 * loads, load_steps=2)
    opposite = static_equilibrium(model, loads=-0.5 * loads, load_steps=2)
    for path in ([(0.5, half)], [(-0.5, opposite)], [(-0.5, opposite), (0.5, half)]):
        solution = static_equilibrium(model, loads=loads, load_steps=4, path=path)
        np.testing.assert_allclose(solution.q, plain.q, rtol=0, atol=1e-10 * 0.2)
    assert solution.iterations < plain.iterations  # the half already solved is skipped


@pytest.mark.parametrize("s", [1.0, 0.0, 2.0])
def test_a_path_point_off_the_path_is_refused(s):
    model, loads = bent_cantilever()
    half = static_equilibrium(model, loads=0.5 * loads)
    with pytest.raises(ValueError, match="needs 0 != s < 1"):
        static_equilibrium(model, loads=loads, path=[(s, half)])
    other = bent_cantilever()[0]
    with pytest.raises(ValueError, match="the same model"):
        static_equilibrium(other, loads=loads, path=[(0.5, half)])


def test_a_step_that_fails_from_a_path_point_is_halved_toward_it():
    """From the path point at half the load, one load step reaches for the full load; with
    one Newton iteration allowed, every step fails (the cantilever is nonlinear), and each
    halving tries half the increment tried before: 1 -> 0.75 -> 0.625 -> 0.5625 -> 0.53125.
    The error names the last one."""
    model, loads = bent_cantilever()
    half = static_equilibrium(model, loads=0.5 * loads, load_steps=2)
    with pytest.raises(ConvergenceError, match=r"load factor 0\.5 -> 0\.5312, after 4 step "
                       r"halvings"):
        static_equilibrium(model, loads=loads, load_steps=1, path=[(0.5, half)],
                           max_iterations=1)
