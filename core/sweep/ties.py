"""Tied sweep parameters: a scene key given at every point as a function of swept keys.

    flexure sweep wire_tripod --param elements.wire1.segments=1,2,4 \
        --tie elements.wire2.segments=elements.wire1.segments \
        --tie elements.wire3.segments=elements.wire1.segments
    flexure sweep stage_planar_1dof --param sections.leaf.height=0.3e-3:0.8e-3:6 \
        --tie "sections.leaf.width=36*sections.leaf.height"

`--tie KEY=EXPRESSION`: EXPRESSION is arithmetic over numbers and the keys of `--param`:

    expression := term (("+" | "-") term)*
    term       := factor (("*" | "/") factor)*
    factor     := ("+" | "-") factor | NUMBER | KEY | "(" expression ")"

A KEY is a dotted scene key (letters, digits, "_", ".") that a `--param` sweeps; a bare KEY
ties the value itself (an integer stays an integer: a count of segments). The text is parsed
into a tree and the tree is evaluated on the point's numbers: no Python is executed, so
`__import__('os')` is only an unknown character. Integers stay integers through + - * (a
tied `segments` of 2*elements.bar.segments is a count); / gives a float. A mistake is a
UsageError naming `--tie` and what is wrong.
"""

from __future__ import annotations

import math
import operator
import re

from ..errors import UsageError

__all__ = ["Tie", "parse_tie", "tie_points"]

DIGITS = 15  # a computed float rounded as a swept value is (grid.DIGITS): 36*0.0004 = 0.0144

_TOKEN = re.compile(r"\s*(?:(?P<number>(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?)"
                    r"|(?P<key>[A-Za-z_][\w.]*)|(?P<op>[-+*/()]))")
_OPERATORS = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv}


class Tie:
    """`key` = the expression `text` of the swept keys `uses`; `value(point)` evaluates it."""

    def __init__(self, key: str, text: str, tree, uses: tuple[str, ...]):
        self.key, self.text, self.tree, self.uses = key, text, tree, uses

    def value(self, point: dict):
        """The tied key's value at `point` {swept key: value}; UsageError where the
        expression cannot be evaluated there (a division by zero, a value not a number)."""
        return _evaluate(self.tree, point, self)


def tie_points(points: list[dict], ties: list[Tie]) -> list[dict]:
    """Each grid point {swept key: value} with the tied keys' values added, in `ties`' order;
    a computed float rounded to DIGITS significant digits."""
    tied = []
    for point in points:
        values = {}
        for tie in ties:
            value = tie.value(point)
            if isinstance(value, float) and tie.tree[0] != "key":
                value = float(f"{value:.{DIGITS}g}")
            values[tie.key] = value
        tied.append({**point, **values})
    return tied


def parse_tie(text: str, swept: list[str]) -> Tie:
    """The Tie of "KEY=EXPRESSION" (module docstring) over the `swept` keys; UsageError
    naming --tie and what is wrong."""
    key, sep, expression = text.partition("=")
    key, expression = key.strip(), expression.strip()
    if not sep or not key or not expression:
        raise UsageError(f"--tie {text!r}: expected KEY=EXPRESSION, e.g. "
                         "elements.wire2.segments=elements.wire1.segments")
    if key in swept:
        raise UsageError(f"--tie {key}: also a --param; a key is either swept or tied")
    tokens = _tokens(text, expression)
    parser = _Parser(text, tokens)
    tree = parser.expression()
    if parser.at < len(tokens):
        raise UsageError(f"--tie {text!r}: unexpected {tokens[parser.at][1]!r} after a "
                         "complete expression")
    uses = tuple(dict.fromkeys(_keys(tree)))
    for name in uses:
        if name not in swept:
            raise UsageError(f"--tie {text!r}: {name} is not a --param key; an expression "
                             f"may use {', '.join(swept)}")
    return Tie(key, expression, tree, uses)


def _tokens(text, expression):
    """[(kind, text)] of the expression; UsageError at the first character that is none."""
    tokens, at = [], 0
    while at < len(expression):
        if expression[at:].strip() == "":
            break
        match = _TOKEN.match(expression, at)
        if match is None:
            raise UsageError(f"--tie {text!r}: unexpected {expression[at:].strip()[0]!r}; an "
                             "expression has numbers, --param keys, + - * / and brackets")
        kind = match.lastgroup
        tokens.append((kind, match[kind]))
        at = match.end()
    return tokens


class _Parser:
    """Recursive descent over the grammar of the module docstring, to a tree of tuples:
    ("number", value), ("key", name), ("neg", tree), (op, left, right)."""

    def __init__(self, text, tokens):
        self.text, self.tokens, self.at = text, tokens, 0

    def peek(self):
        return self.tokens[self.at][1] if self.at < len(self.tokens) else None

    def expression(self):
        tree = self.term()
        while self.peek() in ("+", "-"):
            op = self.tokens[self.at][1]
            self.at += 1
            tree = (op, tree, self.term())
        return tree

    def term(self):
        tree = self.factor()
        while self.peek() in ("*", "/"):
            op = self.tokens[self.at][1]
            self.at += 1
            tree = (op, tree, self.factor())
        return tree

    def factor(self):
        if self.at >= len(self.tokens):
            raise UsageError(f"--tie {self.text!r}: the expression ends where a number, a key "
                             "or '(' is expected")
        kind, value = self.tokens[self.at]
        self.at += 1
        if value in ("+", "-"):
            inner = self.factor()
            return ("neg", inner) if value == "-" else inner
        if kind == "number":
            number = float(value) if any(c in value for c in ".eE") else int(value)
            return ("number", number)
        if kind == "key":
            return ("key", value)
        if value == "(":
            tree = self.expression()
            if self.peek() != ")":
                raise UsageError(f"--tie {self.text!r}: a '(' is not closed")
            self.at += 1
            return tree
        raise UsageError(f"--tie {self.text!r}: unexpected {value!r} where a number, a key "
                         "or '(' is expected")


def _keys(tree):
    if tree[0] == "key":
        yield tree[1]
    elif tree[0] != "number":
        for branch in tree[1:]:
            yield from _keys(branch)


def _evaluate(tree, point, tie):
    kind = tree[0]
    if kind == "number":
        return tree[1]
    if kind == "key":
        value = point[tree[1]]
        if tree is tie.tree:  # a bare key: its value as it is (a string, a list, a count)
            return value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise UsageError(f"--tie {tie.key}={tie.text}: {tree[1]} is {value!r} here, not a "
                             "number")
        return value
    if kind == "neg":
        return -_evaluate(tree[1], point, tie)
    left, right = _evaluate(tree[1], point, tie), _evaluate(tree[2], point, tie)
    if kind == "/" and right == 0:
        raise UsageError(f"--tie {tie.key}={tie.text}: a division by zero at "
                         + ", ".join(f"{k}={point[k]!r}" for k in tie.uses))
    result = _OPERATORS[kind](left, right)
    if isinstance(result, float) and not math.isfinite(result):
        raise UsageError(f"--tie {tie.key}={tie.text}: {result} at "
                         + ", ".join(f"{k}={point[k]!r}" for k in tie.uses))
    return result
