"""J's factors kept from an earlier kinematic solution (core/engine/kept_factors.py): the
refinement's residual against the plain product, and the engine's right-hand side with kept
factors (refined or not) against the one that factors J at every solution (the default)."""

import numpy as np

from flexure.core.engine import data as ed
from flexure.core.engine import engine, kept_factors
from flexure.core.engine.data import EngineData
from tests.test_engine import MODELS
from tests.test_sparse_lu import random_case


def test_the_residual_is_b_minus_a_y_in_the_matrix_order():
    """r = b - A y and b - A^T y on a random sparse A (its columns packed permuted) against
    numpy's products, to round-off of the terms."""
    for seed in range(3):
        rng, a, lu = random_case(seed, 40, 0.1)
        y, b, r = rng.standard_normal(40), rng.standard_normal(40), np.empty(40)
        for transposed, matrix in ((False, a), (True, a.T)):
            kept_factors.residual(lu.ints, lu.floats, y, b, r, transposed)
            scale = np.abs(matrix) @ np.abs(y) + np.abs(b)
            assert np.all(np.abs(r - (b - matrix @ y)) <= 1e-14 * scale)


def rhs_pair(data, move=0.0, refinements=0, singular_ratio=None):
    """OP_RHS at a random state y of 1e-4 (m, rad, m/s, rad/s) and then at y moved by 1e-6
    at random: (the second right-hand side, the counters)."""
    settings = data.float_array("settings")
    settings[ed.J_KEPT_MOVE], settings[ed.J_REFINEMENTS] = move, refinements
    if singular_ratio is not None:
        settings[ed.SINGULAR_RATIO] = singular_ratio
    n = data.int_array("dims")[ed.NDOF]
    rng = np.random.default_rng(1)
    y = 1e-4 * rng.standard_normal(2 * n)
    out = np.zeros(2 * n)
    assert engine.call(data, engine.OP_RHS, y, out) == ed.OK
    assert engine.call(data, engine.OP_RHS, y + 1e-6 * rng.standard_normal(2 * n), out) == ed.OK
    return out, data.int_array("counters").copy()


def test_kept_factors_refined_give_the_right_hand_side_of_fresh_ones():
    """On a scene forced onto the sparse LU (augmented form: xdot and the accelerations' J
    solves): the default factors J at both solutions; kept factors without refinement give
    a right-hand side off by the first-order term (measured: 1.7e-9 of its size here), each
    refinement contracts it (measured: 6.6e-13 after one), and three leave round-off."""
    model = MODELS["stage_spatial_19dof"]()

    def data():
        return EngineData(model, augmented=True, sparse=True)

    fresh, counters = rhs_pair(data())
    assert (counters[ed.SOLUTION_FACTORS], counters[ed.SOLUTION_KEPT]) == (2, 0)
    size = np.max(np.abs(fresh))
    errors = []
    for refinements in (0, 1, 3):
        kept, counters = rhs_pair(data(), move=1e12, refinements=refinements)
        assert (counters[ed.SOLUTION_FACTORS], counters[ed.SOLUTION_KEPT]) == (1, 1)
        errors.append(np.max(np.abs(kept - fresh)) / size)
    assert 1e-11 < errors[0] < 1e-6  # the kept factors were used, and serve to first order
    assert errors[1] < 1e-2 * errors[0]
    assert errors[2] < 1e-12


def test_no_factors_kept_near_a_singular_configuration_or_beyond_the_move():
    """Kept only while the pivot ratio of the kept factors exceeds KEPT_MARGIN times the
    singular ratio (the singular check then stays with every factorisation), and only
    within the move; the full Newton of a cold start factors at its solution."""
    model = MODELS["stage_spatial_19dof"]()
    data = EngineData(model, augmented=True, sparse=True)
    _, counters = rhs_pair(data, move=1e12)
    ratio = data.float_array("j_factored")[-1]
    assert counters[ed.SOLUTION_KEPT] == 1
    data = EngineData(model, augmented=True, sparse=True)
    _, counters = rhs_pair(data, move=1e12, singular_ratio=1.01 * ratio /
                           kept_factors.KEPT_MARGIN)
    assert (counters[ed.SOLUTION_FACTORS], counters[ed.SOLUTION_KEPT]) == (2, 0)
    data = EngineData(model, augmented=True, sparse=True)
    _, counters = rhs_pair(data, move=1e3)  # a move of 1e-6 is some 1e9 step tolerances
    assert (counters[ed.SOLUTION_FACTORS], counters[ed.SOLUTION_KEPT]) == (2, 0)
