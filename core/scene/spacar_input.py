"""SPACAR input files (.dat) read into flexure scene dictionaries: `read_spacar(path)`.

A SPACAR input file holds one keyword per line followed by its numbers; `%` or `#` starts a
comment, keywords may be in either case. Its data come in blocks, each closed by END: the
kinematic block first (X, the elements, FIX, INPUTX, INPUTE, DYNX, DYNE, RLSE), then the
dynamic data (ESTIFF, EDAMP, EM, XM, XF, GRAVITY: `spacar_properties`; the inputs' start
values INPUTX, INPUTE and increments DELINPX, DELINPE, the inputs INPUTF, INX and the outputs
OUTX, OUTXP, OUTE, OUTF: `spacar_ports`); HALT may follow an END, and
END END ends the input (what follows, such as SPAVISUAL's VISUALIZATION data, is not read).
Node numbers name flexure's nodes ("1", "2", ...), element numbers its elements and their
sections; directions 1, 2, 3 are x, y, z (1 is phi on a planar rotational node, 1 to 4 the
Euler parameters of a spatial one); deformation numbers n are flexure's "en"; INPUTF / INX
number k is the input "uk" (one numbering, SPACAR's vector u), OUTX / OUTXP / OUTE / OUTF
number k the output "yk" (one numbering, SPACAR's vector y).

    PLTRUSS e p q             TRUSS e p q               FIX n [dir ...]
    PLBEAM e p rp q rq        BEAM e p rp q rq yx yy yz  INPUTX n dir [dir ...]
    X n x y [z]               DYNX n dir [dir ...]      DYNE e def [def ...]
    RLSE e def [def ...]      ESTIFF e EA [EI [EI/GAs]]  ESTIFF e EA GIt EIy EIz [sy sz]  (BEAM)
    EDAMP e (as ESTIFF: EdA [EdI [0]]; EdA GdIt EdIy EdIz [0 0])
    EM e rho_A [0]            EM e rho_A [rho(Iy+Iz) rho_Iy rho_Iz 0]  (BEAM)
    XM n m | J | Jxx Jxy Jxz Jyy Jyz Jzz    XF n fx fy [fz] | M    GRAVITY gx gy [gz]
    INPUTF k n dir            OUTX k n dir              OUTXP k n dir     ITERSTEP ... (ignored)
    INPUTE e def [def ...]    INPUTX n dir x | INPUTE e def v  (after END: the start values)
    DELINPX n dir dx          DELINPE e def dv          INX k n dir
    OUTE k e def              OUTF k e def

What this is based on (SPACAR's own manual was not at hand):
- The course notes "Prototype modelling of mechanic systems" (Aarts, Jonker, van Dijk,
  University of Twente): PLTRUSS, PLBEAM and BEAM with their nodes and deformations e1..e6,
  the node numbering of their models (a beam's translational and rotational nodes as separate
  numbers), fixed / dynamic-DOF coordinates and released deformations, `INPUTF 1 2 1` and
  `OUTX 1 2 1` (number, node, coordinate).
- SPACAR Light (github.com/precision-utwente/spalight, spacarlight.m version 1.28 and the
  earlier Spacar_light.m), the University of Twente's MATLAB front end that writes the .dat
  files SPACAR reads: `X n x y z`, `BEAM e p rp q rq yx yy yz` (the last three the principal
  y' axis), DYNE / RLSE with deformation numbers, `FIX n [dir]`, `INPUTX n dir ...`, ESTIFF
  with EA GJ EIy EIz and the two shear terms sy = EIy / (k G A), sz = EIz / (k G A) (m^2, k
  the shear coefficient of its calc_stiffness; read as the shear stiffnesses GAs_z = EIy / sy
  and GAs_y = EIz / sz, N), EM with m/L Jxx/L Jyy/L Jzz/L Jyz/L, XM with a mass
  or Ixx Ixy Ixz Iyy Iyz Izz, XF, GRAVITY, ITERSTEP, INPUTF / OUTX / OUTXP, the blocks
  END HALT ... END END and `#` comments; `INPUTX n dir x` after the kinematic block (the
  input's start, an absolute coordinate: the X position plus its initial displacement) and
  `DELINPX n dir dx` (its increment over the load steps), and INX, OUTF in its draft of a
  state space (commented out: INX k n dir numbered with INPUTF).
Where they are silent (the PLTRUSS, PLBEAM and TRUSS lines, EDAMP, DYNX, the planar counts,
the PLBEAM's shear term, taken as EI / (k G A) after the BEAM's) the choice made here follows
the same pattern and is documented in docs/scene-format.md, with what is refused. Every
mistake is a SceneError naming the file, the line and what is wrong; nothing is guessed.
"""

import re
from pathlib import Path

from ..errors import SceneError
from .spacar_ports import STATUS_WORDS, PortRecords
from .spacar_properties import PropertyRecords
from .spacar_records import (
    AXES,
    BOTH_BLOCKS,
    DYNAMIC,
    ELEMENTS,
    KINEMATIC,
    NUMBER,
    UNSUPPORTED,
    R,
    RecordReader,
    T,
    records,
)

__all__ = ["import_spacar", "read_spacar"]


def read_spacar(path: str | Path) -> dict:
    """The flexure scene dictionary of a SPACAR input file; `load_scene` reads a `.dat` path
    through this.

    Parameters
    ----------
    path : str or Path
        The SPACAR input file (.dat), in SI units; the module docstring lists its syntax.

    Returns
    -------
    dict
        The scene dictionary, in the file's (SI) units: what `build_model` takes and
        `scene_toml` writes.

    Raises
    ------
    SceneError
        "`path`: line N: KEYWORD: what is wrong" for an unreadable file, a mistake, or what
        flexure does not support.
    """
    return import_spacar(path)[0]


def import_spacar(path: str | Path) -> tuple[dict, list[str]]:
    """The scene dictionary of a SPACAR input file (`read_spacar`) and what became of its
    INPUTX and INPUTE coordinates and deformations, one line each (`flexure import` prints
    them): a kinematic input with its start and increment, or held.

    Parameters
    ----------
    path : str or Path
        The SPACAR input file (.dat).

    Returns
    -------
    tuple of (dict, list of str)

    Raises
    ------
    SceneError
        As `read_spacar`.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise SceneError(f"{path}: cannot read the SPACAR input file: {error.strerror}") from None
    # keywords and numbers are ASCII: a byte that is not UTF-8 (8-bit text in a comment) can
    # only matter outside a comment, where its replacement character is a named mistake
    found = records(path, raw.decode("utf-8", errors="replace"))
    importer = _Importer(path, found)
    return importer.scene(), importer.notes


class _Importer(PortRecords, PropertyRecords, RecordReader):
    """Turns the records of one file into a scene dictionary, checking each."""

    def __init__(self, path, found):
        self.path = path
        self.records = found
        self.dimension = None
        self.elements = {}  # number -> {"type", "nodes", "record", "y_axis"}
        self.kinds = {}  # node number -> (kind, record that made it so)
        self.positions = {}  # node number -> (values, record)
        self.coordinate_status = {}  # (node, axis) -> (status, record)
        self.deformation_status = {}  # (element, deformation) -> (status, record)
        self.sections = {}  # element number -> {flexure key: value}
        self.nodal = {}  # (node, "mass" | "force") -> (value, record)
        self.given = {}  # (keyword, number) -> record: property lines given once
        self.first_element = None  # the record that set the dimension
        self.gravity = None
        self.notes = []  # what each INPUTX / INPUTE became (`import_spacar`)
        self.init_ports()

    # -- the scene ------------------------------------------------------------------------
    def scene(self):
        """Read every record (elements and X first: they say what the nodes are)."""
        for record in self.records:
            self.check_block(record)
        for record in self.records:
            if record.keyword in ELEMENTS:
                self.element(record)
        if self.dimension is None:
            raise SceneError(f"{self.path}: no element (PLTRUSS, PLBEAM, TRUSS or BEAM): "
                             "nothing to model")
        for record in self.records:
            if record.keyword == "X":
                self.position(record)
        for number, element in self.elements.items():
            for node in element["nodes"]:
                if self.kinds[node][0] == T and node not in self.positions:
                    self.fail(element["record"], f"node {node} of element {number} is a "
                                                 "translational node without an X line (its "
                                                 "initial position)")
        handlers = {"FIX": self.fix, "INPUTX": self.coordinate_list, "DYNX": self.coordinate_list,
                    "DYNE": self.deformation_list, "RLSE": self.deformation_list,
                    "INPUTE": self.deformation_list, "DELINPX": self.motion_value,
                    "DELINPE": self.motion_value, "INX": self.port, "OUTE": self.port,
                    "OUTF": self.port,
                    "ESTIFF": self.stiffness, "EDAMP": self.stiffness, "EM": self.mass_per_length,
                    "XM": self.lumped_mass, "XF": self.force, "GRAVITY": self.set_gravity,
                    "INPUTF": self.port, "OUTX": self.port, "OUTXP": self.port,
                    "ITERSTEP": lambda record: None}  # flexure's solver has its own steps
        for record in self.records:
            if record.keyword in BOTH_BLOCKS and record.block > 0:
                self.motion_value(record)  # a start value, after the declarations
            elif record.keyword in handlers:
                handlers[record.keyword](record)
        self.check_released_stiffness()
        return self.assemble()

    def check_block(self, record):
        """A known keyword in its block; an unknown or unsupported one refused."""
        keyword = record.keyword
        if keyword in UNSUPPORTED:
            self.fail(record, UNSUPPORTED[keyword])
        if keyword not in KINEMATIC | DYNAMIC:
            if NUMBER.fullmatch(keyword):
                self.fail(record, "a line must start with a keyword, not a number")
            self.fail(record, f"unknown keyword (flexure reads "
                              f"{', '.join(sorted(KINEMATIC | DYNAMIC))}, END and HALT)")
        if keyword in BOTH_BLOCKS:
            return  # declarations before the first END, start values after it
        if keyword in KINEMATIC and record.block > 0:
            self.fail(record, "belongs to the kinematic block, before the first END")
        if keyword in DYNAMIC and record.block == 0:
            self.fail(record, "belongs after the kinematic block's END (SPACAR reads the "
                              "dynamic data there)")

    # -- values -------------------------------------------------------------------------

    def node(self, record, word):
        number = self.integer(record, word, "a node number")
        if number not in self.kinds:
            self.fail(record, f"unknown node {number}: no X line and no element has it")
        return number

    def element_number(self, record, word):
        number = self.integer(record, word, "an element number")
        if number not in self.elements:
            self.fail(record, f"unknown element {number}: no element line defines it")
        return number

    def axes(self, node):
        return AXES[(self.kinds[node][0], self.dimension)]

    def direction(self, record, node, word):
        """The axis name of direction `word` (1, 2, ...) of `node`."""
        axes = self.axes(node)
        number = self.integer(record, word, "a direction")
        if number > len(axes):
            self.fail(record, f"node {node} is {self.kinds[node][0]} with directions 1 to "
                              f"{len(axes)} ({', '.join(axes)}); got {number}")
        return axes[number - 1]

    # -- the kinematic block ----------------------------------------------------------------
    def element(self, record):
        syntax = ELEMENTS[record.keyword]
        what = "element number, nodes " + " ".join(
            ("p", "rp", "q", "rq") if len(syntax.node_kinds) == 4 else ("p", "q"))
        if syntax.orientation:
            what += " and the principal y' axis (3 numbers)"
        words = self.count(record, {1 + len(syntax.node_kinds) + 3 * syntax.orientation},
                           what)
        number = self.integer(record, words[0], "an element number")
        if number in self.elements:
            self.fail(record, f"element {number} is defined twice (first on line "
                              f"{self.elements[number]['record'].line})")
        if self.dimension is None:
            self.dimension, self.first_element = syntax.dimension, record
        elif syntax.dimension != self.dimension:
            first = self.first_element
            self.fail(record, f"a {syntax.dimension}-D element in a {self.dimension}-D model "
                              f"({first.keyword}, line {first.line}); planar (PL...) and "
                              "spatial elements do not mix")
        nodes = [self.integer(record, word, "a node number")
                 for word in words[1:1 + len(syntax.node_kinds)]]
        for node, kind in zip(nodes, syntax.node_kinds, strict=True):
            known = self.kinds.setdefault(node, (kind, record))
            if known[0] != kind:
                self.fail(record, f"node {node} is {kind} here but {known[0]} in "
                                  f"{known[1].keyword} on line {known[1].line}")
        if len(set(nodes)) < len(nodes):
            self.fail(record, f"a node appears twice among {nodes}")
        entry = {"type": record.keyword, "nodes": nodes, "record": record}
        if syntax.orientation:
            entry["y_axis"] = [self.number(record, w, "the principal y' axis")
                               for w in words[-3:]]
        self.elements[number] = entry

    def position(self, record):
        words = self.count(record, {1 + self.dimension},
                           f"node number and {self.dimension} coordinates in this "
                           f"{self.dimension}-D model")
        node = self.integer(record, words[0], "a node number")
        kind = self.kinds.setdefault(node, (T, record))
        if kind[0] == R:
            self.fail(record, f"node {node} is the rotational node of {kind[1].keyword} on "
                              f"line {kind[1].line}; X gives translational nodes' positions")
        if node in self.positions:
            self.fail(record, f"node {node} has an X line already (line "
                              f"{self.positions[node][1].line})")
        self.positions[node] = ([self.number(record, w, "coordinate") for w in words[1:]],
                                record)

    def set_status(self, table, key, status, record, name):
        """Give a coordinate or deformation its status once: a second time, even the same
        status (FIX 2 2 2), is refused as anything given twice is (which one was meant?)."""
        if key in table:
            known_status, known_record = table[key]
            self.fail(record, f"{name} is already {STATUS_WORDS[known_status]} "
                              f"({known_record.keyword}, line {known_record.line})")
        table[key] = (status, record)

    def fix(self, record):
        self.at_least(record, 1, "node number, then optional directions")
        node = self.node(record, record.words[0])
        axes = [self.direction(record, node, w) for w in record.words[1:]] or self.axes(node)
        if self.kinds[node][0] == R and self.dimension == 3 and set(axes) != set(self.axes(node)):
            self.fail(record, f"node {node} is a spatial rotational node: flexure fixes its "
                              "orientation as a whole (FIX without directions)")
        for axis in axes:
            self.set_status(self.coordinate_status, (node, axis), "fixed", record,
                            f"{axis} of node {node}")

    def coordinate_list(self, record):
        """INPUTX (an input held at its X position: fixed) or DYNX (a DOF) coordinates."""
        words = self.at_least(record, 2, "node number and one or more directions")
        node = self.node(record, words[0])
        if self.kinds[node][0] == R and self.dimension == 3:
            self.fail(record, f"node {node} is a spatial rotational node: its Euler "
                              "parameters cannot be DOFs or inputs in flexure (make a "
                              "deformation a DOF with DYNE)")
        status = "input" if record.keyword == "INPUTX" else "dof"
        for word in words[1:]:
            axis = self.direction(record, node, word)
            self.set_status(self.coordinate_status, (node, axis), status, record,
                            f"{axis} of node {node}")

    def deformation_list(self, record):
        """DYNE (DOF), RLSE (released) or INPUTE (kinematic input) deformations of one
        element."""
        words = self.at_least(record, 2, "element number and one or more deformation numbers")
        number = self.element_number(record, words[0])
        status = {"DYNE": "edof", "RLSE": "released", "INPUTE": "input"}[record.keyword]
        for word in words[1:]:
            deformation = self.deformation_number(record, number, word)
            self.set_status(self.deformation_status, (number, deformation), status, record,
                            f"deformation {deformation} of element {number}")

    def check_released_stiffness(self):
        """A released deformation deforms elastically in flexure: it needs its stiffness."""
        for (number, deformation), (status, record) in self.deformation_status.items():
            syntax = ELEMENTS[self.elements[number]["type"]]
            needed = syntax.stiffness_of[deformation - 1]
            if status == "released" and self.sections.get(number, {}).get(needed, 0.0) <= 0.0:
                self.fail(record, f"deformation {deformation} of element {number} is released "
                                  f"but has no stiffness: flexure needs ESTIFF {number} with "
                                  f"{needed} > 0 (a released deformation deforms elastically; "
                                  "a free one is a DOF: DYNE)")

    # -- the scene dictionary ---------------------------------------------------------------
    def assemble(self):
        name = re.sub(r"[^A-Za-z0-9_]", "_", self.path.stem)
        if not name or name[0].isdigit():
            name = f"spacar_{name}"
        inputs, outputs, self.notes = self.port_tables()
        moving = self.moving()
        # held: an INPUTX coordinate fixed at its X position, an INPUTE deformation prescribed
        # zero (the spacar_ports docstring says why)
        held = [(n, a) for (n, a), (s, _) in sorted(self.coordinate_status.items())
                if s == "input" and ("x", n, a) not in moving]
        held_e = [f"{e}.e{d}" for (e, d), (s, _) in sorted(self.deformation_status.items())
                  if s == "input" and ("e", e, d) not in moving]
        self.notes += [f"INPUTX {c.replace('.', ' ')} -> the fixed coordinate {n}.{a}: held at "
                       "its X position (no INPUTX value, DELINPX or INX moves it)"
                       for c, (n, a) in ((self.spacar_coordinate(h), h) for h in held)]
        self.notes += [f"INPUTE {d.replace('.e', ' ')} -> the deformation {d} prescribed zero: "
                       "held (no INPUTE value or DELINPE moves it)" for d in held_e]
        description = f"imported from the SPACAR input file {self.path.name}" + (
            f"; INPUTX held at the X position: {', '.join(f'{n}.{a}' for n, a in held)}"
            if held else "") + (
            f"; INPUTE held at zero: {', '.join(held_e)}" if held_e else "")
        header = {"name": name, "description": description, "dimension": self.dimension}
        if self.gravity is not None:
            header["gravity"] = self.gravity[0]
        scene = {"scene": header, "sections": {}, "nodes": {}, "elements": {}}
        for node in sorted(self.kinds):
            scene["nodes"][str(node)] = self.node_table(node)
        for number in sorted(self.elements):
            scene["sections"][str(number)] = dict(self.sections.get(number, {}))
            scene["elements"][str(number)] = self.element_table(number)
        if inputs:
            scene["inputs"] = inputs
        if outputs:
            scene["outputs"] = outputs
        return scene

    def spacar_coordinate(self, coordinate):
        """"n.dir" of a (node, axis): its SPACAR numbers."""
        node, axis = coordinate
        return f"{node}.{self.axes(node).index(axis) + 1}"

    def node_table(self, node):
        kind = self.kinds[node][0]
        status = {a: self.coordinate_status.get((node, a), (None,))[0] for a in self.axes(node)}
        moving = self.moving()
        fixed = [a for a, s in status.items()
                 if s == "fixed" or (s == "input" and ("x", node, a) not in moving)]
        dofs = [a for a, s in status.items() if s == "dof"]
        if kind == T:
            table = {"position": self.positions[node][0]}
        elif self.dimension == 2:
            table = {"angle": 0.0}  # SPACAR's rotational nodes start unrotated
        else:
            table = {"rotation": [0.0, 0.0, 0.0]}
            fixed = bool(fixed)
        if fixed:
            table["fixed"] = fixed
        if dofs:
            table["dof"] = dofs
        if (node, "mass") in self.nodal:
            table["mass" if kind == T else "inertia"] = self.nodal[(node, "mass")][0]
        if (node, "force") in self.nodal:
            table["force" if kind == T else "moment"] = self.nodal[(node, "force")][0]
        return table

    def element_table(self, number):
        element = self.elements[number]
        table = {"type": element["type"], "nodes": [str(n) for n in element["nodes"]],
                 "section": str(number)}
        for status, key in (("released", "released"), ("edof", "dof")):
            found = sorted(d for (e, d), (s, _) in self.deformation_status.items()
                           if e == number and s == status)
            if found:
                table[key] = [f"e{d}" for d in found]
        if "y_axis" in element:
            table["y_axis"] = element["y_axis"]
        return table
