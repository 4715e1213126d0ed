"""The engine's failure statuses: each comes back from compiled code as its code, and every
caller that turns one into an error words it the same way.

Compiled code never raises; it returns a status (`core/engine/data.py`), and each caller
words it through `status.status_message`. On a truss pendulum (its elongation held zero,
the mass's y the DOF): each status where it arises (unconnected, singular where it hangs
straight down, beyond its reach, a non-finite state or result, no mass), the Simulator's
errors with the time and the message, the table against the codes the engine defines, and
the inverse dynamics' and stress resultants' error paths.
"""

import numpy as np
import pytest

from flexure.core import SimulationError, Simulator, build_model
from flexure.core.analysis.inverse_engine import engine_motion
from flexure.core.analysis.stress_engine import engine_stresses
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.engine.status import STATUS_MESSAGES, status_message
from flexure.core.errors import ConvergenceError


def truss_pendulum(length=0.5, mass=1.0):
    """A truss with its elongation prescribed zero and the mass's y as the DOF: singular where
    it hangs vertically (y = -length)."""
    node = {"position": [length, 0.0], "dof": ["y"]}
    if mass:
        node["mass"] = mass
    return build_model({
        "scene": {"name": "truss_pendulum", "gravity": [0.0, -9.81]},
        "sections": {"rod": {"EA": 1.0}},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]}, "2": node},
        "elements": {"rod": {"type": "PLTRUSS", "nodes": ["1", "2"], "section": "rod"}},
        "outputs": {"y": {"node": "2", "coordinate": "y"}},
    })


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


def test_statuses_and_their_messages():
    """Each failure comes back as its status code (nothing raises in compiled code), and
    Simulator turns it into a SimulationError with the time and the documented message."""
    model = truss_pendulum()
    data = EngineData(model)
    # the forms run the evaluation through the table of the operations' addresses, which
    # `connect` gives (and `call` with it): without it the entry answers with a status
    # instead of jumping to 0
    y, ydot = np.zeros(2), np.empty(2)
    rhs = engine.ENTRIES[engine.OP_RHS]
    assert rhs.ctypes(engine.OP_RHS, data.address, 0.0, y.ctypes.data, ydot.ctypes.data, None,
                      0.0) == ed.NOT_CONNECTED

    def kinematics(y):
        data.int_array("dims")[ed.WARM] = 0  # full Newton from the scene's coordinates
        return engine.call(data, engine.OP_KINEMATICS, np.array([y]))

    assert kinematics(-0.3) == ed.OK
    assert kinematics(-0.5 * (1 - 1e-13)) == ed.SINGULAR_CONSTRAINTS  # x = 3.5e-7 m
    assert kinematics(-0.6) == ed.NOT_CONVERGED  # beyond its reach
    # the first-order form checks the state first, then its result
    ydot = np.empty(2)
    assert engine.call(data, engine.OP_RHS, np.array([np.inf, 0.0]), ydot) == ed.NONFINITE_STATE
    nonfinite = truss_pendulum()
    nonfinite.loads[nonfinite.dof_coordinates[0]] = np.inf
    assert engine.call(EngineData(nonfinite), engine.OP_RHS, np.zeros(2), ydot) == \
        ed.NONFINITE_RESULT
    massless = EngineData(truss_pendulum(mass=0.0))
    assert engine.call(massless, engine.OP_RHS, np.zeros(2), ydot) == ed.SINGULAR_MASS

    sim = Simulator(model)  # q_ref = 0 (y = 0: the truss horizontal)
    checks = [([-0.5 * (1 - 1e-13), 0.0], ed.SINGULAR_CONSTRAINTS),
              ([0.0, np.nan], ed.NONFINITE_STATE)]
    for y, status in checks:
        with pytest.raises(SimulationError) as error:
            sim.derivative(0.25, np.array(y))
        assert str(error.value) == f"t = 0.25 s: {STATUS_MESSAGES[status]}"
    with pytest.raises(SimulationError, match="singular configuration"):
        sim.jacobian_matrix(0.0, np.array([-0.5 * (1 - 1e-13), 0.0]))
    with pytest.raises(SimulationError, match="initial DOFs q0 cannot be assembled: a singular"):
        sim.reset(q0=[-0.5 * (1 - 1e-13)])
    with pytest.raises(SimulationError, match=r"M_bar is singular"):
        Simulator(truss_pendulum(mass=0.0)).derivative(0.0, np.zeros(2))
    assert np.all(np.isfinite(sim.derivative(0.0, np.array([-0.3, 0.1]))))  # still usable
