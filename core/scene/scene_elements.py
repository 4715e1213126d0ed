"""The [elements] of a scene: each element's type, nodes, section, principal axis and the
status of each deformation (zero, released or a DOF), split into segments where it asks
(`meshing`), gathered into one ElementGroup per type with its reference data."""

import numpy as np

from ..elements import ELEMENT_TYPES
from ..model import DOF, RELEASED, ZERO, ElementGroup
from .meshing import segment_count, split
from .scene_reader import show


class ElementBuilding:
    """The scene builder's part for [elements]; uses the builder's nodes (`node`,
    `node_coordinates`, `initial`), sections and `dimension`."""

    def build_elements(self, elements):
        by_type = {}
        deformation_names, deformation_status = [], []
        for name, element in elements.items():
            with self.entry():  # collected, so every entry is checked
                self.build_element(name, element, elements, by_type, deformation_names,
                                   deformation_status)
        self.raise_problems()
        return self.element_groups(by_type), deformation_names, deformation_status

    def build_element(self, name, element, elements, by_type, deformation_names,
                      deformation_status):
        """One [elements.NAME], its segments when meshed, added to by_type and the lists."""
        key = f"elements.{name}"
        element = self.table(key, element)
        allowed = {"type", "nodes", "section", "released", "dof", "segments"}
        self.check_keys(key, element, allowed | ({"y_axis"} if self.dimension == 3 else set()))
        type_name = element.get("type")
        if not isinstance(type_name, str) or type_name.upper() not in ELEMENT_TYPES:
            self.fail(f"{key}.type", f"unknown element type {type_name!r}; expected one of "
                                     f"{', '.join(ELEMENT_TYPES)}")
        kind = ELEMENT_TYPES[type_name.upper()]
        if kind.dimension != self.dimension:
            self.fail(f"{key}.type", f"{kind.type_name} is a {kind.dimension}-D element in a "
                                     f"{self.dimension}-D scene")
        nodes = self.element_nodes(key, element, kind)
        count = segment_count(self, key, element)
        for piece, table in split(self, name, element, kind, nodes, count):
            if piece != name and piece in elements:
                self.fail(f"{key}.segments", f"the segment {piece!r} has the name of an "
                                             "element of the scene; rename that element")
            self.add_element(key, piece, table, kind, by_type, deformation_names,
                             deformation_status)

    def element_nodes(self, key, element, kind):
        """The element's node names, each checked to exist and to be of the kind it needs."""
        nodes = element.get("nodes")
        if not isinstance(nodes, list) or len(nodes) != len(kind.node_kinds):
            self.fail(f"{key}.nodes", f"{kind.type_name} expects {len(kind.node_kinds)} nodes "
                                      f"({', '.join(kind.node_kinds)}), got {nodes!r}")
        return [self.node(f"{key}.nodes[{i}]", n, k)
                for i, (n, k) in enumerate(zip(nodes, kind.node_kinds, strict=True))]

    def add_element(self, key, name, element, kind, by_type, deformation_names,
                    deformation_status):
        """Add element `name` (the scene's element at `key`, or one of its segments) to its
        type's entry of by_type (its coordinates, section properties, principal axis) and its
        deformations, with their status, to the two lists."""
        nodes = self.element_nodes(key, element, kind)
        index = [i for n in nodes for i in self.node_coordinates[n].values()]
        section_name = element.get("section")
        if section_name is None:
            self.fail(key, "element without a section: add section = \"NAME\"")
        if not isinstance(section_name, str) or section_name not in self.sections:
            self.fail(f"{key}.section", f"unknown section {show(section_name)}; expected one "
                                        f"of {', '.join(self.sections) or 'none declared'}")
        section = self.sections[section_name]
        released = self.names(f"{key}.released", element.get("released", []),
                              kind.deformation_names)
        dofs = self.names(f"{key}.dof", element.get("dof", []), kind.deformation_names)
        for both in set(released) & set(dofs):
            self.fail(key, f"deformation {both!r} is both released and a DOF")
        for deformation in released:
            needed = kind.deformation_stiffness[deformation]
            if section.get(needed, 0.0) <= 0.0:
                self.fail(f"{key}.released",
                          f"released deformation {deformation!r} needs a stiffness: "
                          f"section {section_name!r} has no {needed} > 0")
        entry = by_type.setdefault(kind.type_name, {"kind": kind, "names": [], "coords": [],
                                                    "defs": [], "props": [], "axes": []})
        if getattr(kind, "needs_orientation", False):
            if "y_axis" not in element:
                self.fail(key, f"a {kind.type_name} needs its principal axis: add "
                               "y_axis = [x, y, z]")
            entry["axes"].append(self.vector(f"{key}.y_axis", element["y_axis"], 3))
        elif "y_axis" in element:
            self.fail(f"{key}.y_axis", f"a {kind.type_name} has no principal axis")
        entry["names"].append(name)
        entry["coords"].append(index)
        entry["props"].append({key.name: section.get(key.name, key.default)
                               for key in kind.section_schema})
        start = len(deformation_names)
        entry["defs"].append(list(range(start, start + len(kind.deformation_names))))
        for deformation in kind.deformation_names:
            deformation_names.append(f"{name}.{deformation}")
            deformation_status.append(
                DOF if deformation in dofs else RELEASED if deformation in released else ZERO)

    def element_groups(self, by_type):
        """One ElementGroup per element type, with its reference data from the initial
        coordinates; an element whose reference configuration its type cannot take (its
        `reference_problems`: a zero length, a principal axis along a beam) refused by name."""
        groups = []
        for entry in by_type.values():
            kind = entry["kind"]
            coords = np.array(entry["coords"], dtype=int)
            x0 = np.array(self.initial)[coords]
            orientation = {"y_axis": np.array(entry["axes"])} if entry["axes"] else {}
            check = getattr(kind, "reference_problems", None)
            for i, key, message in check(x0, **orientation) if check else ():
                with self.entry():  # collected, so every such element is named
                    self.fail(f"elements.{entry['names'][i]}.{key}", message)
            self.raise_problems()
            props = {p: np.array([v[p] for v in entry["props"]]) for p in kind.properties}
            section = getattr(kind, "reference_properties", ())
            if section:  # section data the deformations depend on (a BEAM's Ip_A)
                orientation["properties"] = {key: props[key] for key in section}
            reference = kind.reference(x0, **orientation)
            groups.append(ElementGroup(kind=kind, names=tuple(entry["names"]),
                                       coordinate_index=coords,
                                       deformation_index=np.array(entry["defs"], dtype=int),
                                       reference=reference, properties=props))
        return groups
