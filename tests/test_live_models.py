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
