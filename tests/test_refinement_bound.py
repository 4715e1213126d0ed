"""The input response refined to a weighted bound (core/engine/refinement.py's
`refined_solve_within`, the ESDIRK's `response_weights`) against independent solutions.

OP_INPUT_RESPONSE takes the error weights w (NDOF,) of its second array: a refined response
may stop once its estimated error e in d qddot has sqrt(mean((w_j e_j)^2)) <= 1, besides the
fixed 1e-12 of itself. The references: qddot(u1) - qddot(u0) of two full rhs at the same
state, each with the kept factors dropped, so that it solves the assembled system afresh
(an rhs that refines with kept factors stops at a residual of 45 ulps of the forces,
whose error in a difference of two accelerations is far above 1e-12 of it), and numpy's
dense solve of the assembled A (tests/test_refinement.py's); the loop's: the same loop with
the fixed tolerance (flags[I_BOUNDED_RESPONSE] = 0).
"""

import numpy as np
import pytest
from compiled_loops import run_compiled_loop
from test_engine import close
from test_refined_accelerations import plain
from test_refinement import counted, numpy_solution, packed, stage_force

from flexure.core import Simulator, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.refinement import MAX_PRODUCTS, weighted_size
from flexure.core.simulation.esdirk_layout import I_BOUNDED_RESPONSE

STATES_APART = 5  # the kept factors' age in states 1e-7 m or rad apart (tests/test_refinement)


def response(data, u, weights=None):
    """d qddot (m/s^2, rad/s^2) for the inputs u against the last stage force's, refined to
    the weights' bound (None: the fixed tolerance); and the products it took."""
    data.float_array("inputs")[:] = u
    out = np.full(data.int_array("dims")[ed.NDOF], np.nan)
    before = counted(data)
    assert engine.call(data, engine.OP_INPUT_RESPONSE, out, weights) == ed.OK
    refined, products, factored = (a - b for a, b in zip(counted(data), before, strict=True))
    assert (refined, factored) == (1, 0)
    return out, products


def aged(name):
    """(data, y, u0, u1): A factored at a random state, then a stage force STATES_APART
    states further on, whose responses refine with those kept factors."""
    model, data, y0, u0 = packed(name)
    stage_force(data, y0, u0)
    out = np.zeros(data.int_array("dims")[ed.NDOF])
    data.float_array("inputs")[:] = u0 + 1.0
    assert engine.call(data, engine.OP_INPUT_RESPONSE, out) == ed.OK
    assert counted(data)[2] == 1
    rng = np.random.default_rng(42)
    n = y0.size // 2
    y = y0 + STATES_APART * 1e-7 * np.concatenate([rng.standard_normal(n), np.zeros(n)])
    stage_force(data, y, u0)
    return data, y, u0, u0 + rng.standard_normal(u0.size)


def weighted_error(change, exact, weights):
    """sqrt(mean((w_j e_j)^2)) of e = change - exact."""
    return float(np.sqrt(np.mean(np.square(weights * (change - exact)))))


@pytest.mark.parametrize("relative", [1e-3, 1e-6])
def test_a_response_to_a_loose_bound_meets_it_in_fewer_products(relative):
    """On manipulator_control with factors five states back: the fixed tolerance takes two
    or three products; a bound of `relative` of the largest |d qddot| (weights 1 / (relative
    max |d qddot|) on every DOF) stops earlier, and the response it gives is within that
    bound of qddot(u1) - qddot(u0) of two full rhs solved afresh (whose own error, about
    1e-12 of qddot, is far below it). The fixed tolerance's response is still exact to 1e-11 of the
    largest acceleration against numpy's dense solve (tests/test_refinement.py's bound).
    Measured: 3 products fixed; 1 and 2 bounded, off by 3.9e-8 and 4.8e-11 of the largest
    |d qddot| (the second at the full rhs' own round-off)."""
    data, y, u0, u1 = aged("manipulator_control")
    fixed, fixed_products = response(data, u1)
    d, expected = numpy_solution(data)
    close(d, expected, 1e-11)
    assert 2 <= fixed_products <= MAX_PRODUCTS
    weights = np.full(fixed.size, 1.0 / (relative * np.max(np.abs(fixed))))
    stage_force(data, y, u0)  # the same state again: the kept factors are unchanged
    bounded, products = response(data, u1, weights)
    assert products < fixed_products
    exact = plain(data, y, u1)[0] - plain(data, y, u0)[0]
    assert weighted_error(bounded, exact, weights) <= 1.0
    assert weighted_error(fixed, exact, weights) <= 1e-3  # the reference's own error


def test_a_bound_tighter_than_round_off_takes_the_fixed_tolerances_products():
    """Weights that ask for 1e-15 of the response (below round-off) change nothing: the
    fixed tolerance's test still accepts, after as many products, and the two responses
    are equal to the bit."""
    data, y, u0, u1 = aged("manipulator_control")
    fixed, fixed_products = response(data, u1)
    weights = np.full(fixed.size, 1.0 / (1e-15 * np.max(np.abs(fixed))))
    stage_force(data, y, u0)
    bounded, products = response(data, u1, weights)
    assert products == fixed_products
    np.testing.assert_array_equal(bounded, fixed)


@pytest.mark.parametrize("name", ["manipulator_control", "cantilever_16"])
def test_the_weighted_size_is_that_of_the_responses_accelerations(name):
    """`weighted_size` of the augmented system's solution d that a response leaves (its free
    coordinates' accelerations, and with rigid clusters the slaves' from their masters') is
    sqrt(mean((w_j d qddot_j)^2)) of the d qddot the response returned, for random weights,
    to round-off (on manipulator_control most DOFs are slaves' coordinates)."""
    data, y, u0, u1 = aged(name)
    change, _ = response(data, u1)
    dims = data.int_array("dims")
    solution = data.float_array("augmented_rhs")[:dims[ed.NFREE] + dims[ed.NRIGID]].copy()
    weights = np.random.default_rng(7).uniform(0.5, 2.0, change.size)
    size = weighted_size(data.address, solution, weights, np.zeros(dims[ed.NX]),
                         np.zeros(change.size))
    expected = np.sqrt(np.mean(np.square(weights * change)))
    assert size == pytest.approx(expected, rel=1e-13)


@pytest.mark.slow  # 2 s: two loops of manipulator_control
def test_the_loop_with_the_bounded_response_tracks_as_with_the_fixed_one():
    """A 10 ms move of manipulator_control at 4 kHz (esdirk2 = TR-BDF2 at rtol 1e-5, as the
    benchmark's loop; the compiled loop, the input response from a stage force's A each
    sample) with the response to the step's weighted bound against the fixed 1e-12: the
    positions within 0.01 rtol of the stroke (the bound lets each step move by at most
    RESPONSE_SHARE / sqrt(2) of the Newton tolerance, 0.0035 of the error a step may make),
    the forces within 1e-5 of the largest, and the bounded run takes fewer products
    (measured: 6.4e-12 of the stroke, 3.6e-9 of the forces; over the 49 responses 105
    products and one factorisation of A against 145 and 30)."""
    from flexure.controllers import build_loop

    model = load_scene("manipulator_control")
    controller, design = build_loop(model, stroke=1e-3, duration=0.01, settle=0.0025,
                                    fs=4000.0)
    runs, products = [], []
    for bounded in (True, False):
        sim = Simulator(model, method="esdirk2", rtol=1e-5)
        assert sim.data.int_array("dims")[ed.NEWTON_SPARSE] == 1
        sim.integrator.flags[I_BOUNDED_RESPONSE] = int(bounded)
        runs.append(run_compiled_loop(sim, controller, design))
        counters = sim.data.int_array("counters")
        products.append(counters[ed.REFINEMENT_PRODUCTS])
    (_, position, force), (_, position_fixed, force_fixed) = runs
    stroke = np.ptp(position_fixed)
    assert stroke > 5e-4
    close(position, position_fixed, 0.01 * 1e-5, scale=stroke)
    close(force, force_fixed, 1e-5)
    assert products[0] < products[1]  # over as many responses (one a sample)
