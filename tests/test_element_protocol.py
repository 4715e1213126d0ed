"""The element protocol (core/elements/protocol.py), checked when an element registers: every
registered element follows it, a malformed one is refused with one message that names the module
and each problem, and the registry is left as it was."""

import types

import pytest

from flexure.core.elements import (
    ELEMENT_TYPES,
    ElementProtocolError,
    SchemaKey,
    plspring,
    register,
)
from flexure.core.elements.protocol import element_problems, property_names


def copy_of(module, name="test_element", **changes):
    """A new module with the public attributes of `module`, then `changes` (None: delete)."""
    copy = types.ModuleType(name)
    for attribute in dir(module):
        if not attribute.startswith("__"):
            setattr(copy, attribute, getattr(module, attribute))
    for attribute, value in changes.items():
        if value is None:
            delattr(copy, attribute)
        else:
            setattr(copy, attribute, value)
    return copy


@pytest.mark.parametrize("name", sorted(ELEMENT_TYPES))
def test_every_registered_element_follows_the_protocol(name):
    assert element_problems(ELEMENT_TYPES[name]) == []


def test_a_copy_of_an_element_under_a_new_name_registers():
    kind = copy_of(plspring, type_name="MYSPRING")
    try:
        assert register(kind) is kind and ELEMENT_TYPES["MYSPRING"] is kind
    finally:
        ELEMENT_TYPES.pop("MYSPRING", None)


def test_a_malformed_element_is_refused_naming_the_module_and_each_problem():
    before = dict(ELEMENT_TYPES)
    kind = copy_of(plspring, "broken_spring", type_name="BROKEN", deformations=None,
                   node_roles=("p",), coordinates_per_element=6,
                   deformation_stiffness={"e1": "kx", "e2": "k_y"},
                   deformations_entry=plspring.deformations_kernel, damping=0.5)
    with pytest.raises(ElementProtocolError) as error:
        register(kind)
    assert str(error.value) == (
        "element module broken_spring does not follow the element protocol "
        "(core/elements/protocol.py):\n"
        "  node_roles has 1 entries for 2 node_kinds\n"
        "  coordinates_per_element = 6, but its node_kinds have 4 coordinates in 2-D\n"
        "  deformation_stiffness uses ['k_y'], which section_schema does not declare\n"
        "  deformations is missing (a function)\n"
        "  damping = 0.5: expected a function\n"
        f"  deformations_entry = {plspring.deformations_kernel!r}: expected a C entry with "
        "the engine's signature, entries.deformations_entry(deformations_kernel)")
    assert isinstance(error.value, TypeError)
    assert ELEMENT_TYPES == before


@pytest.mark.parametrize("changes, problem", [
    ({"type_name": "plspring2"}, "type_name = 'plspring2': expected an upper-case name"),
    ({"dimension": 4}, "dimension = 4: expected 2 or 3"),
    ({"node_kinds": ("translational", "elastic")}, "node_kinds = ('translational', "
                                                   "'elastic'): expected a non-empty tuple"),
    ({"deformation_names": ("e1", "e1")}, "expected a non-empty tuple of distinct names"),
    ({"deformation_stiffness": {"e1": "kx"}}, "deformation_stiffness names ['e1'], expected "
                                              "every deformation ['e1', 'e2']"),
    ({"inertia_point_kinds": ("position", "corner")}, "inertia_point_kinds = ('position', "
                                                      "'corner'): expected a tuple of"),
    ({"section_schema": ("kx", "ky")}, "section_schema = ('kx', 'ky'): expected a tuple of "
                                       "SchemaKey"),
    ({"section_schema": (*plspring.section_schema, plspring.section_schema[0])},
     "section_schema lists 'kx' 2 times"),
    ({"properties": ("kx", "ky")}, "properties = ('kx', 'ky'): expected "
                                   "property_names(section_schema)"),
    ({"REFERENCE_WIDTH": 0}, "REFERENCE_WIDTH = 0: expected an int >= 1"),
    ({"inertia_entry": None}, "inertia_entry is missing (a C entry"),
    ({"needs_orientation": "yes"}, "needs_orientation = 'yes': expected True or False"),
    ({"reference_problems": []}, "reference_problems = []: expected a function"),
    ({"reference_properties": ("Ip_A",)}, "reference_properties = ('Ip_A',): expected a "
                                          "tuple of the section keys"),
])
def test_each_malformed_attribute_is_named(changes, problem):
    with pytest.raises(ElementProtocolError) as error:
        register(copy_of(plspring, "odd_spring", **{"type_name": "ODDSPRING", **changes}))
    assert "element module odd_spring does not follow the element protocol" in str(error.value)
    assert problem in str(error.value)
    assert "ODDSPRING" not in ELEMENT_TYPES and "plspring2" not in ELEMENT_TYPES


def test_a_type_name_is_registered_once():
    with pytest.raises(ElementProtocolError, match="type_name 'PLSPRING' is already registered "
                                                   "by flexure.core.elements.plspring"):
        register(copy_of(plspring))


def test_a_section_key_has_one_unit_across_the_elements():
    """A new element may read a key another element reads (EA, kx) only in the same unit."""
    schema = (SchemaKey("kx", "N.m/rad", "a rotational stiffness"), *plspring.section_schema[1:])
    kind = copy_of(plspring, type_name="TWISTSPRING", section_schema=schema,
                   properties=property_names(schema))
    with pytest.raises(ElementProtocolError, match=r"section key 'kx' in N\.m/rad, but "
                                                   r"PLSPRING reads it in N/m"):
        register(kind)
