"""What is computed once per live model and kept while the model lives.

A model is meant not to change once built (a parameter study builds a model per parameter
set), so what is derived from it alone (its packed engine, its orderings, its atol scales) is
kept by the model's identity and dropped when the model is collected. `id` alone could name a
new model at a collected one's address: each entry keeps a weak reference, checked on every
look-up. But a `Model` is a plain dataclass whose arrays can be written into (tests write
`model.loads[:]`, `model.gravity[:]`): each entry also keeps a digest of the model's content
(`content_digest`), and a look-up after a change finds nothing, so what is derived is derived
again rather than stale.
"""

from __future__ import annotations

import dataclasses
import hashlib
import weakref
from typing import Any

import numpy as np

# a dataclass field whose metadata holds DERIVED: arrays computed when the model is built (an
# element group's reference geometry, megabytes on the manipulators: 10 ms to digest on
# manipulator_reduced, as much as the packing kept) enter the digest by identity, not content
DERIVED = "derived"


class PerLiveModel:
    """A store of one value per live model (and per `variant`, a hashable, where one model has
    several: a packing with and without its rigid clusters)."""

    def __init__(self):
        self._known: dict[tuple, tuple[weakref.ref, bytes, Any]] = {}

    def get(self, model, variant=None):
        """The value kept for `model` (and `variant`), or None: None too when the model's
        content changed since it was kept."""
        known = self._known.get((id(model), variant))
        if known is None or known[0]() is not model or known[1] != content_digest(model):
            return None
        return known[2]

    def put(self, model, value, variant=None):
        """Keep `value` for `model` (and `variant`) while the model lives, and as long as its
        content stays as it is now; returns `value`."""
        key = (id(model), variant)
        # the callback holds the dict itself: at the interpreter's exit the module's globals
        # may be gone before the models
        self._known[key] = (weakref.ref(model, lambda _, key=key, known=self._known:
                                        known.pop(key, None)), content_digest(model), value)
        return value


def content_digest(model) -> bytes:
    """A digest (16 bytes) of what can change in a built model: the bytes of its arrays (an
    object array's by its items' identities: a change to an equal new object only looks like
    a change), the items of its lists and dicts, the hashes of its immutable values; a
    dataclass by its compared fields (not `Model.scene`, the text it came from), a field
    marked DERIVED by its arrays' identities. An object that is not a dataclass: b""."""
    if not dataclasses.is_dataclass(model):
        return b""
    digest = hashlib.blake2b(digest_size=16)
    _feed(digest, model)
    return digest.digest()


def _feed(digest, value, derived=False):
    if isinstance(value, np.ndarray):
        digest.update(f"a{value.dtype.str}{value.shape}{id(value) if derived else ''}".encode())
        if not derived:
            digest.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, dict):
        digest.update(f"d{len(value)}".encode())
        for key, item in value.items():
            _feed(digest, key, derived)
            _feed(digest, item, derived)
    elif isinstance(value, list):
        digest.update(f"l{len(value)}".encode())
        _feed_items(digest, value, derived)
    elif dataclasses.is_dataclass(value):
        try:  # a frozen dataclass of immutable values: its hash (Node, Port, Actuator)
            digest.update(hash(value).to_bytes(8, "little", signed=True))
        except TypeError:  # not hashable: it holds arrays, lists or dicts (ElementGroup)
            digest.update(type(value).__name__.encode())
            for field in dataclasses.fields(value):
                if field.compare:
                    _feed(digest, getattr(value, field.name),
                          derived or DERIVED in field.metadata)
    elif isinstance(value, tuple):
        _feed_items(digest, value, derived)
    else:  # a number, a string, None, a module (an element group's kind)
        digest.update(repr(value).encode())


def _feed_items(digest, items, derived):
    try:  # all immutable (names, chosen DOFs, nodes): one hash, in C
        digest.update(hash(tuple(items)).to_bytes(8, "little", signed=True))
    except TypeError:
        digest.update(f"t{len(items)}".encode())
        for item in items:
            _feed(digest, item, derived)
