"""Complete the modelDescription.xml that pythonfmu 0.7.0 writes, so `fmpy validate` is clean.

pythonfmu leaves out what FMI 2.0 asks for beyond the variable list: units (it has no unit
attribute; `UnitReal` adds one), <UnitDefinitions>, <ModelStructure><InitialUnknowns>, and
default variabilities and initials. `fix_model_description` adds them:

- <UnitDefinitions> with one <Unit> (and its SI <BaseUnit> exponents where known) for every
  unit a <Real> uses, placed right after <CoSimulation> as the schema orders it;
- variability: parameters "fixed", Real inputs/outputs/locals "continuous", others "discrete";
- initial: "exact" on parameters;
- <InitialUnknowns>: every output whose initial is approx or calculated (or absent), and every
  calculatedParameter, in value-reference order (FMI 2.0 section 2.2.8);
- variableNamingConvention "flat": flexure's variable names follow the scene's keys
  ("sections.leaf.EdA", "nodes.3.mass"), which the structured grammar rejects;
- on request, a unit for Real variables the slave declared without one (`units`), and the
  FMU's Python requirements (`flexure.fmu.requirements`): appended to the description
  attribute, which hosts show (`fmpy info`), and listed in <VendorAnnotations><Tool
  name="flexure"><PythonRequirements>, the place FMI 2.0 gives a tool's own data (fmpy's
  schema validation accepts it).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names for the annotations only
    from .requirements import Requirements

# SI base-unit exponents (kg, m, s, A, K, mol, cd, rad) of the units flexure declares.
BASE_UNITS = {
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "s": {"s": 1},
    "1/s": {"s": -1},
    "kg": {"kg": 1},
    "kg.m2": {"kg": 1, "m": 2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "N.s": {"kg": 1, "m": 1, "s": -1},
    "N.m2": {"kg": 1, "m": 3, "s": -2},
    "N.m2.s": {"kg": 1, "m": 3, "s": -1},
    "kg/m3": {"kg": 1, "m": -3},
    "N/m": {"kg": 1, "s": -2},
    "N.s/m": {"kg": 1, "s": -1},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "kg/m": {"kg": 1, "m": -1},
    "kg.m": {"kg": 1, "m": 1},
    "m2": {"m": 2},
    "m3": {"m": 3},
    "1": {},
    "A": {"A": 1},  # voice-coil actuators: coil current, drive signal, Km, R, L
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "N/A": {"kg": 1, "m": 1, "s": -2, "A": -1},
    "N.m/A": {"kg": 1, "m": 2, "s": -2, "A": -1},
    "A/V": {"kg": -1, "m": -2, "s": 3, "A": 2},
    "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "H": {"kg": 1, "m": 2, "s": -2, "A": -2},
}

REQUIREMENTS_FILE = "resources/requirements.txt"

# The element order of fmiModelDescription (FMI 2.0, fmi2ModelDescription.xsd).
_ORDER = ["ModelExchange", "CoSimulation", "UnitDefinitions", "TypeDefinitions",
          "LogCategories", "DefaultExperiment", "VendorAnnotations", "ModelVariables",
          "ModelStructure"]


def fix_model_description(xml_text: str | bytes, *,
                          requirements: Requirements | None = None,
                          units: Mapping[str, str] | None = None) -> bytes:
    """Return the completed modelDescription.xml text (see the module docstring).

    Parameters
    ----------
    xml_text : str or bytes
        The modelDescription.xml pythonfmu wrote.
    requirements : flexure.fmu.requirements.Requirements, optional
        The FMU's Python requirements, to describe.
    units : mapping of str to str, optional
        {variable name: unit} for Real variables that have none (SI, as FMI writes it:
        "m", "N", "N.m", "rad/s").

    Returns
    -------
    bytes
        UTF-8 XML with declaration.
    """
    root = ET.fromstring(xml_text)
    root.set("variableNamingConvention", "flat")
    variables = root.find("ModelVariables").findall("ScalarVariable")
    extra = dict(units or {})
    units = []
    for variable in variables:
        causality = variable.get("causality", "local")
        kind = next(iter(variable))
        if variable.get("variability") is None:
            if causality in ("parameter", "calculatedParameter"):
                variability = "fixed"
            elif kind.tag == "Real":
                variability = "continuous"
            else:
                variability = "discrete"
            variable.set("variability", variability)
        if causality == "parameter" and variable.get("initial") is None:
            variable.set("initial", "exact")
        if kind.tag == "Real" and not kind.get("unit") and variable.get("name") in extra:
            kind.set("unit", extra[variable.get("name")])
        unit = kind.get("unit")
        if unit and unit not in units:
            units.append(unit)

    for old in root.findall("UnitDefinitions"):
        root.remove(old)
    if units:
        definitions = ET.Element("UnitDefinitions")
        for unit in units:
            element = ET.SubElement(definitions, "Unit", name=unit)
            if unit in BASE_UNITS:
                ET.SubElement(element, "BaseUnit",
                              {k: str(v) for k, v in BASE_UNITS[unit].items()})
        _insert_in_order(root, definitions)

    structure = root.find("ModelStructure")
    if structure is None:
        structure = ET.SubElement(root, "ModelStructure")
    for old in structure.findall("InitialUnknowns"):
        structure.remove(old)
    initial_unknowns = [
        index for index, variable in enumerate(variables, start=1)
        if (variable.get("causality") == "output"
            and variable.get("initial") in (None, "approx", "calculated"))
        or variable.get("causality") == "calculatedParameter"
    ]
    if initial_unknowns:
        element = ET.Element("InitialUnknowns")
        for index in initial_unknowns:
            ET.SubElement(element, "Unknown", index=str(index))
        # Schema order inside ModelStructure: Outputs, Derivatives, InitialUnknowns.
        structure.append(element)
    if requirements is not None:
        _describe_requirements(root, requirements)
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def _describe_requirements(root, requirements):
    """The requirements in the description attribute and in a flexure VendorAnnotation."""
    pins = [f"Python >= {requirements.python}"] if requirements.python else []
    pins += [item.pin() for item in requirements.items]
    description = (root.get("description") or "").rstrip(". ")
    root.set("description", f"{description}{'. ' if description else ''}Needs in the host's "
                            f"Python ({REQUIREMENTS_FILE}): {', '.join(pins)}")
    for old in root.findall("VendorAnnotations"):
        root.remove(old)
    annotations = ET.Element("VendorAnnotations")
    tool = ET.SubElement(annotations, "Tool", name="flexure")
    listed = ET.SubElement(tool, "PythonRequirements", file=REQUIREMENTS_FILE)
    if requirements.python:
        listed.set("python", f">={requirements.python}")
    for item in requirements.items:
        entry = ET.SubElement(listed, "Requirement", distribution=item.distribution,
                              version=item.version, module=item.module)
        if item.minimum:
            entry.set("minimum", item.minimum)
    _insert_in_order(root, annotations)


def _insert_in_order(root, element):
    rank = _ORDER.index(element.tag)
    for position, child in enumerate(root):
        if child.tag in _ORDER and _ORDER.index(child.tag) > rank:
            root.insert(position, element)
            return
    root.append(element)
