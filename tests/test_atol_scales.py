"""The default atol's model scales, kept per live model (`tolerances.model_scales`): the same
numbers as a fresh evaluation, and a Simulator's integration independent of whether they were
kept before (they are evaluated on a packing of their own, never on the Simulator's)."""

import numpy as np
import pytest

from flexure.core import Simulator, default_atol, load_scene
from flexure.core.simulation import tolerances


@pytest.mark.parametrize("scene", ["stage_planar_3dof", "manipulator_control"])
def test_kept_scales_give_the_atol_of_a_fresh_evaluation(scene, monkeypatch):
    model = load_scene(scene)
    first = default_atol(model, 1e-6)
    evaluations = []
    real = tolerances.initial_matrices
    monkeypatch.setattr(tolerances, "initial_matrices",
                        lambda *args: evaluations.append(1) or real(*args))
    for rtol in (1e-6, 3e-5):  # the kept scales at another rtol too: atol is rtol times them
        kept = default_atol(model, rtol)
        fresh = default_atol(load_scene(scene), rtol)  # a new model: evaluated again
        np.testing.assert_array_equal(kept, fresh)  # tolerance 0: the same expressions
    np.testing.assert_array_equal(first, default_atol(model, 1e-6))
    assert len(evaluations) == 2  # the two new models', none for the kept one


def test_a_simulator_integrates_the_same_bits_whether_the_scales_were_kept_or_not():
    """On the sparse path the engine refines with the factors its last evaluation kept:
    evaluated on the Simulator's own packing, the atol's start evaluation would leave them
    there for a first Simulator and not for a second, whose state after a step then differs
    in round-off (3e-13 m on manipulator_control after 0.01 s when it was so)."""
    model = load_scene("manipulator_control")
    states = []
    for _ in range(2):  # the first evaluates the scales, the second finds them kept
        sim = Simulator(model, method="esdirk", rtol=1e-6)
        sim.set_inputs(0.1 * np.ones(len(model.inputs)))
        sim.advance_to(0.002)
        states.append(sim.state)
    np.testing.assert_array_equal(states[0], states[1])
