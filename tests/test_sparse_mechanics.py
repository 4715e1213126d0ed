"""Dense and sparse mechanics agree: the rule (`Mechanics.sparse`, from
`kinematics.SPARSE_FROM` free coordinates on) and both paths on the same models just below
and just above the threshold: the spatial stage with each leaf in 21 or 22 segments (294 and
308 free coordinates), loaded sideways and under gravity, so that the geometric stiffness
carries stresses and the gravity term."""

import numpy as np
import pytest

from flexure.core import load_scene
from flexure.core.analysis.linearization import linearize
from flexure.core.analysis.modal import natural_frequencies
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.mechanics.kinematics import SPARSE_FROM
from flexure.core.mechanics.mechanics import Mechanics


def stage(segments):
    return load_scene("stage_spatial_1dof", overrides={
        "elements.leaf_left.segments": segments, "elements.leaf_right.segments": segments,
        "nodes.5.force": [1.0, 0.5, 0.2], "scene.gravity": [0.0, 0.0, -9.81]})


@pytest.mark.parametrize("segments", [21, 22])
def test_both_paths_give_the_same_linear_model_near_the_threshold(segments):
    model = stage(segments)
    assert Mechanics(model).sparse == (model.free_coordinates.size >= SPARSE_FROM)
    assert (model.free_coordinates.size >= SPARSE_FROM) == (segments == 22)
    dense, sparse = Mechanics(model, sparse=False), Mechanics(model, sparse=True)
    solution = static_equilibrium(model, mechanics=dense)
    assert np.any(np.abs(solution.stress_resultants) > 0.0)
    config, sigma = solution.config, solution.stress_resultants
    pairs = [(dense.mass_matrix(config), sparse.mass_matrix(config)),
             (dense.damping_matrix(config), sparse.damping_matrix(config)),
             (dense.structural_stiffness(config), sparse.structural_stiffness(config)),
             (dense.geometric_stiffness(config, sigma), sparse.geometric_stiffness(config,
                                                                                   sigma))]
    for a, b in pairs:  # the same sums in another order: round-off of the largest entry
        assert isinstance(b, np.ndarray) and b.shape == a.shape
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()
    # the frequencies of the same equilibrium through each: round-off of the largest
    # entries (axial stiffnesses of 5 mm segments) reaches the lowest eigenvalue amplified
    # (measured 2e-9 relative; the dense path alone moves as much with another BLAS)
    f_dense = natural_frequencies(model, 5, linear_model=linearize(
        model, solution, mechanics=dense)).frequencies_hz
    f_same = natural_frequencies(model, 5, linear_model=linearize(
        model, solution, mechanics=sparse)).frequencies_hz
    assert np.allclose(f_same, f_dense, rtol=1e-8, atol=0.0)
    # the statics through each: the same equilibrium within the Newton tolerance (1e-11 of
    # the size, 0.1 m), whose difference moves the frequencies by a few 1e-9 (measured 2e-9)
    other = static_equilibrium(model, mechanics=sparse)
    assert np.abs(other.x - solution.x).max() < 1e-11 * 0.1
    f_sparse = natural_frequencies(model, 5, linear_model=linearize(
        model, other, mechanics=sparse)).frequencies_hz
    assert np.allclose(f_sparse, f_dense, rtol=1e-7, atol=0.0)


def test_the_statics_share_one_initial_configuration_and_leave_it_unchanged():
    """Every solve through one Mechanics starts at the configuration it keeps for the
    initial coordinates: after solves under two loads it is the same object with the same
    numbers, and a solve through it gives the bits of one through a new Mechanics."""
    model = stage(22)
    mech = Mechanics(model)
    first = static_equilibrium(model, mechanics=mech, compiled=False)  # numpy: not the engine
    shared = mech.initial_configuration(shared=True)
    assert shared is mech.initial_configuration(shared=True)
    assert shared is not mech.initial_configuration()
    kept = {name: np.array(getattr(shared, name)) for name in ("q", "x", "e", "De", "DF")}
    twice = static_equilibrium(model, loads=2.0 * model.loads, mechanics=mech, compiled=False)
    fresh = static_equilibrium(model, loads=2.0 * model.loads, mechanics=Mechanics(model),
                               compiled=False)
    assert np.array_equal(twice.x, fresh.x)
    assert np.array_equal(twice.stress_resultants, fresh.stress_resultants)
    assert np.abs(twice.x - first.x).max() > 1e-6
    assert mech.initial_configuration(shared=True) is shared
    for name, value in kept.items():
        assert np.array_equal(np.asarray(getattr(shared, name)), value), name
