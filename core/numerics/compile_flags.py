"""numba's compile flags hashed and compared at the cost of one dict comparison.

numba's typing looks up every call of an overloaded function (a numpy function, `carray`,
`min`, a flexure intrinsic) in a cache whose key holds the compile flags in force
(`templates._OverloadFunctionTemplate._get_impl`): each lookup hashes the flags, and each hit
compares them with the cached key's. `TargetConfig.__hash__` and `__eq__` build the dict of
all 22 options through their properties every time (`values()`), about 10 us a hash and 16 us
a comparison; the first `flexure loop` on an empty cache makes some 35 000 hashes and 45 000
comparisons, about 1 s of its CPU.

`install` gives numba's configuration classes the same hash and comparison, computed from
what they are computed from:

- the hash is `hash(tuple(sorted(self.values())))`, and sorting a dict sorts its keys: the
  sorted option names, the same for every instance of a class (computed once per class);
- `values()` maps every option to its value set on the instance, else its default: the
  class's defaults updated with the instance's set values (`_values`) is the same dict, made
  by one dict merge; the comparison compares those.

Each class is checked first (`_fast_class`): its options' properties must be numba's own
generated getters (`self._values.get(name, default)`) and `values` numba's; an instance whose
set values name something that is not an option of its class (a copy from another class's
configuration) is compared as numba compares it. Anything else is hashed and compared by
numba's own methods: the results are numba's in every case, only their cost changes. Where
numba's module lacks what this relies on, nothing is changed (`install` returns False).
"""

import functools

# by configuration class: (defaults, hash) when the fast form is exactly numba's, else None
_CLASSES = {}
# numba's generated option getter (targetconfig._MetaTargetConfig.__init__'s make_prop)
_GETTER = "_MetaTargetConfig.__init__.<locals>.make_prop.<locals>.getter"


def _fast_class(cls, values):
    """(defaults, hash) of configuration class `cls` when its options are plain properties
    of numba's making and its `values` is numba's (`values`), else None."""
    if cls in _CLASSES:
        return _CLASSES[cls]
    known = None
    options = getattr(cls, "options", None)
    if options is not None and getattr(cls, "values", None) is values:
        getters = [getattr(getattr(cls, name, None), "fget", None) for name in options]
        if all(getattr(g, "__qualname__", "") == _GETTER for g in getters):
            known = ({name: option.default for name, option in options.items()},
                     hash(tuple(sorted(options))))
    _CLASSES[cls] = known
    return known


def _values(config, values):
    """numba's `config.values()` as one dict merge, or None when that would not be it."""
    known = _fast_class(type(config), values)
    if known is None or not config._values.keys() <= known[0].keys():
        return None
    return {**known[0], **config._values}


@functools.cache
def install():
    """Give numba's `TargetConfig` (its compile flags) the hash and comparison of the module
    docstring, once per process. Returns whether it could."""
    try:
        from numba.core import targetconfig
    except ImportError:
        return False
    base = getattr(targetconfig, "TargetConfig", None)
    if base is None or not all(hasattr(base, name) for name in ("values", "__hash__",
                                                                "__eq__")):
        return False
    values, numba_hash, numba_eq = base.values, base.__hash__, base.__eq__

    def __hash__(self):
        known = _fast_class(type(self), values)
        return numba_hash(self) if known is None else known[1]

    def __eq__(self, other):
        if self is other:
            return True
        if not isinstance(other, base):
            return NotImplemented
        mine, theirs = _values(self, values), _values(other, values)
        if mine is None or theirs is None:
            return numba_eq(self, other)
        return mine == theirs

    base.__hash__, base.__eq__ = __hash__, __eq__
    base._flexure_numba_hash_eq = (numba_hash, numba_eq)  # numba's own, for the tests
    return True
