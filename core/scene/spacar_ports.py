"""The inputs and outputs of a SPACAR input file: its force inputs and kinematic inputs (the
vector u and the prescribed motion) and its outputs (the vector y), read into a scene's
[inputs] and [outputs]; the part of `spacar_input`'s importer that says what moves the model
and what is measured.

    INPUTX n dir [dir ...]   (kinematic block)  coordinates that are kinematic inputs
    INPUTE e def [def ...]   (kinematic block)  deformations that are kinematic inputs
    INPUTX n dir x           (after END)        the coordinate's value at the run's start
    DELINPX n dir dx                            its increment over the run
    INPUTE e def v, DELINPE e def dv            the same for a deformation (m)
    INPUTF k n dir           the force input uk      INX k n dir     the kinematic input uk
    OUTX / OUTXP k n dir     the output yk: a coordinate's position / velocity
    OUTE / OUTF k e def      the output yk: a deformation (m) / its stress resultant (N)

What a kinematic input becomes. An INPUTX coordinate (an INPUTE deformation) that the file
moves, by an INPUTX (INPUTE) value after the kinematic block, a DELINPX (DELINPE) or an INX,
becomes a scene input of `kind = "motion"`: `start` the value the run starts from (the
INPUTX value; without one the X position, 0 on a deformation), `value` = start + increment,
where the run ends and a static solution holds it; INX k names it uk (SPACAR's input vector
u, one numbering with INPUTF), the others `inputx_N_AXIS` and `inpute_E_eD`. One that the file
holds, without any of these, stays what SPACAR makes of it: a coordinate fixed at its X
position, a deformation prescribed zero. A held input moves nothing, so it is the same model
either way; as a fixed coordinate it keeps the file simulating (`flexure simulate`, `loop`,
the FMU), which a kinematic input does not yet (docs/scene-format.md says why this was chosen).

The values after the kinematic block take one number each, as SPACAR Light writes them
(`INPUTX n dir x`, `DELINPX n dir dx`): SPACAR's rates of the input are not read. OUTE and
OUTF name an element and its deformation number as INPUTE does (chosen: SPACAR Light's draft
of them, commented out in spacarlight.m 1.28, is unfinished). Every mistake is a SceneError
naming the file, the line and the keyword.
"""

from .spacar_records import ELEMENTS, R

STATUS_WORDS = {"fixed": "fixed", "input": "an input", "dof": "a DOF", "released": "released",
                "edof": "a DOF"}

# after the kinematic block, each keyword that gives a kinematic input's start or increment:
# (what it moves, a coordinate "x" or a deformation "e"; "start" or "increment")
MOTION_VALUES = {"INPUTX": ("x", "start"), "DELINPX": ("x", "increment"),
                 "INPUTE": ("e", "start"), "DELINPE": ("e", "increment")}
# each numbered port keyword: (its vector, "u" or "y", and what it reads)
PORTS = {"INPUTF": ("u", "force"), "INX": ("u", "motion"), "OUTX": ("y", "position"),
         "OUTXP": ("y", "velocity"), "OUTE": ("y", "deformation"), "OUTF": ("y", "stress")}


class PortRecords:
    """The importer's part for inputs and outputs; uses its `coordinate_status`,
    `deformation_status`, `elements`, `positions` and the checked readers of
    `RecordReader`."""

    def init_ports(self):
        self.ports = {"u": {}, "y": {}}  # number -> (record, target, quantity)
        # ("x", node, axis) or ("e", element, deformation) -> {"start" or "increment": (value,
        # record)}: what the file says of each kinematic input's move, in the file's order
        self.motion = {}

    # -- records ------------------------------------------------------------------------------
    def motion_value(self, record):
        """INPUTX / INPUTE with a value (after the kinematic block), DELINPX, DELINPE: one
        kinematic input's start or increment, m (rad on a planar angle)."""
        kind, which = MOTION_VALUES[record.keyword]
        if kind == "x":
            words = self.count(record, {3}, "node number, direction and value")
            node = self.node(record, words[0])
            if self.kinds[node][0] == R and self.dimension == 3:
                self.fail(record, f"node {node} is a spatial rotational node: its Euler "
                                  "parameters cannot be inputs in flexure")
            axis = self.direction(record, node, words[1])
            target, name = ("x", node, axis), f"{axis} of node {node}"
            status = self.coordinate_status.get((node, axis), (None, None))
            declaration = f"INPUTX {node} {words[1]}"
        else:
            words = self.count(record, {3}, "element number, deformation number and value")
            number = self.element_number(record, words[0])
            deformation = self.deformation_number(record, number, words[1])
            target, name = ("e", number, deformation), f"deformation {deformation} of " \
                                                       f"element {number}"
            status = self.deformation_status.get((number, deformation), (None, None))
            declaration = f"INPUTE {number} {deformation}"
        self.require_input(record, status, name, declaration)
        value = self.number(record, words[2], which)
        given = self.motion.setdefault(target, {})
        if which in given:
            self.fail(record, f"the {which} of {name} is given twice (first on line "
                              f"{given[which][1].line})")
        given[which] = (value, record)

    def require_input(self, record, status, name, declaration):
        """Refuse a value or INX for what the kinematic block does not make an input."""
        known, where = status
        if known == "input":
            return
        found = ("the kinematic block does not make it an input" if known is None else
                 f"it is {STATUS_WORDS[known]} ({where.keyword}, line {where.line})")
        self.fail(record, f"{name} is not a kinematic input: {found}; declare it with "
                          f"{declaration} before the first END")

    def deformation_number(self, record, number, word):
        """The deformation number `word` of element `number`, checked against its type."""
        count = len(ELEMENTS[self.elements[number]["type"]].stiffness_of)
        deformation = self.integer(record, word, "a deformation number")
        if deformation > count:
            self.fail(record, f"element {number} ({self.elements[number]['type']}) has "
                              f"deformations 1 to {count}; got {deformation}")
        return deformation

    def port(self, record):
        """INPUTF / INX k n dir (the input uk), OUTX / OUTXP k n dir, OUTE / OUTF k e def (the
        output yk)."""
        vector, quantity = PORTS[record.keyword]
        on_element = quantity in ("deformation", "stress")
        words = self.count(record, {3}, "number, element number and deformation number"
                           if on_element else "number, node number and direction")
        number = self.integer(record, words[0], "an input or output number")
        if on_element:
            element = self.element_number(record, words[1])
            target = ("e", element, self.deformation_number(record, element, words[2]))
        else:
            node = self.node(record, words[1])
            if self.kinds[node][0] == R and self.dimension == 3:
                self.fail(record, f"node {node} is a spatial rotational node: inputs and "
                                  "outputs on its Euler parameters are not supported")
            axis = self.direction(record, node, words[2])
            target = ("x", node, axis)
        if quantity == "motion":
            self.require_input(record, self.coordinate_status.get((node, axis), (None, None)),
                               f"{axis} of node {node}", f"INPUTX {node} {words[2]}")
            named = [r for r, t, q in self.ports["u"].values() if q == "motion" and t == target]
            if named:
                self.fail(record, f"{axis} of node {node} is an input of the state space "
                                  f"already (INX, line {named[0].line})")
        table = self.ports[vector]
        if number in table:
            first = table[number][0]
            self.fail(record, f"number {number} is given twice (first in {first.keyword} on "
                              f"line {first.line})")
        table[number] = (record, target, quantity)

    # -- the scene's tables -------------------------------------------------------------------
    def moving(self):
        """{target: the name of its kinematic input} for every INPUTX coordinate and INPUTE
        deformation that the file moves (a start, an increment or an INX); the others are
        held (module docstring)."""
        names = {target: f"u{k}" for k, (_, target, quantity) in self.ports["u"].items()
                 if quantity == "motion"}
        for target in self.motion:
            if target not in names:
                kind, owner, which = target
                names[target] = (f"inputx_{owner}_{which}" if kind == "x"
                                 else f"inpute_{owner}_e{which}")
        return names

    def motion_table(self, target):
        """The [inputs.NAME] table of one kinematic input the file moves, and a line saying
        what it is (for `flexure import`)."""
        kind, owner, which = target
        given = self.motion.get(target, {})
        table = ({"kind": "motion", "node": str(owner), "coordinate": which} if kind == "x"
                 else {"kind": "motion", "element": str(owner), "deformation": f"e{which}"})
        if kind == "x":
            axes = self.axes(owner)
            scene_start = (self.positions[owner][0][axes.index(which)]
                           if self.kinds[owner][0] != R else 0.0)
            what = f"INPUTX {owner} {axes.index(which) + 1}"
            unit = "rad" if which == "phi" else "m"
        else:
            scene_start, what, unit = 0.0, f"INPUTE {owner} {which}", "m"
        start = given["start"][0] if "start" in given else scene_start
        if "start" in given:
            table["start"] = start
        if given:  # where the run ends, and a static solution holds it
            table["value"] = start + given["increment"][0] if "increment" in given else start
        delta = "DELINPX" if kind == "x" else "DELINPE"
        if "increment" in given:
            said = (f"from {start!r} {unit} by {given['increment'][0]!r} {unit} "
                    f"({delta}) to {table['value']!r} {unit}, where a static solution holds it")
        else:
            said = f"held at {start!r} {unit} (no {delta})"
        return table, f"{what} -> the kinematic input {{name}}: {said}"

    def port_tables(self):
        """The scene's "inputs" and "outputs" tables (those the file has), and one line per
        kinematic input saying what it became."""
        names = self.moving()
        inputs, notes = {}, []

        def motion(target):
            inputs[names[target]], said = self.motion_table(target)
            notes.append(said.format(name=names[target]))

        for k, (_, target, quantity) in self.numbered(self.ports["u"]):
            if quantity == "force":
                inputs[f"u{k}"] = {"node": str(target[1]), "coordinate": target[2]}
            else:  # INX: uk, in the state space's input vector
                motion(target)
        for target in self.motion:  # the others the file moves, in its order
            if names[target] not in inputs:
                motion(target)
        outputs = {}
        for k, (_, target, quantity) in self.numbered(self.ports["y"]):
            kind, owner, which = target
            outputs[f"y{k}"] = ({"node": str(owner), "coordinate": which, "quantity": quantity}
                                if kind == "x" else
                                {"element": str(owner), "deformation": f"e{which}",
                                 "quantity": quantity})
        return inputs, outputs, notes

    def numbered(self, table):
        """The entries of an input or output table in order, numbered 1, 2, ... as SPACAR's
        vectors u and y are: a gap is refused."""
        for k, number in enumerate(sorted(table), start=1):
            if number != k:
                record = table[number][0]
                self.fail(record, f"number {number} without a number {k}: SPACAR numbers its "
                                  "inputs (and its outputs) 1, 2, ... as positions in u (y)")
        return [(k, table[k]) for k in sorted(table)]
