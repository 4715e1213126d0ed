"""Compliance and support stiffness at a node against analytic results: the 1-DOF truss
(1/k, k = EA/l0), the leaf-spring stage's bar (two clamped-guided leaves, 24 EI/L^3, less the
consistent geometric stiffness 6/5 P/L under a vertical load P), a clamped cantilever (tip
L^3/(3EI), L/(EI), L^2/(2EI): exact for the Hermite beam, one element or several), a spatial
cantilever's tip rotations; the errors of an unknown node and a singular tangent stiffness; the
CLI."""

import dataclasses
import json

import numpy as np
import pytest
import test_rotation_ports as spatial

from flexure.core import FlexureError, SceneError, build_model, compliance, load_scene
from flexure.core.analysis.linearization import linearize
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.cli import main

LEAF_EI = 2.1e11 * 0.018 * 0.0005**3 / 12  # N m^2, stage_planar_1dof's leaves
LEAF_L = 0.1  # m


def test_truss_compliance_is_one_over_ea_per_l0():
    """truss_1dof_x: EA = 94.5 N, l0 = 0.1 m, so k = 945 N/m; its y is fixed. The 1 N load
    stretches it along itself, so the geometric stiffness acts on y alone."""
    result = compliance(load_scene("truss_1dof_x"), "2")
    assert result.coordinates == ["2.x", "2.y"]
    np.testing.assert_allclose(result.matrix, [[0.1 / 94.5, 0.0], [0.0, 0.0]], rtol=1e-12,
                               atol=0.0)
    assert result.units == [["m/N", "m/N"], ["m/N", "m/N"]]
    assert result.stiffness is None and result.unreachable == ["2.y"]
    assert "2.y cannot move" in result.note


def test_stage_bar_lateral_compliance_unloaded():
    """Two clamped-guided leaves in parallel: k = 2 * 12 EI / L^3 = 945 N/m. The bar's node 3
    carries 3.x, 3.y and its rotational node 4's angle; the leaves do not stretch and the bar
    does not turn, so 3.y and 4.phi are unreachable."""
    result = compliance(load_scene("stage_planar_1dof"), "3")
    assert result.coordinates == ["3.x", "3.y", "4.phi"]
    assert result.matrix[0, 0] == pytest.approx(LEAF_L**3 / (24 * LEAF_EI), rel=1e-12)
    assert result.unreachable == ["3.y", "4.phi"]
    assert np.count_nonzero(result.matrix) == 1 and result.stiffness is None
    assert result.units[0] == ["m/N", "m/N", "m/(N m)"]
    assert result.units[2] == ["rad/N", "rad/N", "rad/(N m)"]


def test_stage_bar_lateral_compliance_under_a_vertical_load():
    """P = 2 N downward on node 3 compresses the left leaf alone (the bar's moment balance
    about node 3; the leaves do not stretch). The PLBEAM's consistent geometric stiffness of a
    clamped-guided leaf is -6/5 P / L (which buckles it at 10 EI / L^2, the notes' 78.75 N for
    two leaves), so k = 24 EI / L^3 - 1.2 P / L. The leaves stay straight under a vertical load,
    so this holds to round-off; the solution is passed in."""
    model = load_scene("stage_planar_1dof")
    loads = np.zeros(model.nx)
    loads[model.coordinate_index("3.y")] = -2.0
    solution = static_equilibrium(model, loads=loads)
    result = compliance(model, "3", solution=solution)
    k = 24 * LEAF_EI / LEAF_L**3 - 1.2 * 2.0 / LEAF_L
    assert result.matrix[0, 0] == pytest.approx(1.0 / k, rel=1e-10)


def test_loaded_sideways_the_bar_moves_on_one_path():
    """With 1 N sideways the bar also drops (parasitic motion): 3.x and 3.y are reachable but
    move only together with the one DOF, so the matrix has rank 1 and no inverse."""
    result = compliance(load_scene("stage_planar_1dof", overrides={"nodes.3.force": [1.0, 0]}),
                        "3")
    assert result.matrix[1, 1] > 0 and result.stiffness is None
    assert "only together (rank 1 of 2)" in result.note


def cantilever(segments):
    """One clamped PLBEAM of L = 0.2 m along x, EI = 2 N m^2, EA = 1e5 N, in `segments`."""
    return build_model({
        "scene": {"name": "cantilever", "dimension": 2},
        "sections": {"s": {"EA": 1e5, "EI": 2.0}},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"angle": 0.0, "fixed": ["phi"]},
                  "3": {"position": [0.2, 0.0], "dof": ["x", "y"]},
                  "4": {"angle": 0.0, "dof": ["phi"]}},
        "elements": {"beam": {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                              "released": ["e1", "e2", "e3"], "segments": segments}}})


@pytest.mark.parametrize("segments", [1, 4])
def test_cantilever_tip_compliance_and_stiffness(segments):
    """Tip loads bend a clamped beam into a cubic, which the Hermite beam holds exactly: the
    textbook flexibility L/EA, L^3/(3EI), L/(EI), L^2/(2EI) to round-off, one element or
    four; its inverse the stiffness EA/L, 12 EI/L^3, 4 EI/L, -6 EI/L^2."""
    L, EA, EI = 0.2, 1e5, 2.0
    result = compliance(cantilever(segments), "3")
    assert result.coordinates == ["3.x", "3.y", "4.phi"]
    expected = [[L / EA, 0, 0], [0, L**3 / (3 * EI), L**2 / (2 * EI)],
                [0, L**2 / (2 * EI), L / EI]]
    np.testing.assert_allclose(result.matrix, expected, rtol=1e-10, atol=1e-16)
    stiffness = [[EA / L, 0, 0], [0, 12 * EI / L**3, -6 * EI / L**2],
                 [0, -6 * EI / L**2, 4 * EI / L]]
    np.testing.assert_allclose(result.stiffness, stiffness, rtol=1e-10, atol=1e-6)
    assert result.unreachable == [] and result.note == ""
    assert result.stiffness_units[2] == ["N m/m", "N m/m", "N m/rad"]
    # the rotational node alone: its angle
    assert compliance(cantilever(segments), "4").matrix[0, 0] == pytest.approx(L / EI,
                                                                               rel=1e-10)


def test_fixed_node_has_zero_compliance_and_no_stiffness():
    result = compliance(load_scene("stage_planar_1dof"), "1")
    assert result.coordinates == ["1.x", "1.y", "2.phi"]
    assert not np.any(result.matrix) and result.stiffness is None
    assert result.unreachable == ["1.x", "1.y", "2.phi"]


def test_unknown_node_is_named():
    with pytest.raises(SceneError, match="has no node '99'; expected one of 1, 2, 3"):
        compliance(load_scene("stage_planar_1dof"), "99")


def test_spatial_translational_node_gives_its_translations():
    result = compliance(load_scene("stage_spatial_1dof"), "3")  # the bar: sideways only
    assert result.coordinates == ["3.x", "3.y", "3.z"]
    assert result.matrix[0, 0] == pytest.approx(LEAF_L**3 / (24 * LEAF_EI), rel=1e-9)


def rotation_matrix(lam):
    """R of Euler parameters (lambda0, lambda1, lambda2, lambda3), written out."""
    l0, lv = lam[0], np.asarray(lam[1:])
    cross = np.array([[0.0, -lv[2], lv[1]], [lv[2], 0.0, -lv[0]], [-lv[1], lv[0], 0.0]])
    return (l0**2 - lv @ lv) * np.eye(3) + 2.0 * np.outer(lv, lv) + 2.0 * l0 * cross


@pytest.mark.parametrize("rotation", [(0.0, 0.0, 0.0), (0.3, -0.2, 0.5)])
def test_spatial_rotational_node_gives_torsion_and_bending(rotation):
    """A clamped spatial beam's tip node: L / GIt about the beam, L / EIy and L / EIz about the
    bending axes, whatever orientation its node starts in (the beam's stiffness is in its
    own axes, here the global ones)."""
    model = build_model(spatial.cantilever(rotation=rotation))
    result = compliance(model, "4")
    assert result.coordinates == ["4.rx", "4.ry", "4.rz"]
    assert result.units[0][0] == "rad/(N m)" and result.stiffness_units[1][1] == "N m/rad"
    L, GIT, EIY, EIZ = spatial.L, spatial.GIT, spatial.EIY, spatial.EIZ
    np.testing.assert_allclose(result.matrix, np.diag([L / GIT, L / EIY, L / EIZ]),
                               rtol=1e-9, atol=1e-12 * L / EIZ)
    np.testing.assert_allclose(result.stiffness, np.diag([GIT, EIY, EIZ]) / L, rtol=1e-9,
                               atol=1e-9 * EIY / L)


def test_spatial_rotational_compliance_under_load_equals_static_differences():
    """Bent by 0.4 rad and twisted under tip moments about fixed global axes (geometric
    nonlinearity couples the axes; such moments are not conservative, so the compliance is
    not symmetric): against central differences of static solutions under +-h N m about each
    axis, the rotation between the two read from their Euler parameters (R+ R-^T), to 1e-6."""
    model = build_model(spatial.cantilever())
    base = {"Mx": 0.2, "My": 0.4 * spatial.EIY / spatial.L, "Mz": 0.0}
    solution = static_equilibrium(model, inputs=base)
    result = compliance(model, "4", solution=solution)
    euler = [model.coordinate_index(f"4.lambda{k}") for k in range(4)]
    h = 1e-4
    numeric = np.zeros((3, 3))
    for k, name in enumerate(("Mx", "My", "Mz")):
        turned = []
        for sign in (1.0, -1.0):
            loads = dict(base)
            loads[name] += sign * h
            turned.append(rotation_matrix(static_equilibrium(model, inputs=loads).x[euler]))
        relative = turned[0] @ turned[1].T
        skew = 0.5 * (relative - relative.T)
        numeric[:, k] = np.array([skew[2, 1], skew[0, 2], skew[1, 0]]) / (2.0 * h)
    assert abs(numeric[0, 2]) > 1e-3 * numeric[0, 0]  # the load couples the axes
    np.testing.assert_allclose(result.matrix, numeric, rtol=1e-6,
                               atol=1e-6 * spatial.L / spatial.EIZ)
    assert abs(result.matrix[0, 2] - result.matrix[2, 0]) > 1e-2 * result.matrix[0, 0]


def test_singular_tangent_stiffness_is_reported():
    model = load_scene("truss_1dof_x")
    lin = linearize(model)
    flat = dataclasses.replace(lin, K0=np.zeros_like(lin.K0), G0=np.zeros_like(lin.G0))
    with pytest.raises(FlexureError, match="tangent stiffness K0 \\+ G0 .* is singular"):
        compliance(model, "2", linear_model=flat)


def test_a_nearly_singular_tangent_stiffness_is_reported_not_inverted(capsys):
    """The manipulator's kinematic stage: its DOFs (the bodies' in-plane positions) have no
    stiffness, so K0 + G0 has a condition number of about 1e17 and a solve still returns
    finite numbers (a compliance with negative diagonal entries); the condition estimate
    refuses it in one line. Whether the static equilibrium before it already stops at the
    singular tangent (its Newton step on a residual of 1e-11 N) depends on the last bits of
    that residual, so on the CPU: either refusal names the singular tangent stiffness."""
    with pytest.raises(FlexureError, match="tangent stiffness (K0 \\+ G0 .* )?is singular"):
        compliance(load_scene("manipulator_stage"), "E")
    assert main(["analyze", "manipulator_stage", "--compliance", "E"]) == 2
    err = capsys.readouterr().err
    assert "is singular" in err and "Traceback" not in err


def test_cli_prints_and_jsons_the_compliance(capsys):
    assert main(["analyze", "truss_1dof_x", "--compliance", "2"]) == 0
    out = capsys.readouterr().out
    assert "compliance of node 2" in out and "2.x (m)" in out and "on 2.x (N)" in out
    assert "0.0010582" in out and "no support stiffness: 2.y cannot move" in out
    assert main(["analyze", "stage_planar_3dof", "--compliance", "3,1", "--compliance", "3",
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert list(result["compliance"]) == ["3", "1"] and "static" not in result
    stage = result["compliance"]["3"]
    assert stage["units"][0] == ["m/N", "m/N", "m/(N m)"]
    assert stage["stiffness"][0][0] == pytest.approx(24 * LEAF_EI / LEAF_L**3, rel=1e-6)


def test_cli_refuses_an_unknown_node_in_one_line(capsys):
    assert main(["analyze", "stage_planar_1dof", "--compliance", "7,99"]) == 2
    err = capsys.readouterr().err
    assert "has no node '99'" in err and "Traceback" not in err and err.count("\n") == 1


def test_cli_refuses_an_empty_node_name(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["analyze", "stage_planar_1dof", "--compliance", ","])
    assert exit_info.value.code == 2
    assert "expected node names separated by commas" in capsys.readouterr().err
