"""The checked reading of a scene's values: every problem a SceneError naming the file, the
key and what is wrong (`SceneReader`, the base of the scene builder)."""

import contextlib
import math

from ..errors import SceneError

# Every number of a scene is in SI units; none of a compliant mechanism comes near 1e20 (steel's
# E is 2.1e11 Pa). The bound keeps products of scene numbers (E w h^3, masses times lengths
# squared, ...) finite, so an absurd value is refused here instead of as inf or NaN later.
MAX_MAGNITUDE = 1e20
# An initial angle or rotation vector beyond this (rad, about 160 turns) is a mistake: its
# sine and cosine would carry no significant digits.
MAX_ANGLE = 1e3


class SceneReader:
    """Reads values from a scene dictionary for the builder, each checked: `source` names the
    file in every message."""

    source = "<dict>"
    problems = ()  # the mistakes collected (`entry`); a list while a scene is built
    overridden = frozenset()  # the keys set by overrides (`flexure.core.scene.overrides`)

    def fail(self, key, message):
        # a mistake in an override is named as the user gave it (`--set KEY`), not as a key
        # of the file, which may not even have it
        if any(key == k or key.startswith((f"{k}.", f"{k}[")) for k in self.overridden):
            key = f"--set {key}"
        raise SceneError(f"{self.source}: {key}: {message}")

    @contextlib.contextmanager
    def entry(self):
        """Check one entry of a table (a node, a section, an element, a port): its mistake is
        collected in `problems` and the table's other entries are checked as well, so that a
        user sees every mistake of a table at once (`raise_problems`), as FMPy's validation
        lists them."""
        try:
            yield
        except SceneError as error:
            self.problems.append(str(error))

    def raise_problems(self):
        """One SceneError for the mistakes collected: a single one as it is, several one per
        line. A table's mistakes are reported before the next table is read, whose entries
        might only repeat them (an element on a node that was refused)."""
        problems, self.problems = list(self.problems), []
        if len(problems) == 1:
            raise SceneError(problems[0])
        if problems:
            prefix = f"{self.source}: "
            raise SceneError(f"{self.source}: {len(problems)} mistakes:\n" + "\n".join(
                f"  {p.removeprefix(prefix)}" for p in problems))

    def table(self, key, value):
        if not isinstance(value, dict):
            self.fail(key, f"expected a table, got {type(value).__name__}")
        return value

    def number(self, key, value, *, minimum=None, positive=False, limit=MAX_MAGNITUDE):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f"expected a number, got {show(value)}")
        if isinstance(value, float) and not math.isfinite(value):
            self.fail(key, f"expected a finite number, got {value!r}")
        if abs(value) > limit:
            unit = "rad" if limit == MAX_ANGLE else "(SI units)"
            self.fail(key, f"expected a magnitude <= {limit:g} {unit}, got {show(value)}")
        if positive and value <= 0:
            self.fail(key, f"expected a value > 0, got {value!r}")
        if minimum is not None and value < minimum:
            self.fail(key, f"expected a value >= {minimum}, got {value!r}")
        return float(value)

    def vector(self, key, value, length, *, limit=MAX_MAGNITUDE):
        if not isinstance(value, list) or len(value) != length:
            self.fail(key, f"expected a list of {length} numbers, got {show(value)}")
        return [self.number(f"{key}[{i}]", v, limit=limit) for i, v in enumerate(value)]

    def string(self, key, value, what="a string"):
        if not isinstance(value, str):
            self.fail(key, f"expected {what}, got {show(value)}")
        return value

    def names(self, key, value, allowed):
        if isinstance(value, str):
            value = [value]
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            self.fail(key, f"expected a list of names, got {show(value)}")
        for v in value:
            if v not in allowed:
                self.fail(key, f"unknown name {v!r}; expected one of {', '.join(allowed)}")
        for v in set(value):
            if value.count(v) > 1:
                self.fail(key, f"{v!r} is listed {value.count(v)} times; list each name once")
        return list(value)

    def check_unique(self, what, names):
        """Refuse a name that appears twice (say, a node "a.x" beside node "a")."""
        seen = set()
        for name in names:
            if name in seen:
                self.fail(f"{what} {name!r}", f"two {what}s of the scene have this name; rename "
                                              "one of the nodes or elements")
            seen.add(name)

    def check_keys(self, key, table, allowed):
        for k in table:
            if k not in allowed:
                self.fail(f"{key}.{k}",
                          f"unknown key; expected one of {', '.join(sorted(allowed))}")


def show(value, width=60):
    """repr(value), shortened to about `width` characters for a one-line message."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**30:
        return f"an integer of {int(value.bit_length() * 0.30103) + 1} digits"
    text = repr(value)
    return text if len(text) <= width else text[:width - 4] + " ..."
