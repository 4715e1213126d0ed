"""`PerLiveModel`: one value per live model (and variant), dropped with the model."""

import gc

from flexure.core.live_models import PerLiveModel


class Model:
    """A stand-in: any object that can be weakly referenced."""


def test_a_value_is_kept_per_model_and_variant_and_dropped_with_the_model():
    store, model, other = PerLiveModel(), Model(), Model()
    assert store.put(model, "packed") == "packed"
    store.put(model, "without clusters", variant=False)
    assert store.get(model) == "packed"
    assert store.get(model, variant=False) == "without clusters"
    assert store.get(other) is None
    del model
    gc.collect()
    assert store._known == {}  # the entries went with their model


def test_a_new_model_at_a_collected_ones_address_finds_nothing():
    store, model = PerLiveModel(), Model()
    store.put(model, "packed")
    reference = store._known[(id(model), None)][0]
    stranger = Model()
    store._known[(id(stranger), None)] = (reference, "packed")  # as if at the same address
    assert store.get(stranger) is None


def test_a_value_kept_for_a_model_is_not_found_after_the_model_changed():
    """A Model is a dataclass whose arrays can be written into: what was kept before a change
    is stale, and a look-up finds nothing (then the caller derives it again)."""
    from flexure.core import load_scene

    store, model = PerLiveModel(), load_scene("stage_planar_3dof")
    store.put(model, "packed")
    assert store.get(model) == "packed"  # unchanged: found
    for change in (lambda m: m.loads.__setitem__(0, 1.0),
                   lambda m: m.gravity.__setitem__(1, -9.81),
                   lambda m: m.groups[0].properties["EA"].__setitem__(0, 2.0),
                   lambda m: m.inputs.pop(),
                   lambda m: setattr(m, "lumped_mass", m.lumped_mass + 1.0)):
        store.put(model, "packed")
        change(model)
        assert store.get(model) is None
