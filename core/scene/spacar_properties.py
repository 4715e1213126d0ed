"""The property lines of a SPACAR input file after its kinematic block: an element's ESTIFF,
EDAMP and EM (its section), a node's XM and XF, and GRAVITY; the part of `spacar_input`'s
importer that reads what the model is made of (`spacar_input` says what the syntax is based
on). Each value is checked (`RecordReader`); a property line given twice is refused."""

from .spacar_records import ELEMENTS, R, T


class PropertyRecords:
    """The importer's part for the property lines; uses its `elements`, `kinds`, `sections`,
    `nodal`, `given` and `gravity`."""

    def once(self, record, number, what):
        """Refuse a property line given twice for the same element or node."""
        first = self.given.setdefault((record.keyword, number), record)
        if first is not record:
            self.fail(record, f"{what} {number}: given twice (first on line {first.line})")

    def stiffness(self, record):
        """ESTIFF (stiffness) or EDAMP (damping) of one element."""
        self.at_least(record, 1, "element number and the values")
        number = self.element_number(record, record.words[0])
        syntax = ELEMENTS[self.elements[number]["type"]]
        keys = syntax.stiffness if record.keyword == "ESTIFF" else syntax.damping
        shear_names = tuple(f"{bending}/{shear}" for shear, bending in syntax.shear)
        allowed = {len(keys) + 1, len(keys) + 1 + len(syntax.shear)}
        shear_text = f" and optionally {' '.join(shear_names)}" * bool(syntax.shear)
        words = self.count(record, allowed, f"element number, then {' '.join(keys)}{shear_text} "
                                            f"for a {self.elements[number]['type']}")
        self.once(record, number, "element")
        values = [self.number(record, w, name, minimum=0.0)
                  for w, name in zip(words[1:], (*keys, *shear_names), strict=False)]
        section = self.sections.setdefault(number, {})
        section.update(zip(keys, values, strict=False))
        shear_terms = values[len(keys):]
        if record.keyword == "EDAMP":
            if any(shear_terms):
                self.fail(record, "flexure's damping has no shear terms of its own (it bends "
                                  "with the stiffness's shear ratio): they must be 0, got "
                                  f"{' '.join(words[1 + len(keys):])}")
            return
        for (shear, bending), term in zip(syntax.shear, shear_terms, strict=False):
            if term > 0.0:  # 0: rigid in shear, the default
                section[shear] = self.shear_stiffness(record, number, section[bending],
                                                      (shear, bending), term)

    def mass_per_length(self, record):
        """EM: mass per length and, for a BEAM, the section's rotational inertia per length."""
        self.at_least(record, 1, "element number and the values")
        number = self.element_number(record, record.words[0])
        kind = self.elements[number]["type"]
        allowed = {"PLTRUSS": {2}, "TRUSS": {2}, "PLBEAM": {2, 3}, "BEAM": {2, 6}}[kind]
        names = {"PLBEAM": ("rho_A", "J/L"),
                 "BEAM": ("rho_A", "Jxx/L", "Jyy/L", "Jzz/L", "Jyz/L")}.get(kind, ("rho_A",))
        words = self.count(record, allowed, f"element number, then {' '.join(names)} for a "
                                            f"{kind}")
        self.once(record, number, "element")
        values = [self.number(record, w, name, minimum=None if name == "Jyz/L" else 0.0)
                  for w, name in zip(words[1:], names, strict=False)]
        section = self.sections.setdefault(number, {})
        section["rho_A"] = values[0]
        if kind == "PLBEAM" and len(values) == 2 and values[1] != 0.0:
            self.fail(record, "flexure's PLBEAM neglects the section's rotational inertia: "
                              f"J/L must be 0, got {words[2]}")
        if kind == "BEAM" and len(values) == 5:
            jxx, jyy, jzz, jyz = values[1:]
            # flexure's torsional inertia is rho (Iy + Iz); the file's values carry about 15
            # decimals (SPACAR Light writes %20.15f), so their sum may differ by round-off
            if abs(jxx - (jyy + jzz)) > 1e-9 * jxx + 3e-15:
                self.fail(record, f"Jxx/L = {words[2]} is not Jyy/L + Jzz/L = {jyy + jzz!r}: "
                                  "flexure's torsional inertia of a section is rho (Iy + Iz)")
            if jyz != 0.0:
                self.fail(record, f"Jyz/L must be 0 (flexure takes principal axes), got "
                                  f"{words[5]}")
            section.update(rho_Iy=jyy, rho_Iz=jzz)

    def lumped_mass(self, record):
        """XM: a translational node's mass, a planar rotational node's inertia, or a spatial
        rotational node's inertia tensor Ixx Ixy Ixz Iyy Iyz Izz (body frame)."""
        self.at_least(record, 1, "node number and the values")
        node = self.node(record, record.words[0])
        kind = self.kinds[node][0]
        if kind == R and self.dimension == 3:
            words = self.count(record, {7}, "node number, then Ixx Ixy Ixz Iyy Iyz Izz")
            xx, xy, xz, yy, yz, zz = (self.number(record, w, "inertia") for w in words[1:])
            value = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]
        else:
            what = "mass" if kind == T else "rotational inertia"
            words = self.count(record, {2}, f"node number and its {what}")
            # a lumped rotational inertia may be negative (SPACAR's lumped bar model)
            value = self.number(record, words[1], what, minimum=0.0 if kind == T else None)
        self.once(record, node, "node")
        self.nodal[(node, "mass")] = (value, record)

    def force(self, record):
        """XF: a force on a translational node, a moment on a planar rotational node."""
        self.at_least(record, 1, "node number and the values")
        node = self.node(record, record.words[0])
        if self.kinds[node][0] == R and self.dimension == 3:
            self.fail(record, f"node {node} is a spatial rotational node: flexure applies no "
                              "moments there")
        axes = self.axes(node)
        words = self.count(record, {1 + len(axes)}, f"node number and {', '.join(axes)}")
        self.once(record, node, "node")
        values = [self.number(record, w, a) for w, a in zip(words[1:], axes, strict=True)]
        self.nodal[(node, "force")] = (values if self.kinds[node][0] == T else values[0], record)

    def set_gravity(self, record):
        words = self.count(record, {self.dimension},
                           f"{self.dimension} components in this {self.dimension}-D model")
        if self.gravity is not None:
            self.fail(record, f"given twice (first on line {self.gravity[1].line})")
        self.gravity = ([self.number(record, w, "gravity") for w in words], record)
