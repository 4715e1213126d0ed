"""Plain-text tables for the command line, and JSON-safe conversion of arrays."""

import json
import math
import sys

import numpy as np


def format_table(headers, rows, *, title=None):
    """A column-aligned text table; numbers are formatted with 6 significant digits."""
    cells = [[_cell(v) for v in row] for row in rows]
    widths = [max(len(h), *(len(r[i]) for r in cells)) if cells else len(h)
              for i, h in enumerate(headers)]
    lines = [title] if title else []
    lines.append("  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True)))
    lines.append("  ".join("-" * w for w in widths))
    lines.extend("  ".join(c.rjust(w) if _numeric(c) else c.ljust(w)
                           for c, w in zip(row, widths, strict=True)) for row in cells)
    return "\n".join(lines)


def markdown_table(headers, rows):
    """A GitHub-flavoured markdown table."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines.extend("| " + " | ".join(_cell(v) for v in row) + " |" for row in rows)
    return "\n".join(lines)


def jsonable(value):
    """Arrays and numpy scalars as plain lists and floats, recursively."""
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        # numbers: tolist() gives Python floats and ints already, nested lists of them (the
        # recursion over an 816-DOF model's three matrices took 2 s of `flexure analyze`)
        return value.tolist() if value.dtype.kind in "biuf" else jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def json_text(value, *, indent=1):
    """(text, replaced): `value` as strict JSON, and where it held NaN or +-Infinity.

    JSON has no NaN or Infinity (json.dumps would write the invalid tokens NaN and Infinity):
    each non-finite number is written as null, and `replaced` lists its place ("modes.
    frequencies_hz[2] = inf") so that the caller can say so.
    """
    value = jsonable(value)
    try:
        return json.dumps(value, indent=indent, allow_nan=False), []
    except ValueError:
        pass
    replaced = []

    def clean(item, where):
        if isinstance(item, dict):
            return {k: clean(v, f"{where}.{k}" if where else str(k)) for k, v in item.items()}
        if isinstance(item, list):
            return [clean(v, f"{where}[{i}]") for i, v in enumerate(item)]
        if isinstance(item, float) and not math.isfinite(item):
            replaced.append(f"{where} = {item}")
            return None
        return item

    return json.dumps(clean(value, ""), indent=indent, allow_nan=False), replaced


def print_json(value, *, command, indent=1):
    """Print `value` as strict JSON; a note on stderr names each non-finite number (null)."""
    text, replaced = json_text(value, indent=indent)
    print(text)
    if replaced:
        shown = ", ".join(replaced[:5]) + (f" and {len(replaced) - 5} more"
                                           if len(replaced) > 5 else "")
        print(f"{command}: note: {len(replaced)} non-finite number(s) written as null (JSON has "
              f"no NaN or Infinity): {shown}", file=sys.stderr)


def _cell(value):
    if isinstance(value, (float, np.floating)):
        return f"{value:.6g}"
    return str(value)


def _numeric(text):
    try:
        float(text)
    except ValueError:
        return False
    return True
