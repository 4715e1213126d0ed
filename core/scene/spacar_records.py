"""The lines of a SPACAR input file: its keyword records in their blocks (`records`), the
syntax of its element lines (`ELEMENTS`), and the checked reading of their values
(`RecordReader`, the base of `spacar_input`'s importer). `spacar_input` says what the syntax is
based on; every problem is a SceneError naming the file and the line."""

import re
from dataclasses import dataclass

from ..errors import SceneError
from .scene_reader import MAX_MAGNITUDE, show

T, R = "translational", "rotational"


@dataclass(frozen=True)
class ElementSyntax:
    """How SPACAR writes one element type and what its property lines hold."""

    dimension: int
    node_kinds: tuple  # the kinds of the node numbers after the element number
    stiffness: tuple  # flexure's section key of each ESTIFF value, in order
    damping: tuple  # ... of each EDAMP value
    stiffness_of: tuple  # the stiffness key behind each deformation e1, e2, ...
    # the optional trailing ESTIFF values, SPACAR's shear terms EI / (G As) (m^2), one per
    # bending plane: (flexure's shear stiffness key G As (N), the bending key EI it divides)
    shear: tuple = ()
    orientation: bool = False  # the principal y' axis follows the nodes


ELEMENTS = {
    "PLTRUSS": ElementSyntax(2, (T, T), ("EA",), ("EdA",), ("EA",)),
    "PLBEAM": ElementSyntax(2, (T, R, T, R), ("EA", "EI"), ("EdA", "EdI"), ("EA", "EI", "EI"),
                            shear=(("GAs", "EI"),)),
    "TRUSS": ElementSyntax(3, (T, T), ("EA",), ("EdA",), ("EA",)),
    "BEAM": ElementSyntax(3, (T, R, T, R), ("EA", "GIt", "EIy", "EIz"),
                          ("EdA", "GdIt", "EdIy", "EdIz"),
                          ("EA", "GIt", "EIy", "EIy", "EIz", "EIz"),
                          shear=(("GAs_z", "EIy"), ("GAs_y", "EIz")), orientation=True),
}
KINEMATIC = {"X", "FIX", "INPUTX", "INPUTE", "DYNX", "DYNE", "RLSE", *ELEMENTS}
DYNAMIC = {"ESTIFF", "EDAMP", "EM", "XM", "XF", "GRAVITY", "INPUTF", "OUTX", "OUTXP",
           "ITERSTEP", "INPUTX", "INPUTE", "DELINPX", "DELINPE", "INX", "OUTE", "OUTF"}
# in the kinematic block they declare kinematic inputs, after it they give their start values
BOTH_BLOCKS = {"INPUTX", "INPUTE"}
# SPACAR keywords met in public files that flexure does not model: why, in one line each
UNSUPPORTED = {
    "DELXF": "a load increment over the load steps is not supported; put the final load in XF",
}
AXES = {(T, 2): ("x", "y"), (T, 3): ("x", "y", "z"), (R, 2): ("phi",),
        (R, 3): ("lambda0", "lambda1", "lambda2", "lambda3")}
COMMENT = re.compile(r"[%#]")
INTEGER = re.compile(r"[-+]?\d+")
MAX_DIGITS = 9  # of a node, element, direction or port number
# a Fortran number: 1, -2.5, .5, 1e-3, 1.5D3 (Python's float() would take nan, inf and 1_0)
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?")


@dataclass(frozen=True)
class Record:
    """One keyword line: its line number, keyword (upper case), values and block (0 is the
    kinematic block, before the first END)."""

    line: int
    keyword: str
    words: tuple
    block: int


def records(path, text):
    """The keyword lines of the file up to END END, each with its block number."""
    found, block, previous, opened = [], 0, None, None
    for number, raw in enumerate(text.splitlines(), start=1):
        words = COMMENT.split(raw, maxsplit=1)[0].split()
        if not words:
            continue
        keyword = words[0].upper()
        if keyword in ("END", "HALT"):
            if len(words) > 1:
                raise SceneError(f"{path}: line {number}: {keyword} takes no values, got "
                                 f"{show(' '.join(words[1:]))}")
            if keyword == "HALT" and previous != "END":
                raise SceneError(f"{path}: line {number}: HALT must follow an END")
            if keyword == "END" and previous == "END":
                return found  # END END: the end of SPACAR's input
            if keyword == "END":
                block, opened = block + 1, None
            previous = keyword
            continue
        previous = keyword
        opened = opened or number
        found.append(Record(number, keyword, tuple(words[1:]), block))
    if block == 0:
        what = "keywords but " if found else "no keyword line and "
        raise SceneError(f"{path}: {what}no END: a SPACAR input file closes its kinematic "
                         "block (X, the elements, FIX, ...) with END")
    if opened is not None:
        raise SceneError(f"{path}: line {opened}: the block that starts here has no END "
                         "before the end of the file")
    return found


class RecordReader:
    """Reads the values of one file's records, each checked: `path` names the file, the
    record its line and keyword, in every message."""

    path = "<input>"

    def fail(self, record, message):
        """Raise the SceneError "path: line N: KEYWORD: message"."""
        raise SceneError(f"{self.path}: line {record.line}: {record.keyword}: {message}")

    def count(self, record, allowed, what):
        """The record's values, refused unless their number is one of `allowed`."""
        if len(record.words) not in allowed:
            expected = " or ".join(str(n) for n in sorted(allowed))
            plural = "" if allowed == {1} else "s"
            self.fail(record, f"expected {expected} value{plural} ({what}), got "
                              f"{len(record.words)}")
        return record.words

    def at_least(self, record, minimum, what):
        """The record's values, refused if fewer than `minimum`."""
        if len(record.words) < minimum:
            self.fail(record, f"expected at least {minimum} value{'s' * (minimum > 1)} "
                              f"({what}), got {len(record.words)}")
        return record.words

    def integer(self, record, word, what):
        """The positive integer `word` (a node, element, direction or port number)."""
        # the length first: int() refuses more than 4300 digits with a ValueError of its own,
        # and no model numbers its nodes beyond a billion
        if not INTEGER.fullmatch(word) or len(word.lstrip("+-")) > MAX_DIGITS or int(word) < 1:
            self.fail(record, f"expected {what} (a positive integer of at most {MAX_DIGITS} "
                              f"digits), got {show(word)}")
        return int(word)

    def number(self, record, word, what, *, minimum=None):
        """The finite number `word` (SI units, as the file), at least `minimum` if given;
        `what` names it in a message."""
        if not NUMBER.fullmatch(word):
            self.fail(record, f"{what}: expected a number, got {show(word)}")
        value = float(word.replace("d", "e").replace("D", "e"))
        if abs(value) > MAX_MAGNITUDE:
            self.fail(record, f"{what}: expected a magnitude <= {MAX_MAGNITUDE:g} (SI units), "
                              f"got {word}")
        if minimum is not None and value < minimum:
            self.fail(record, f"{what}: expected a value >= {minimum:g}, got {word}")
        return value

    def shear_stiffness(self, record, number, bending, keys, term):
        """G As (N) = EI / term from one of SPACAR's shear terms EI / (G As) (m^2, > 0);
        keys: (the shear key, the bending key), bending: the EI value (N m^2)."""
        shear_key, bending_key = keys
        name = f"{bending_key}/{shear_key}"
        if bending <= 0.0:
            self.fail(record, f"element {number}: the shear term {name} = {term!r} m^2 needs "
                              f"{bending_key} > 0 (the shear stiffness {shear_key} is "
                              f"{bending_key} / ({name})), got {bending_key} = {bending!r}")
        value = bending / term
        if not value <= MAX_MAGNITUDE:
            self.fail(record, f"element {number}: the shear term {name} = {term!r} m^2 gives "
                              f"{shear_key} = {value:g} N, above {MAX_MAGNITUDE:g} (SI units); "
                              "write 0 for a beam rigid in shear")
        return value
