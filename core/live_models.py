"""What is computed once per live model and kept while the model lives.

A model is not changed once built (a parameter study builds a model per parameter set), so
what is derived from it alone (its packed engine, its orderings) is kept by the model's
identity and dropped when the model is collected. `id` alone could name a new model at a
collected one's address: each entry keeps a weak reference, checked on every look-up.
"""

from __future__ import annotations

import weakref
from typing import Any


class PerLiveModel:
    """A store of one value per live model (and per `variant`, a hashable, where one model has
    several: a packing with and without its rigid clusters)."""

    def __init__(self):
        self._known: dict[tuple, tuple[weakref.ref, Any]] = {}

    def get(self, model, variant=None):
        """The value kept for `model` (and `variant`), or None."""
        known = self._known.get((id(model), variant))
        return known[1] if known is not None and known[0]() is model else None

    def put(self, model, value, variant=None):
        """Keep `value` for `model` (and `variant`) while the model lives; returns `value`."""
        key = (id(model), variant)
        # the callback holds the dict itself: at the interpreter's exit the module's globals
        # may be gone before the models
        self._known[key] = (weakref.ref(model, lambda _, key=key, known=self._known:
                                        known.pop(key, None)), value)
        return value
