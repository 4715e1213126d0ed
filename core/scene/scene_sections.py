"""The [sections] of a scene, each checked against the section schemas of the elements that
use it.

A section takes the keys its elements read (each element module's `section_schema`: unit,
default, meaning) and, where those elements read a property its shape and material derive
(`sections.PLANAR`, `sections.SPATIAL`), the shape and material keys (E, width, rho, ...). A key
none of them reads is refused as unknown, a key they require and the section leaves out as
missing, a value that is no number (or negative, or a dimension not above zero) as such, each
naming the file, the section and the key. A section no element uses is checked against every
element type of the scene's dimension.
"""

import math

from ..elements import ELEMENT_TYPES, section_keys
from .sections import CALCULATORS


def section_users(elements, dimension):
    """{section name: [element modules]}: the types of the scene's [elements] (a raw table)
    that name a section. Entries that are malformed are left out here; the elements' own
    checks report them."""
    users = {}
    for element in elements.values() if isinstance(elements, dict) else ():
        if not isinstance(element, dict):
            continue
        type_name, section = element.get("type"), element.get("section")
        if not (isinstance(type_name, str) and isinstance(section, str)):
            continue
        kind = ELEMENT_TYPES.get(type_name.upper())
        if kind is not None and kind.dimension == dimension and kind not in users.get(
                section, []):
            users.setdefault(section, []).append(kind)
    return users


def section_schema(kinds, dimension):
    """({name: SchemaKey} a section used by the element modules `kinds` takes, the
    `SectionCalculator` that derives some of their properties, or None)."""
    schema = {key.name: key for kind in kinds for key in kind.section_schema}
    calculator = CALCULATORS.get(dimension)
    if calculator is None or not calculator.outputs & schema.keys():
        return schema, None
    schema.update({key.name: key for key in calculator.inputs})
    return schema, calculator


def section_key(name):
    """The SchemaKey of a section key `name` (an element property or a shape or material key
    of either dimension), or None."""
    keys = {key.name: key for calculator in CALCULATORS.values() for key in calculator.inputs}
    return section_keys().get(name, keys.get(name))


class SectionBuilding:
    """The scene builder's part for [sections]; uses the builder's `dimension` and its checked
    reading of values (`SceneReader`)."""

    def build_sections(self, sections, elements):
        """{name: {key: value}} of the scene's [sections] (SI units, derived properties
        added); `elements` is the scene's raw [elements] table, which says who uses each."""
        users = section_users(elements, self.dimension)
        result = {}
        for name, section in sections.items():
            with self.entry():  # collected, so every entry is checked
                result[name] = self.build_section(name, section, users.get(name, []))
        self.raise_problems()
        return result

    def build_section(self, name, section, kinds):
        """One [sections.NAME] for the element modules `kinds` that use it (every type of the
        scene's dimension when none does): its properties, SI units."""
        key = f"sections.{name}"
        section = self.table(key, section)
        schema, calculator = section_schema(kinds or [
            k for k in ELEMENT_TYPES.values() if k.dimension == self.dimension], self.dimension)
        self.check_keys(key, section, {k for k, entry in schema.items() if entry.given})
        values = {k: self.number(f"{key}.{k}", v, minimum=0.0, positive=schema[k].positive)
                  for k, v in section.items()}
        if calculator is not None:
            try:
                values = calculator.derive(values)
            except ValueError as error:
                self.fail(key, str(error))
        for kind in kinds:
            for entry in kind.section_schema:
                if entry.required and entry.name not in values:
                    self.fail(f"{key}.{entry.name}", f"missing: a {kind.type_name} needs it "
                                                     f"({entry.meaning}, {entry.unit})")
        return self.finite_section(key, values)

    def finite_section(self, key, values):
        """Refuse a section whose derived properties (EA = E w h, ...) over- or underflow."""
        for k, v in values.items():
            if not math.isfinite(v):
                self.fail(key, f"the section's {k} comes out as {v!r} from its numbers; check "
                               "their magnitudes (SI units)")
        return values
