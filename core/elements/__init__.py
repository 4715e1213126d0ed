"""The element registry: one module per element type, looked up by its SPACAR name.

An element module follows the element protocol (`protocol`: its nodes, deformations with
their derivatives, stiffness, damping, mass, section schema and compiled kernels, each function
working on all elements of the type at once) and is registered below with `register`, which
checks it and refuses a malformed one with an `ElementProtocolError` naming the module and
what is missing. The scene loader reads the registered types (their nodes, deformations and
section schemas); nothing else names them. Adding an element is its module, one line below
and its test.

The normalisation constraint of 3-D rotational nodes (`euler`) and the rigid-body inertia of
3-D rotational nodes (`rotary_inertia`) are pseudo-elements for the engine, not registered:
the scene builder adds them, a scene cannot name them.

The arrays an element's functions return may be shared between calls (a constant second
derivative of the inertia points is returned from the reference data, read-only): callers read
them and never modify them in place.
"""

from . import beam, plbeam, plspring, pltruss, spring, truss
from .protocol import ElementProtocolError, SchemaKey, check_element

ELEMENT_TYPES = {}


def register(kind):
    """Add the element module `kind` to the registry under its `type_name`, once it has been
    checked against the element protocol (ElementProtocolError naming the module and every
    missing or malformed attribute). Returns `kind`."""
    check_element(kind, ELEMENT_TYPES.values())
    ELEMENT_TYPES[kind.type_name] = kind
    return kind


def element_type(name):
    """The element module for a SPACAR element name such as "PLBEAM" (KeyError if unknown)."""
    return ELEMENT_TYPES[name.upper()]


def section_keys():
    """{name: SchemaKey} of every section key a registered element reads (one unit per name:
    `register` refuses an element that reads a key in another unit)."""
    return {key.name: key for kind in ELEMENT_TYPES.values() for key in kind.section_schema}


for _kind in (pltruss, plbeam, truss, beam, plspring, spring):
    register(_kind)

__all__ = ["ELEMENT_TYPES", "ElementProtocolError", "SchemaKey", "element_type", "register",
           "section_keys"]
