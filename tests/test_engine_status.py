"""The engine's failure statuses in words: one wording for every caller that reports one.

Compiled code never raises; it returns a status (`core/engine/data.py`), and each caller that
turns a failure into an error words it through `status.status_message`. These tests check the
table against the codes the engine defines and the analyses' error paths that report one:
a state beyond the truss pendulum's reach (|y| > the rod's length, which the prescribed zero
elongation cannot reach).
"""

import numpy as np
import pytest

from flexure.core.analysis.inverse_engine import engine_motion
from flexure.core.analysis.stress_engine import engine_stresses
from flexure.core.engine import data as ed
from flexure.core.engine.status import STATUS_MESSAGES, status_message
from flexure.core.errors import ConvergenceError
from tests.test_engine import truss_pendulum

FAILURES = (ed.NOT_CONVERGED, ed.SINGULAR_CONSTRAINTS, ed.SINGULAR_MASS, ed.NONFINITE_STATE,
            ed.NONFINITE_RESULT, ed.NOT_CONNECTED)


def test_every_failure_the_engine_defines_has_its_own_words():
    """The failures are the codes besides OK and NOT_AVAILABLE (an operation telling its
    caller to take another way); each has a message, and no two share one."""
    codes = (ed.OK, ed.NOT_AVAILABLE) + FAILURES
    assert sorted(codes) == list(range(8))
    assert set(STATUS_MESSAGES) == set(FAILURES)
    assert len(set(STATUS_MESSAGES.values())) == len(FAILURES)
    for code in FAILURES:
        assert status_message(np.int64(code)) == STATUS_MESSAGES[code]


@pytest.mark.parametrize("code", [ed.OK, ed.NOT_AVAILABLE, 99])
def test_a_status_that_is_no_failure_is_named_by_its_number_as_a_defect(code):
    message = status_message(code)
    assert message.startswith(f"engine status {code} (") and "defect in flexure" in message


def test_the_inverse_dynamics_kinematics_report_the_engines_words():
    """A configuration beyond reach is a ConvergenceError naming the model, q and the
    engine's cause; the next one is solved from the last good start."""
    motion = engine_motion(truss_pendulum())
    start = motion.solve(np.array([0.1]), None)
    with pytest.raises(ConvergenceError) as error:
        motion.solve(np.array([0.7]), start)  # beyond the rod's 0.5 m
    assert str(error.value) == ("kinematics of 'truss_pendulum' at q = [0.7]: "
                                f"{STATUS_MESSAGES[ed.NOT_CONVERGED]}")
    x = motion.solve(np.array([-0.3]), start).x
    np.testing.assert_allclose(x[2:], [0.4, -0.3], rtol=0, atol=1e-14)


def test_the_stress_resultants_report_the_engines_words():
    """An FMU's stress outputs and `stresses_along` go through this: a state beyond reach is
    a ConvergenceError naming the model, the state and the cause, and the next state is
    evaluated as if nothing had happened."""
    stresses = engine_stresses(truss_pendulum())
    with pytest.raises(ConvergenceError) as error:
        stresses.stress_resultants(np.array([0.7, 0.0]), None)
    assert str(error.value) == ("the stress resultants of 'truss_pendulum' at q = [0.7]: "
                                f"{STATUS_MESSAGES[ed.NOT_CONVERGED]}")
    stresses.restart()
    x, sigma = stresses.stress_resultants(np.array([-0.3, 0.0]), None)
    np.testing.assert_allclose(x[2:], [0.4, -0.3], rtol=0, atol=1e-14)
    assert np.all(np.isfinite(sigma))
