"""Scene FMUs answer every failure with fmi2Discard (or a warning) and a logged message
instead of taking the host down: non-finite inputs, a wrong communication point or step, a
bad method or step budget, a state beyond the range of validity, an integrator failure."""

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy_slave import Slave


def test_non_finite_input_is_discarded_at_the_last_good_time(scene_fmus):
    slave = Slave(scene_fmus("stage_planar_1dof"))
    slave.set(1.0)
    for k in range(3):
        good = slave.step(k * 1e-3, 1e-3)
    for bad in (np.nan, np.inf):
        slave.set(bad)
        for _ in range(2):  # refused again while the host leaves the input as it is
            with pytest.raises(FMICallException, match="discard"):
                slave.step(3e-3, 1e-3)
            assert np.array_equal(slave.y(), good)
    assert "not finite" in slave.logs[-1][1] and slave.logs[-1][0] == 3  # fmi2Error
    assert "last good time t = 0.003" in slave.logs[-1][1]
    slave.set(1.0)  # the instance goes on from its last good time
    slave.step(3e-3, 1e-3)
    slave.close()


def test_wrong_communication_point_and_step_are_discarded(scene_fmus):
    slave = Slave(scene_fmus("truss_1dof_x"))
    with pytest.raises(FMICallException, match="discard"):
        slave.step(0.5, 1e-3)
    assert "expected the communication point t = 0.0 s, got 0.5 s" in slave.logs[-1][1]
    with pytest.raises(FMICallException, match="discard"):
        slave.step(0.0, -1e-3)
    assert "expected a step size h > 0" in slave.logs[-1][1]
    slave.step(0.0, 1e-3)
    slave.close()


def test_bad_method_parameter_is_reported_not_fatal(scene_fmus):
    slave = Slave(scene_fmus("truss_1dof_x"), strings={"integrator.method": "euler%s"})
    with pytest.raises(FMICallException, match="discard"):
        slave.step(0.0, 1e-3)
    text = " ".join(m for _, m in slave.logs)
    assert "euler%s" in text and "cannot go on" in text
    slave.fmu.reset()  # a reset with a valid method recovers the instance
    slave.initialize()
    slave.step(0.0, 1e-3)
    slave.close()


@pytest.mark.parametrize("method", ["cvode-bdf", "esdirk"])
def test_a_do_step_beyond_its_step_budget_is_discarded(scene_fmus, method):
    """integrator.max_steps: a doStep that would need more integrator steps answers
    fmi2Discard naming the budget, in the integrator's own count (no step-by-step return to
    Python); the instance then goes on."""
    slave = Slave(scene_fmus("stage_planar_3dof"), strings={"integrator.method": method},
                  integers={"integrator.max_steps": 30})
    slave.set(1.0)
    slave.step(0.0, 1e-4)  # a short step, within the budget
    with pytest.raises(FMICallException, match="discard"):
        slave.step(1e-4, 0.5)  # thousands of steps
    status, message = slave.logs[-1]
    assert "the step budget of 30 integrator steps is spent" in message
    slave.close()


def test_a_state_beyond_the_range_of_validity_is_a_warning_in_the_log(scene_fmus):
    """1e9 N on stage_planar_3dof: the doStep answers OK (the equations stay defined) and the
    log carries fmi2Warning, once per kind of limit, naming the limit; 1 N stays silent."""
    slave = Slave(scene_fmus("stage_planar_3dof"))
    slave.set(1.0)
    slave.step(0.0, 1e-3)
    assert not any(status == 1 for status, _ in slave.logs)
    slave.set(1e9)
    for k in range(1, 4):
        slave.step(k * 1e-3, 1e-3)
    warnings = [message for status, message in slave.logs if status == 1]
    assert len(warnings) == 2
    assert any("axial strain" in m and "range of validity" in m for m in warnings)
    assert any("moved" in m and "0.25 x its size" in m for m in warnings)
    slave.close()


def test_a_step_budget_out_of_range_is_refused(scene_fmus):
    slave = Slave(scene_fmus("truss_1dof_x"), integers={"integrator.max_steps": 0})
    with pytest.raises(FMICallException):
        slave.step(0.0, 1e-3)
    assert any("integrator.max_steps = 0: expected an integer from 1 to 1e9" in message
               for _, message in slave.logs)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # the overflow on the way to failure
def test_integrator_failure_is_discarded(scene_fmus):
    """A force of 1e300 N: the integrator fails in the first step (error tests). The
    step is discarded with the cause at the last good time, never Fatal; the instance goes
    on when the force is sane again. (A Newton failure of the kinematics takes the same
    path, but needs ~20 s of integration to provoke.)"""
    slave = Slave(scene_fmus("stage_planar_1dof"))
    slave.set(1.0)
    good = slave.step(0.0, 1e-3)
    slave.set(1e300)
    with pytest.raises(FMICallException, match="discard"):
        slave.step(1e-3, 1e-3)
    status, message = slave.logs[-1]
    assert status == 3 and "discarded" in message
    assert "simulation of 'stage_planar_1dof' stopped at t = 0.001 s" in message  # the cause
    assert "last good time t = 0.001 s" in message
    assert np.array_equal(slave.y(), good)
    slave.set(1.0)
    slave.step(1e-3, 1e-3)
    slave.close()
