"""SUNDIALS' memory is freed when a run ends, not when the collector finds it: a solver whose
inputs come from functions is in a reference cycle (its callbacks' closures refer to it), as
is a simulator, so that the solver's finalizer ran whenever the collector did, in whatever
code was running then. The collector is off in these tests: what is freed is freed by the
run."""

import gc

import pytest

from flexure.core import Simulator, load_scene, simulate
from flexure.core.simulation.sundials import Cvode, Ida

SOLVERS = (Cvode, Ida)


def solvers():
    """The SUNDIALS solvers alive, garbage not yet collected included."""
    return [o for o in gc.get_objects() if issubclass(type(o), SOLVERS)]


@pytest.fixture
def no_collector():
    gc.collect()
    gc.disable()
    yield
    gc.enable()


@pytest.mark.parametrize("method", ["cvode-bdf", "cvode-adams", "ida"])
def test_a_run_with_an_input_function_frees_its_solver_as_it_ends(method, no_collector):
    before = {id(o) for o in solvers()}
    result = simulate(load_scene("stage_planar_1dof"), 2e-3, inputs={"F": lambda t: 1.0},
                      method=method, rtol=1e-6)
    assert result.statistics["steps"] > 0
    made = [o for o in solvers() if id(o) not in before]
    assert len(made) == 1 and made[0].memory is None  # freed, though the object may live on


def test_a_simulator_closes_its_solver_at_the_end_of_a_with_block(no_collector):
    with Simulator(load_scene("stage_planar_1dof"), method="cvode-bdf",
                   input_functions={0: lambda t: 1.0}) as sim:  # F (N)
        sim.advance_to(1e-3)
        solver = sim.integrator
        assert solver.memory is not None
    assert solver.memory is None
    sim.close()  # again: nothing to do
    assert solver.memory is None
