"""Scenes back to TOML: `scene_toml(data)` writes a scene dictionary as a scene file.

The scene format uses a small part of TOML: tables of tables ([nodes.3], [elements.leaf]),
strings, integers, floats, booleans, lists of those and lists of inline tables ([buckling]
forces). `scene_toml` writes exactly that part, so that `tomllib.loads(scene_toml(data))`
gives `data` back (floats through repr: the same bits); anything else is a ValueError naming
the key. Comments of the file a scene came from are not kept.
"""

import math

__all__ = ["scene_toml", "toml_value"]


def scene_toml(data: dict, header: str = "") -> str:
    """The TOML text of a scene dictionary; `tomllib.loads` of it gives `data` back.

    Parameters
    ----------
    data : dict
        The scene dictionary (docs/scene-format.md).
    header : str
        Comment lines for the top of the file, without "#".

    Returns
    -------
    str
        The TOML text.

    Raises
    ------
    ValueError
        A value the scene format cannot hold (not finite, or of another type), naming its
        key.
    """
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    _table(lines, [], data)
    return "\n".join(lines).lstrip("\n") + "\n"


def toml_value(value) -> str:
    """The TOML text of one scene value (a number, string, boolean, list or inline table)."""
    return _value(value, [])


def _table(lines, path, table):
    scalars = {k: v for k, v in table.items() if not isinstance(v, dict)}
    tables = {k: v for k, v in table.items() if isinstance(v, dict)}
    if path and (scalars or not tables):
        lines.append("")
        lines.append(f"[{'.'.join(_key(p) for p in path)}]")
    for key, value in scalars.items():
        lines.append(f"{_key(key)} = {_value(value, [*path, key])}")
    for key, value in tables.items():
        _table(lines, [*path, key], value)


def _key(key):
    text = str(key)
    if text and all(c.isalnum() or c in "_-" for c in text):
        return text
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _value(value, path):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{'.'.join(map(str, path))}: {value!r} has no place in a scene")
        return repr(value)
    if isinstance(value, str):
        escaped = value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
        return f'"{escaped}"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v, path) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(v, [*path, k])}"
                                for k, v in value.items()) + " }"
    raise ValueError(f"{'.'.join(map(str, path))}: a {type(value).__name__} cannot be written "
                     "to a scene")
