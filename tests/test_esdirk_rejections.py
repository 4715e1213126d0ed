"""The ESDIRK's step after repeated error-test failures at one t (`esdirk_kernels.
observed_shrink`).

The step size control assumes the error falls as h^(p + 1) (p the lower of the tableau's two
orders). After a second failure at the same t the error's observed order in h, from the two
failed attempts, replaces it where it is lower. Checked here:

- the factor against its plain formula, and that it leaves a step whose error falls as
  assumed (or faster) to the usual control;
- the case that asked for it: the 384-DOF spatial cantilever under a sudden 1 N tip load,
  whose first step's error falls as about h^0.4. At rtol 1e-7 the ESDIRK had stopped at
  t = 0 with ERROR_TEST_FAILURES (more than MAX_FAILURES rejections); it now runs the 5 ms
  to its tip's z within 3e-5 of the deflection of an rtol 1e-10 run (measured 1.0e-5; the
  rtol 1e-6 run's 5.1e-5), and at rtol 1e-6 takes at most 5 rejected steps (10 before,
  with the same sample stops: measured 2).
"""

import math

import numpy as np
import pytest

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Simulator
from flexure.core.simulation.esdirk_kernels import (
    ORDER_FLOOR,
    SAFETY,
    SHRINK_FLOOR,
    observed_shrink,
)

EXPONENT = 0.25  # the order-4 tableau's control exponent 1 / (3 + 1)


def plain_shrink(h, error, h_before, error_before, exponent):
    """The module docstring's rule, written out."""
    if h_before <= h:
        return 1.0
    order = math.log(error_before / error) / math.log(h_before / h)
    if order >= 1.0 / exponent:
        return 1.0
    return max(SHRINK_FLOOR, SAFETY * error ** (-1.0 / max(order, ORDER_FLOOR)))


@pytest.mark.parametrize("h, error, h_before, error_before", [
    (5e-7, 6.0 * 0.5 ** 0.4, 1e-6, 6.0),      # the cantilever's start: order 0.4 -> floor 0.5
    (5e-7, 6.0 * 0.5 ** 1.5, 1e-6, 6.0),      # order 1.5
    (5e-7, 30.0, 1e-6, 20.0),                 # error grew as h fell: the floor of the factor
    (5e-7, 2.0, 1e-6, 2.0 * 2.0 ** 4),        # as assumed: no further cut
    (5e-7, 1.5, 1e-6, 1.5 * 2.0 ** 5),        # faster than assumed: no further cut
    (1e-6, 3.0, 5e-7, 6.0),                   # a larger h than before: no information
])
def test_the_factor_after_a_second_failure_is_the_plain_formula(h, error, h_before,
                                                                error_before):
    got = observed_shrink(h, error, h_before, error_before, EXPONENT)
    want = plain_shrink(h, error, h_before, error_before, EXPONENT)
    assert math.isclose(got, want, rel_tol=1e-12), (got, want)
    assert SHRINK_FLOOR <= got <= 1.0


def test_a_slowly_falling_error_cuts_the_step_harder_than_the_assumed_order():
    """Error 6 falling as h^0.4: the usual control cuts h by 0.9 6^(-1/4) = 0.575; the
    observed order (floored at 0.5) by 0.9 e^(-2), about 0.033 at e = 4.5."""
    error = 6.0 * 0.5 ** 0.4
    got = observed_shrink(5e-7, error, 1e-6, 6.0, EXPONENT)
    assert math.isclose(got, SAFETY * error ** -2.0, rel_tol=1e-12)
    assert got < 0.1 * SAFETY * error ** -EXPONENT


def tip_history(model, rtol, samples):
    """The tip's z (m) at `samples` (s) and the run's integrator statistics."""
    sim = Simulator(model, method="esdirk", rtol=rtol)
    z = []
    for t in samples:
        sim.advance_to(float(t))
        z.append(float(sim.outputs()[0]))
    return np.array(z), sim.integrator.statistics()


@pytest.mark.slow
def test_the_384_dof_cantilevers_sudden_load_starts_at_a_tight_tolerance():
    model = spatial_cantilever(64, output=True)
    samples = np.linspace(1e-3, 5e-3, 5)
    reference, _ = tip_history(model, 1e-10, samples)
    tight, _ = tip_history(model, 1e-7, samples)  # stopped at t = 0 before
    assert np.max(np.abs(tight - reference)) <= 3e-5 * np.max(np.abs(reference))
    _, statistics = tip_history(model, 1e-6, samples)
    assert statistics["rejected_steps"] <= 5, statistics
