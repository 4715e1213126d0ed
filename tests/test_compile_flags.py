"""numba's compile flags hashed and compared cheaply (core/numerics/compile_flags.py): the
hash and the comparison are numba's own (kept by `install`) on every kind of configuration,
set or not, copied across classes or not. What they save is measured in docs/benchmarks.md
(session 27, the cold first use), not here: a speed is a benchmark's figure, not a test's."""

import pytest
from numba.core import targetconfig
from numba.core.compiler import Flags

from flexure.core.numerics import compile_flags, jit


class _Other(targetconfig.TargetConfig):
    """A configuration class of a few options, as numba's subclasses declare them."""

    nrt = targetconfig.Option(type=bool, default=False, doc="")
    error_model = targetconfig.Option(type=str, default="python", doc="")


class _OwnGetter(targetconfig.TargetConfig):
    """A configuration class with a property of its own: compared as numba compares it."""

    nrt = targetconfig.Option(type=bool, default=False, doc="")


_OwnGetter.nrt = property(lambda self: True)  # not numba's getter: always set


def _numba(config_class=targetconfig.TargetConfig):
    return config_class._flexure_numba_hash_eq


def _configs():
    """Flags and configurations of other classes, unset, set to their defaults, set apart."""
    plain, default_set, numpy_model, both = Flags(), Flags(), Flags(), Flags()
    default_set.nrt = False  # set, to the default: equal to the unset one
    numpy_model.error_model = "numpy"
    both.error_model, both.nrt = "numpy", True
    copied = Flags(both)
    crossed = Flags(_Other())  # set values of another class's options (none here)
    other = _Other()
    other.nrt = True
    foreign = _Other(both)  # holds values of options _Other does not have
    return [plain, default_set, numpy_model, both, copied, crossed, _Other(), other, foreign,
            _OwnGetter(), _OwnGetter(plain)]


def test_installed_with_this_numba():
    jit.numba_module()
    assert compile_flags.install()
    assert targetconfig.TargetConfig.__eq__.__module__ == compile_flags.__name__


def test_hash_and_comparison_are_numbas():
    jit.numba_module()
    numba_hash, numba_eq = _numba()
    configs = _configs()
    for a in configs:
        assert hash(a) == numba_hash(a)
        for b in configs:
            assert (a == b) == numba_eq(a, b), (a, b)
            assert (a != b) == (not numba_eq(a, b))
    assert configs[0] == configs[1] and configs[3] == configs[4]
    assert configs[0] != configs[2] and configs[2] != configs[3]
    assert (Flags() == 3) is False and Flags() != "flags"


@pytest.mark.parametrize("name", ["nrt", "error_model", "fastmath", "boundscheck"])
def test_each_option_set_counts(name):
    jit.numba_module()
    _, numba_eq = _numba()
    a, b = Flags(), Flags()
    value = getattr(a, name)
    setattr(b, name, value)
    assert (a == b) and numba_eq(a, b)
    setattr(b, name, {bool: not value, str: "numpy"}.get(type(value), value))
    assert (a == b) == numba_eq(a, b)
