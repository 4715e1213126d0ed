"""Property-based fuzzing: no user input gives a traceback.

The scene loader gets the shipped scenes with one to three mutations (a value replaced by one
of another type or an absurd number, a key deleted, an unknown key added) and TOML texts with
random bytes inserted or flipped; the command line gets random option values. Either the
input is accepted, or the project's own error (FlexureError) or argparse's exit (SystemExit
with a message on stderr) answers it: any other exception is a failure.

The command-line cases replace the long runs (simulation, work-precision study, closed loop,
FMU build and check) by stubs: what is fuzzed is the validation of the options and of the
output paths, which all happens before those runs.
"""

import datetime
import math
import tomllib

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flexure.core import FlexureError, build_model, builtin_scenes, load_scene, scene_path

SCENES = {name: scene_path(name).read_bytes() for name in builtin_scenes()}
DATA = {name: tomllib.loads(text.decode()) for name, text in SCENES.items()}
FAST = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow], database=None)

absurd_floats = st.sampled_from([0.0, -0.0, 1e308, -1e308, 1e-308, 5e-324, math.inf, -math.inf,
                                 math.nan, 1e21, -1e21, 1e20, 1e300, 1e-300, -1.0, 1e3, 1e4])
numbers = st.one_of(st.integers(min_value=-10**30, max_value=10**30),
                    st.just(10**400), absurd_floats,
                    st.floats(allow_nan=True, allow_infinity=True))
scalars = st.one_of(numbers, st.booleans(), st.text(max_size=8),
                    st.sampled_from(["x", "y", "z", "phi", "e1", "e2", "lambda0", "1", "3",
                                     "BEAM", "PLBEAM", "PLTRUSS", "TRUSS", "position",
                                     "velocity", "leaf", "bar", "rotation"]),
                    st.just(datetime.date(2024, 1, 1)), st.just(datetime.time(12, 0)))
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=5), st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=8)


def _paths(data, prefix=()):
    """Every path (tuple of keys and list indices) to a value in `data`, tables included."""
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        yield (*prefix, key)
        if isinstance(value, (dict, list)):
            yield from _paths(value, (*prefix, key))


def _copy(value):
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_copy(v) for v in value]
    return value


@st.composite
def mutated_scenes(draw):
    name = draw(st.sampled_from(sorted(DATA)))
    data = _copy(DATA[name])
    for _ in range(draw(st.integers(1, 3))):
        paths = list(_paths(data))
        kind = draw(st.sampled_from(["replace", "replace", "number", "delete", "add"]))
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = data
        for key in path[:-1]:
            parent = parent[key]
        last = path[-1]
        if kind == "replace":
            parent[last] = draw(values)
        elif kind == "number":
            parent[last] = draw(numbers)
        elif kind == "delete":
            del parent[last]
        else:
            target = parent[last] if isinstance(parent[last], dict) else parent
            if isinstance(target, dict):
                target[draw(st.text(max_size=6))] = draw(values)
            else:
                target.append(draw(values))
    return name, data


def _accepts_or_explains(load):
    try:
        load()
    except FlexureError as error:
        assert str(error), f"{type(error).__name__} without a message"


@settings(FAST, max_examples=700)
@given(mutated_scenes())
def test_mutated_scene_dictionaries(case):
    _, data = case
    _accepts_or_explains(lambda: build_model(data, source="fuzz.toml"))


@st.composite
def mutated_texts(draw):
    text = bytearray(SCENES[draw(st.sampled_from(sorted(SCENES)))])
    for _ in range(draw(st.integers(1, 4))):
        position = draw(st.integers(0, len(text) - 1))
        kind = draw(st.sampled_from(["flip", "insert", "delete", "invalid"]))
        if kind == "flip":
            text[position] = draw(st.integers(0, 255))
        elif kind == "insert":
            text[position:position] = draw(st.binary(min_size=1, max_size=4))
        elif kind == "delete":
            del text[position:position + draw(st.integers(1, 20))]
        else:
            text[position:position] = draw(st.sampled_from([b"\xff", b"\xc3", b"\xed\xa0\x80",
                                                             b"\x00", b"\xe2\x82"]))
    return bytes(text)


@settings(FAST, max_examples=300)
@given(mutated_texts())
def test_mutated_scene_bytes(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("fuzz") / "scene.toml"
    path.write_bytes(text)
    _accepts_or_explains(lambda: load_scene(path))


@pytest.mark.parametrize("name", sorted(SCENES))
def test_the_shipped_scenes_still_load(name):
    load_scene(name)
