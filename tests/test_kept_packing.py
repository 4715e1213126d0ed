"""A model's packing kept while the model lives (`engine.data`): a second EngineData of a
model is the packing of a fresh one, slot for slot and bit for bit, in arrays of its own."""

import numpy as np
import pytest

from flexure.core import load_scene
from flexure.core.engine.data import EngineData


@pytest.mark.parametrize("scene", ["stage_planar_3dof", "wire_tripod", "manipulator_control"])
@pytest.mark.parametrize("rigid", [True, False])
def test_a_kept_packing_is_a_fresh_one_in_arrays_of_its_own(scene, rigid):
    model = load_scene(scene)
    first = EngineData(model, rigid=rigid)
    first.float_array("x")[:] = np.nan  # what a packing's user writes stays in its arrays
    first.int_array("dims")[0] += 1
    kept = EngineData(model, rigid=rigid)
    fresh = EngineData(load_scene(scene), rigid=rigid)  # a new model: packed again
    assert kept.rigid.enabled == fresh.rigid.enabled and kept.costs == fresh.costs
    kept_slots, fresh_slots = kept.slots(), fresh.slots()
    assert kept_slots.keys() == fresh_slots.keys()
    for name, array in kept_slots.items():
        assert array.dtype == fresh_slots[name].dtype, name
        np.testing.assert_array_equal(array, fresh_slots[name], err_msg=name)  # exact
    assert not any(np.shares_memory(a, b) for a in first.ints + first.floats
                   for b in kept.ints + kept.floats if a.size and b.size)


def test_a_model_changed_after_its_first_simulator_is_packed_again():
    """A Model's arrays can be written into (tests do, `model.loads[:] = ...`): a Simulator
    built after the change integrates the changed model, bit for bit as a model built with
    those values, never the packing (or the atol scales) kept before the change. Here 1 N
    sideways and gravity move the stage 0.23 mm in 0.01 s; kept stale, it stayed put."""
    from flexure.core import Simulator

    def state_after(model):
        sim = Simulator(model, method="esdirk", rtol=1e-6)
        sim.advance_to(0.01)
        return sim.state

    def change(model):
        model.gravity[:] = [0.0, -9.81]
        model.loads[model.coordinate_index("3.x")] = 1.0

    changed, fresh = load_scene("stage_planar_3dof"), load_scene("stage_planar_3dof")
    state_after(changed)  # packs it and keeps the packing and the atol scales
    change(changed)
    change(fresh)
    expected = state_after(fresh)
    assert abs(expected[0]) > 1e-4  # it moves (m)
    np.testing.assert_array_equal(state_after(changed), expected)  # tolerance 0


def test_a_packing_choice_changed_between_two_packings_of_one_model_is_taken(monkeypatch):
    """The sparse Newton matrix's threshold and the forms' cost rule are read at packing
    (`data.packing_key`): changed between two packings of one model, the second has the
    changed choice, not the kept packing's."""
    from flexure.core.engine import data as ed
    from flexure.core.engine import newton_packing

    model = load_scene("manipulator_control")  # 75 DOFs: the sparse Newton matrix from 50
    assert EngineData(model).int_array("dims")[ed.NEWTON_SPARSE] == 1
    monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", 10**9)
    assert EngineData(model).int_array("dims")[ed.NEWTON_SPARSE] == 0
    cost = ed.evaluation_cost
    monkeypatch.setattr(ed, "evaluation_cost",
                        lambda *args, **kwargs: {**cost(*args, **kwargs), "reduced": 0.0})
    assert not EngineData(model).int_array("dims")[ed.AUGMENTED]
