"""Meshing: an element with `segments = n` split into n beams, against analytic frequencies,
against the same refinement written out by hand, and its error paths."""

import copy
import math

import numpy as np
import pytest

from flexure.core import build_model, load_scene, natural_frequencies
from flexure.core.errors import SceneError
from flexure.core.scene.building import parse_toml, scene_path

# a 0.1 m steel leaf, 18 mm x 0.5 mm: EI = 0.039375 N m^2, rho A = 0.07065 kg/m
LENGTH, EI, RHO_A = 0.1, 2.1e11 * 0.018 * 0.0005 ** 3 / 12, 7850.0 * 0.018 * 0.0005
# clamped-free Euler-Bernoulli beam: omega_i = (beta_i L)^2 sqrt(EI / (rho A L^4))
BETA_L = (1.8751040687119611, 4.6940911329741746, 7.8547574382376126)


def cantilever(segments, dimension=2):
    """A clamped leaf along x with a free tip; its elongation prescribed zero, bending
    released (in space: bending about z', sideways along y, and the other bending and
    torsion released too, so that the tip is free in every direction but along the leaf)."""
    section = {"E": 2.1e11, "rho": 7850.0, "width": 0.018, "height": 0.0005}
    if dimension == 2:
        nodes = {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                 "2": {"angle": 0.0, "fixed": ["phi"]},
                 "3": {"position": [LENGTH, 0.0], "dof": ["y"]},
                 "4": {"angle": 0.0, "dof": ["phi"]}}
        leaf = {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"], "section": "leaf",
                "released": ["e2", "e3"], "segments": segments}
    else:
        section["nu"] = 0.3
        nodes = {"1": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
                 "2": {"rotation": [0.0, 0.0, 0.0], "fixed": True},
                 "3": {"position": [LENGTH, 0.0, 0.0]},
                 "4": {"rotation": [0.0, 0.0, 0.0]}}
        # y' along global y: bending e5, e6 (about z') is the sideways motion along y
        leaf = {"type": "BEAM", "nodes": ["1", "2", "3", "4"], "section": "leaf",
                "y_axis": [0.0, 1.0, 0.0], "dof": ["e2", "e3", "e4", "e5", "e6"],
                "segments": segments}
    return build_model({"scene": {"name": f"leaf_{dimension}d_{segments}",
                                  "dimension": dimension},
                        "sections": {"leaf": section}, "nodes": nodes,
                        "elements": {"leaf": leaf}}, source="test_meshing")


def analytic_hz(i):
    return BETA_L[i] ** 2 * math.sqrt(EI / (RHO_A * LENGTH ** 4)) / (2.0 * math.pi)


def test_a_meshed_leaf_converges_to_the_analytic_bending_frequencies():
    """The first three frequencies of the clamped leaf in 1, 2, 4, 8, 16 segments approach the
    Euler-Bernoulli ones from above, the error falling as h^4 (Hermite cubics with their
    consistent mass) once the mesh resolves the mode."""
    counts = (1, 2, 4, 8, 16)
    errors = []
    for n in counts:
        model = cantilever(n)
        assert model.ndof == 2 * n  # the tip's y and phi, then e2, e3 of n - 1 segments
        f = natural_frequencies(model, 3 if n > 1 else 2).frequencies_hz
        errors.append([f[i] / analytic_hz(i) - 1.0 for i in range(f.size)])
    first = np.array([e[0] for e in errors])
    assert np.all(first > 0) and np.all(np.diff(first) < 0)
    orders = np.log2(first[1:-1] / first[2:])  # skip the finest: round-off nears
    np.testing.assert_allclose(orders, 4.0, atol=0.2)
    assert first[-1] < 2e-7  # 1.3e-7 measured at 16 segments
    third = np.array([e[2] for e in errors[1:]])
    assert np.all(np.diff(third) < 0) and third[-1] < 1e-4


def test_a_meshed_spatial_leaf_bends_like_the_planar_one():
    """The spatial BEAM leaf in 8 segments: its first sideways bending frequency matches the
    analytic one within the section's rotational inertia, (h / l)^2 small (1e-4)."""
    model = cantilever(8, dimension=3)
    assert model.ndof == 5 * 8
    frequencies = natural_frequencies(model).frequencies_hz
    nearest = frequencies[np.argmin(np.abs(frequencies - analytic_hz(0)))]
    assert nearest == pytest.approx(analytic_hz(0), rel=1e-4)


def meshed_stage(n):
    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    for side in ("left", "right"):
        data["elements"][f"leaf_{side}"]["segments"] = n
    return build_model(data, source="meshed")


def test_segments_give_the_model_written_out_by_hand():
    """Segments (interior nodes dependent, the segments' deformations DOFs) and the same
    refinement by hand (interior coordinates DOFs, deformations released) are one mechanism
    in two sets of coordinates: the same DOF count and natural frequencies. By hand:
    examples/benchmarks/stage_models.py's refined_stage, each leaf written out as n PLBEAMs with
    the interior node coordinates as DOFs."""
    from examples.benchmarks.stage_models import refined_stage

    meshed, by_hand = meshed_stage(4), refined_stage(4)
    assert meshed.ndof == by_hand.ndof == 21
    np.testing.assert_allclose(natural_frequencies(meshed).frequencies_hz,
                               natural_frequencies(by_hand).frequencies_hz, rtol=1e-9)
    names = meshed.coordinate_names
    assert "leaf_left_1.x" in names and "leaf_left_3_r.phi" in names
    assert "leaf_left_4.e2" in meshed.deformation_names and "leaf_left" not in str(
        [n for n in meshed.deformation_names if n.startswith("leaf_left.")])


def test_one_segment_is_the_element_itself():
    data = parse_toml(scene_path("stage_planar_3dof"))
    plain = load_scene("stage_planar_3dof")
    one = copy.deepcopy(data)
    one["elements"]["leaf_left"]["segments"] = 1
    model = build_model(one)
    assert model.coordinate_names == plain.coordinate_names
    assert model.deformation_names == plain.deformation_names


def test_interior_nodes_can_be_measured():
    """An output on an interior node: under a small sideways force on the bar, the leaf's
    midpoint moves half the bar's displacement (a guided beam's S-shape, 3 s^2 - 2 s^3 at
    s = 1/2, which the cubic segments represent exactly). What departs from it: the leaves'
    axial compliance lets the bar tilt, a few EI / (EA l^2) = 2.1e-6 (6.2e-6 measured); at
    1 mN the geometric nonlinearity is ~1e-10."""
    from flexure.core import static_equilibrium

    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    data["elements"]["leaf_left"]["segments"] = 2
    data["elements"]["leaf_right"]["segments"] = 2
    data["outputs"]["mid"] = {"node": "leaf_left_1", "coordinate": "x", "quantity": "position"}
    model = build_model(data)
    mid, tip = model.coordinate_index("leaf_left_1.x"), model.coordinate_index("3.x")
    assert model.outputs[-1].name == "mid" and model.outputs[-1].coordinate == mid
    loads = np.zeros(model.nx)
    loads[tip] = 1e-3  # N
    moved = static_equilibrium(model, loads=loads).x - model.initial_coordinates
    assert moved[mid] / moved[tip] == pytest.approx(0.5, abs=2e-5)


@pytest.mark.parametrize("value", [0, -2, 2.5, True, "3", 1001, [2]])
def test_a_bad_segment_count_is_named(value):
    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    data["elements"]["leaf_left"]["segments"] = value
    with pytest.raises(SceneError, match=r"elements\.leaf_left\.segments: expected a whole "
                                         r"number of segments from 1 to 1000"):
        build_model(data, source="bad.toml")


def test_only_beams_are_split():
    data = parse_toml(scene_path("truss_1dof_x"))
    name = next(iter(data["elements"]))
    data["elements"][name]["segments"] = 3
    with pytest.raises(SceneError, match=rf"elements\.{name}\.segments: only beams \(PLBEAM, "
                                         r"BEAM\) can be split"):
        build_model(data)


def test_a_name_clash_with_the_scene_is_named():
    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    data["elements"]["leaf_left"]["segments"] = 3
    data["nodes"]["leaf_left_2"] = {"position": [0.5, 0.5]}
    with pytest.raises(SceneError, match="the interior node 'leaf_left_2' of the segments has "
                                         "the name of a node of the scene"):
        build_model(data)
    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    data["elements"]["leaf_left"]["segments"] = 3
    data["elements"]["leaf_left_3"] = copy.deepcopy(data["elements"]["bar"])
    with pytest.raises(SceneError, match="the segment 'leaf_left_3' has the name of an element "
                                         "of the scene"):
        build_model(data)


def test_segments_in_a_scene_that_lists_no_dofs():
    """Meshing and chosen DOFs together: the clamped leaf with no DOF listed anywhere, in
    8 segments, gets its 16 DOFs chosen and the frequencies of the listed version."""
    listed = cantilever(8)
    data = {"scene": {"name": "leaf_free_choice"},
            "sections": {"leaf": {"E": 2.1e11, "rho": 7850.0, "width": 0.018,
                                  "height": 0.0005}},
            "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                      "2": {"angle": 0.0, "fixed": ["phi"]},
                      "3": {"position": [LENGTH, 0.0]}, "4": {"angle": 0.0}},
            "elements": {"leaf": {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"],
                                  "section": "leaf", "released": ["e2", "e3"],
                                  "segments": 8}}}
    chosen = build_model(data)
    assert chosen.ndof == chosen.declared_dof_count == listed.ndof == 16
    assert len(chosen.chosen_dofs) == 16
    np.testing.assert_allclose(natural_frequencies(chosen).frequencies_hz,
                               natural_frequencies(listed).frequencies_hz, rtol=1e-8)
