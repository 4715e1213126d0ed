"""Parameter overrides: dotted scene keys set on a scene dictionary before it is built.

    load_scene("stage_planar_1dof", overrides={"sections.leaf.height": 0.3e-3,
                                               "nodes.3.mass": 0.2})
    flexure analyze stage_planar_1dof --set sections.leaf.height=0.3e-3 --set nodes.3.mass=0.2

An override names one value of the scene: `scene.KEY` or `buckling.KEY`, or `TABLE.NAME.KEY` in
a table of named entries (sections, nodes, elements, inputs, actuators, outputs). NAME must be
one the scene declares: an override changes a scene, it adds no node, section or element to it.
KEY may be one the file leaves out where the scene format allows it (`nodes.3.mass` on a node
the file gives no mass): the scene builder then checks every key and value exactly as it checks
the file's own, and its message names the override as `--set KEY` (`SceneReader.fail`). A list
(a position, `fixed`, the buckling forces) is set as a whole.

On the command line VALUE is read as a TOML value (`0.3e-3`, `[0, 1]`, `"text"`, `true`); text
that is not one is taken as a string (`--set elements.bar.type=PLTRUSS`).
"""

import copy
import datetime
import tomllib
from collections.abc import Mapping

import numpy as np

from ..errors import SceneError

__all__ = ["apply_overrides", "declared_value", "describe_overrides", "parse_assignment",
           "parse_value"]

# the tables whose entries are named ([nodes.3], [sections.leaf]), and the singular for messages
NAMED_TABLES = {"sections": "section", "nodes": "node", "elements": "element", "inputs": "input",
                "actuators": "actuator", "outputs": "output"}
PLAIN_TABLES = ("scene", "buckling")
EXAMPLE = "e.g. sections.leaf.height or nodes.3.mass"


def apply_overrides(data: dict, overrides: Mapping[str, object] | None, *,
                    source: str = "<dict>") -> dict:
    """A copy of scene dictionary `data` with each dotted key of `overrides` set to its value.

    Checks where each key points (a table of the scene format, a name the scene declares) and
    that each value is one a TOML file could hold; the key itself and the value's type, range
    and unit (SI) are checked by the scene builder (`build_model(data, overrides=...)`).

    Parameters
    ----------
    data : dict
        The scene dictionary; it is not changed.
    overrides : mapping of str to value, optional
        {dotted scene key: value}, e.g. {"sections.leaf.height": 0.3e-3} (SI units).
    source : str
        How messages name the scene (a file path).

    Returns
    -------
    dict
        The changed copy.

    Raises
    ------
    SceneError
        "`source`: --set KEY: what is wrong": `overrides` is not a mapping, a key points
        nowhere in the scene format or the scene, or a value no TOML file could hold.
    """
    result = copy.deepcopy(data)
    if not isinstance(overrides or {}, Mapping):
        raise SceneError(f"{source}: overrides: expected a mapping {{dotted scene key: value}}, "
                         f"got a {type(overrides).__name__}")
    for key, value in dict(overrides or {}).items():
        table, name = _target(result, key, source)
        table[name] = _toml_value(key, value, source)
    return result


def declared_value(data: dict, key: str, *, source: str = "<dict>",
                   option: str = "--set") -> object:
    """The value scene dictionary `data` gives for dotted key `key` (as the file holds it).

    The key is checked as `apply_overrides` checks it (a table of the scene format, a name
    the scene declares), and the scene must give the value itself: a key left to its default
    has no value to read.

    Parameters
    ----------
    data : dict
        The scene dictionary; it is not changed.
    key : str
        A dotted scene key, e.g. "sections.leaf.height".
    source : str
        How messages name the scene (a file path).
    option : str
        How messages name the option that gave the key ("--set", "--sensitivity").

    Returns
    -------
    object
        The value: a number, a string, a boolean or a list (SI units).

    Raises
    ------
    SceneError
        "`source`: `option` KEY: what is wrong": the key points nowhere in the scene format
        or the scene, or the scene gives no value for it.
    """
    table, name = _target(copy.deepcopy(data), key, source, option)
    if name not in table:
        raise SceneError(f"{source}: {option} {key}: the scene gives no value for it (its "
                         f"entry has {', '.join(table) or 'no keys'})")
    return table[name]


def _target(data, key, source, option="--set"):
    """(the table that holds `key`, the name of the value in it); the table is made if the
    scene has none of it yet ([buckling], [scene])."""
    def fail(message):
        raise SceneError(f"{source}: {option} {key}: {message}")

    if not isinstance(data, dict):
        raise SceneError(f"{source}: scene file: expected a table, got {type(data).__name__}")
    parts = key.split(".") if isinstance(key, str) else [""]
    if not all(parts):
        fail(f"expected a dotted scene key ({EXAMPLE})")
    top = parts[0]
    if top in PLAIN_TABLES:
        if len(parts) != 2:
            fail(f"expected {top}.KEY ({top} has no named entries)")
        table = data.setdefault(top, {})
        if not isinstance(table, dict):
            fail(f"the scene's {top} is not a table")
        return table, parts[1]
    if top not in NAMED_TABLES:
        fail(f"unknown table {top!r}; expected one of "
             f"{', '.join([*PLAIN_TABLES, *NAMED_TABLES])}")
    if len(parts) < 3:
        fail(f"expected {top}.NAME.KEY ({EXAMPLE}); an entry is changed key by key")
    name = ".".join(parts[1:-1])  # a node's name may hold dots ("a.b"); the key does not
    entries = data.get(top, {})
    if not isinstance(entries, dict) or not isinstance(entries.get(name), dict):
        known = ", ".join(entries) if isinstance(entries, dict) and entries else "none"
        fail(f"unknown {NAMED_TABLES[top]} {name!r}; the scene's {top}: {known}")
    return entries[name], parts[-1]


def _toml_value(key, value, source):
    """`value` as the scene dictionary holds it (what tomllib gives): numpy numbers and arrays
    and tuples become Python numbers and lists; a date or an object is refused."""
    if isinstance(value, np.ndarray | np.generic):
        value = value.tolist()
    if isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, list | tuple):
        return [_toml_value(key, v, source) for v in value]
    if isinstance(value, dict):
        return {str(k): _toml_value(key, v, source) for k, v in value.items()}
    if isinstance(value, datetime.date | datetime.time):
        raise SceneError(f"{source}: --set {key}: a date or time has no place in a scene "
                         f"(got {value}); quote it to give a string")
    raise SceneError(f"{source}: --set {key}: expected a number, string, boolean or a list of "
                     f"them, got a {type(value).__name__}")


def parse_value(text: str):
    """The value of `--set KEY=VALUE`: VALUE read as a TOML value, or the text itself if it is
    not one (so `0.3e-3` is a float, `[0, 1]` a list, `PLTRUSS` and `"PLTRUSS"` strings);
    ValueError for a value nested beyond Python's recursion limit."""
    try:
        parsed = tomllib.loads(f"value = {text}")
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:  # tomllib recurses once per level of nesting
        raise ValueError(f"a value nested deeper than Python's recursion limit, "
                         f"{text[:20]}...: no scene key takes one") from None
    # text such as "1\nx = 2" parses as two keys: it is not one value
    return parsed["value"] if parsed.keys() == {"value"} else text


def parse_assignment(text: str) -> tuple[str, object]:
    """(KEY, value) of "KEY=VALUE" (`parse_value`); ValueError saying what is expected."""
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValueError(f"expected KEY=VALUE with a dotted scene key ({EXAMPLE}), got "
                         f"{text!r}")
    return key, parse_value(value.strip())


def describe_overrides(overrides) -> str:
    """The overrides as command-line options, "--set KEY=VALUE ..." (for headers and logs)."""
    from .scene_writer import toml_value

    return " ".join(f"--set {key}={toml_value(value)}" for key, value in overrides.items())
