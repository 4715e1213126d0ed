"""Scene sections checked against the section schemas of the elements that use them, the
reference configurations an element refuses named by element, and the units of tunable keys
(the scene's `scene_key`, which the FMU's parameters take)."""

import types

import pytest

from flexure.core import SceneError, build_model
from flexure.core.elements import ELEMENT_TYPES, SchemaKey, plspring, register
from flexure.core.elements.protocol import REQUIRED, property_names
from flexure.core.scene.building import scene_key


def planar(sections, elements, nodes=None):
    """A planar scene of two translational nodes "1" (fixed) and "2" 0.1 m to its right (plus
    `nodes`), with the given sections and elements."""
    return {"sections": sections, "elements": elements,
            "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                      "2": {"position": [0.1, 0.0], "fixed": ["x", "y"]}, **(nodes or {})}}


def refused(data):
    """The message of the SceneError that building `data` (source "s.toml") raises."""
    with pytest.raises(SceneError) as error:
        build_model(data, source="s.toml", check=False)
    return str(error.value)


SPRING = {"type": "PLSPRING", "nodes": ["1", "2"], "section": "soft"}
TRUSS = {"type": "PLTRUSS", "nodes": ["1", "2"], "section": "bar"}


def test_a_key_no_user_of_the_section_reads_is_unknown():
    assert refused(planar({"soft": {"kx": 1.0, "EA": 5.0}}, {"s": SPRING})) == (
        "s.toml: sections.soft.EA: unknown key; expected one of cx, cy, kx, ky")
    # a truss reads no bending stiffness; its section takes E, width, height and rho, which
    # derive EA, A and rho_A
    assert refused(planar({"bar": {"EA": 1.0, "EI": 5.0}}, {"t": TRUSS})) == (
        "s.toml: sections.bar.EI: unknown key; expected one of E, EA, EdA, height, rho, "
        "rho_A, width, yield_stress")


def test_a_section_takes_the_keys_of_every_element_that_uses_it():
    section = {"kx": 100.0, "cy": 0.5, "E": 2e11, "width": 0.01, "height": 0.001}
    model = build_model(planar({"both": section},
                               {"s": dict(SPRING, section="both"),
                                "t": dict(TRUSS, section="both")}), check=False)
    props = {group.kind.type_name: {k: v.tolist() for k, v in group.properties.items()}
             for group in model.groups}
    assert props["PLSPRING"] == {"kx": [100.0], "ky": [0.0], "cx": [0.0], "cy": [0.5]}
    assert props["PLTRUSS"]["EA"] == [pytest.approx(2e6, rel=1e-15)]
    assert props["PLTRUSS"]["A"] == [pytest.approx(1e-5, rel=1e-15)]


def test_a_section_no_element_uses_takes_any_key_of_its_dimension():
    build_model(planar({"spare": {"kx": 1.0, "EI": 2.0, "rho": 7850.0}}, {}), check=False)
    assert refused(planar({"spare": {"kz": 1.0}}, {})) == (  # a 3-D key is none of 2-D's
        "s.toml: sections.spare.kz: unknown key; expected one of E, EA, EI, EdA, EdI, GAs, cx, "
        "cy, height, kx, ky, rho, rho_A, width, yield_stress")


@pytest.mark.parametrize("value, message", [
    ("stiff", "s.toml: sections.soft.kx: expected a number, got 'stiff'"),
    (-1.0, "s.toml: sections.soft.kx: expected a value >= 0.0, got -1.0"),
    (True, "s.toml: sections.soft.kx: expected a number, got True"),
])
def test_a_value_of_the_wrong_type_or_sign_is_named(value, message):
    assert refused(planar({"soft": {"kx": value}}, {"s": SPRING})) == message


def test_a_dimension_must_be_positive():
    assert refused(planar({"bar": {"E": 1.0, "width": 0.0, "height": 1.0}}, {"t": TRUSS})) == (
        "s.toml: sections.bar.width: expected a value > 0, got 0.0")


@pytest.fixture
def required_spring():
    """PLSPRING's maths registered as "REQSPRING", whose section must give kx."""
    schema = (SchemaKey("kx", "N/m", "stiffness along x", default=REQUIRED),
              *plspring.section_schema[1:])
    kind = types.ModuleType("required_spring")
    for attribute in dir(plspring):
        if not attribute.startswith("__"):
            setattr(kind, attribute, getattr(plspring, attribute))
    kind.type_name, kind.section_schema = "REQSPRING", schema
    kind.properties = property_names(schema)
    register(kind)
    yield kind
    ELEMENT_TYPES.pop("REQSPRING")


def test_a_required_key_left_out_is_named(required_spring):
    element = dict(SPRING, type="REQSPRING")
    assert refused(planar({"soft": {"ky": 1.0}}, {"s": element})) == (
        "s.toml: sections.soft.kx: missing: a REQSPRING needs it (stiffness along x, N/m)")
    model = build_model(planar({"soft": {"kx": 3.0}}, {"s": element}), check=False)
    assert model.groups[0].properties["kx"] == 3.0


def test_mistakes_of_several_sections_are_reported_together():
    message = refused(planar({"soft": {"kx": "a"}, "bar": {"EI": 1.0}},
                             {"s": SPRING, "t": TRUSS}))
    assert message == ("s.toml: 2 mistakes:\n"
                       "  sections.soft.kx: expected a number, got 'a'\n"
                       "  sections.bar.EI: unknown key; expected one of E, EA, EdA, height, "
                       "rho, rho_A, width, yield_stress")


def test_coincident_nodes_are_refused_by_a_truss_and_taken_by_a_spring():
    nodes = {"3": {"position": [0.0, 0.0]}}
    data = planar({"bar": {"EA": 1.0}, "soft": {"kx": 1.0, "ky": 1.0}},
                  {"t": dict(TRUSS, nodes=["1", "3"]), "u": dict(TRUSS, nodes=["3", "1"])},
                  nodes)
    assert refused(data) == ("s.toml: 2 mistakes:\n"
                             "  elements.t.nodes: zero-length element: its end nodes coincide "
                             "(0 m)\n"
                             "  elements.u.nodes: zero-length element: its end nodes coincide "
                             "(0 m)")
    data["elements"] = {"s": dict(SPRING, nodes=["1", "3"], released=["e1", "e2"])}
    (group,) = build_model(data).groups
    assert group.reference["offset"].tolist() == [[0.0, 0.0]]


def test_a_principal_axis_along_its_beam_is_named():
    data = {"scene": {"dimension": 3}, "sections": {"s": {"EA": 1.0}},
            "nodes": {"a": {"position": [0.0, 0.0, 0.0]}, "ra": {"rotation": [0.0, 0.0, 0.0]},
                      "b": {"position": [0.0, 0.0, 0.2]}, "rb": {"rotation": [0.0, 0.0, 0.0]}},
            "elements": {"beam": {"type": "BEAM", "nodes": ["a", "ra", "b", "rb"],
                                  "section": "s", "y_axis": [0.0, 0.0, -3.0]}}}
    assert refused(data) == ("s.toml: elements.beam.y_axis: the principal axis [0.0, 0.0, -3.0] "
                             "lies along the beam (or is zero)")


@pytest.mark.parametrize("key, unit", [
    ("sections.leaf.EdI", "N.m2.s"), ("sections.leaf.EA", "N"), ("sections.soft.kx", "N/m"),
    ("sections.soft.cz", "N.s/m"), ("sections.leaf.E", "Pa"), ("sections.leaf.rho", "kg/m3"),
    ("sections.rod.rho_Iy", "kg.m"), ("sections.rod.beta", "s"), ("nodes.3.mass", "kg"),
    ("nodes.a.b.inertia", "kg.m2"), ("nodes.2.moment", "N.m"),
])
def test_the_unit_of_a_scene_key_is_its_schemas(key, unit):
    assert scene_key(key).unit == unit


@pytest.mark.parametrize("key", ["sections.leaf.hieght", "nodes.3.position", "scene.name",
                                 "elements.s.released", "sections", "nodes.mass"])
def test_keys_without_a_schema_have_none(key):
    assert scene_key(key) is None


def test_damping_keys_are_marked_in_the_schemas():
    assert {name for name in ("EdA", "EdI", "GdIt", "cx", "beta", "EA", "kx", "rho_A")
            if scene_key(f"sections.s.{name}").damping} == {"EdA", "EdI", "GdIt", "cx", "beta"}


SPRING_SCENE = """
[scene]
name = "spring_on_ground"
dimension = 2

[sections.soft]
kx = 800.0
ky = 1800.0
cx = 4.0

[nodes.g]
position = [0.0, 0.0]
fixed = ["x", "y"]

[nodes.m]
position = [0.0, 0.0]
mass = 2.0

[elements.s]
type = "PLSPRING"
nodes = ["g", "m"]
section = "soft"
released = ["e1", "e2"]

[inputs.F]
node = "m"
coordinate = "x"

[outputs.x]
node = "m"
coordinate = "x"
"""


def test_the_fmu_parameters_take_their_units_and_bounds_from_the_schemas():
    """A spring scene's FMU slave: kx in N/m, cx in N.s/m (a damping: 0 is valid, where a
    stiffness must be > 0), the node mass in kg."""
    from flexure.fmu.scene_slave import SceneSlave

    class spring_on_ground(SceneSlave):
        scene_toml = SPRING_SCENE
        tunable = ("sections.soft.kx", "sections.soft.cx", "nodes.m.mass")

    slave = spring_on_ground(instance_name="a")
    units = {v.name: v.unit for v in slave.vars.values() if v.name in slave.tunable}
    assert units == {"sections.soft.kx": "N/m", "sections.soft.cx": "N.s/m",
                     "nodes.m.mass": "kg"}
    assert slave.check_value("sections.soft.cx", 0.0) is None
    assert slave.check_value("sections.soft.kx", 0.0) == (
        "sections.soft.kx = 0.0: expected a finite number > 0")
    assert slave.check_value("nodes.m.mass", -1.0) == (
        "nodes.m.mass = -1.0: expected a finite number > 0")


def test_the_scene_format_lists_every_element_and_its_section_keys():
    """docs/scene-format.md's table of section keys against the registered schemas."""
    from pathlib import Path

    text = (Path(__file__).parents[1] / "docs" / "scene-format.md").read_text()
    rows = {line.split("|")[1].strip(): line for line in text.splitlines()
            if line.startswith("| ") and line.count("|") == 3}
    for name, kind in ELEMENT_TYPES.items():
        missing = [key.name for key in kind.section_schema if f"`{key.name}`" not in rows[name]]
        assert not missing, f"docs/scene-format.md: {name} lacks {missing}"
