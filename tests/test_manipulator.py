"""The six-DOF flexure manipulator of the chapter (examples/manipulator.py and its scenes):
the guidance over-constrained by design, the end-effector stage exactly constrained with 6
DOFs and moving as its geometry says, the dynamic models' suspension and parasitic modes,
and the reduction that keeps the lowest six."""

import copy
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from examples import manipulator
from flexure.core import (
    ConstraintError,
    Kinematics,
    build_model,
    load_scene,
    natural_frequencies,
    state_space,
    static_equilibrium,
)
from flexure.core.mechanics.constraints import check_exact_constraint
from flexure.core.mechanics.freezing import freezable
from flexure.core.scene.building import parse_toml, scene_path


@pytest.mark.parametrize("file_name", sorted(manipulator.all_scenes()))
def test_the_scenes_are_written_from_the_parameter_table(file_name):
    """The committed scenes are what the generator writes: the table is their one source."""
    assert parse_toml(scene_path(file_name.removesuffix(".toml"))) == \
        manipulator.all_scenes()[file_name]


def test_the_generator_writes_the_committed_files(tmp_path, capsys):
    assert manipulator.main(["--out", str(tmp_path)]) == 0
    for file_name in manipulator.all_scenes():
        committed = scene_path(file_name.removesuffix(".toml")).read_text()
        assert (tmp_path / file_name).read_text() == committed
    assert manipulator.main(["--table"]) == 0
    assert capsys.readouterr().out.endswith(manipulator.parameter_table())


def test_the_docs_show_the_parameter_table():
    docs = Path(__file__).resolve().parents[1] / "docs" / "manipulator.md"
    assert manipulator.parameter_table() in docs.read_text()
    assert manipulator.parameter_table(manipulator.COILS) in docs.read_text()


def test_the_coil_scene_is_the_control_model_with_a_voltage_driven_coil_on_each_input(capsys):
    plain = manipulator.scene_control()
    coiled = manipulator.scene_control_vcm()
    actuators = coiled.pop("actuators")
    assert coiled.pop("scene")["name"] == "manipulator_control_vcm"
    plain.pop("scene")
    assert coiled == plain
    assert [a["input"] for a in actuators.values()] == [f"F{k}" for k in range(1, 7)]
    assert all(a["drive"] == "voltage" and a["force_constant"] == 6.0 for a in
               actuators.values())
    model = load_scene("manipulator_control_vcm")
    assert [a.name for a in model.coil_actuators] == [f"VCM{k}" for k in range(1, 7)]
    assert manipulator.main(["--coils"]) == 0
    assert capsys.readouterr().out == manipulator.parameter_table(manipulator.COILS)


def guidance_with(releases):
    data = copy.deepcopy(manipulator.scene_guidance())
    for name in releases:
        element, deformation = name.rsplit(".", 1)
        data["elements"][element]["released"].append(deformation)
    return data


def test_the_guidance_is_over_constrained_by_design_and_the_proposal_makes_it_exact():
    """Each parallel pair of leaves holds its body's rotation about the guided axis twice and
    the cross-pivot holds the lever's height twice: three redundant constraints, named, and
    one release in each proposed. Released, the guidance has one DOF: the carriage's stroke."""
    with pytest.raises(ConstraintError) as refused:
        load_scene("manipulator_guidance")
    message = str(refused.value)
    assert "so 3 of them are redundant" in message
    assert ("each redundancy: g1_leaf2.e4 with g1_leaf1.e3, g1_leaf1.e4, g1_leaf2.e3 (through "
            "g1_L_to_leaf1, g1_L_to_leaf2); g1_leaf4.e4 with g1_leaf3.e3, g1_leaf3.e4, "
            "g1_leaf4.e3 (through g1_H_to_leaf3, g1_H_to_leaf4, g1_L_to_leaf3, g1_L_to_leaf4); "
            "g1_pivotT.e4 with g1_pivotS.e3, g1_pivotS.e4, g1_pivotT.e3 (through g1_U_to_S, "
            "g1_U_to_T)") in message
    proposal = "g1_leaf2.e4, g1_leaf4.e4, g1_pivotT.e4"
    assert f"a release that removes the over-constraint: {proposal}" in message
    model = build_model(guidance_with(proposal.split(", ")))
    assert model.ndof == 1 and check_exact_constraint(model)["ndof"] == 1


def test_the_folded_guidance_moves_its_carriage_straight():
    """1 mm of stroke: the intermediate body moves half of it (the lever), and the carriage's
    height changes by less than 1 % of one parallel pair's shortening 3 d^2 / (5 h) (the
    folded pairs cancel it; what is left comes from the lever's second-order motion)."""
    data = guidance_with(["g1_leaf2.e4", "g1_leaf4.e4", "g1_pivotT.e4"])
    data["nodes"]["g1_H"]["dof"] = ["x"]
    model = build_model(data)
    kin = Kinematics(model)
    x0 = model.initial_coordinates
    x = kin.solve(np.array([x0[model.coordinate_names.index("g1_H.x")] + 1e-3]), x0).x
    moved = {name: x[i] - x0[i] for i, name in enumerate(model.coordinate_names)}
    assert moved["g1_H.x"] == pytest.approx(1e-3, abs=1e-15)
    assert moved["g1_L.x"] == pytest.approx(0.5e-3, rel=1e-3)
    shortening = 3 * (0.5e-3) ** 2 / (5 * manipulator.value("leaf_length"))
    assert abs(moved["g1_H_leaf3.z"]) < 1e-2 * shortening
    assert abs(moved["g1_H.y"]) < 1e-9


def test_the_end_effector_stage_is_exactly_constrained_with_six_dofs():
    model = load_scene("manipulator_stage")
    assert model.ndof == 6 and not model.chosen_dofs
    assert model.dof_names == ["C1.x", "C1.y", "C2.x", "C2.y", "C3.x", "C3.y"]


def stage_moved(dx):
    """The stage's coordinates with the bodies moved by dx (3, 2) m from the reference."""
    model = load_scene("manipulator_stage")
    x0 = model.initial_coordinates
    q = np.array([x0[model.coordinate_names.index(n)] for n in model.dof_names]) + np.ravel(dx)
    x = Kinematics(model).solve(q, x0).x
    return model, {name: x[i] - x0[i] for i, name in enumerate(model.coordinate_names)}


def test_moving_the_bodies_alike_translates_the_end_effector_alike():
    _, moved = stage_moved([[2e-3, -1e-3]] * 3)
    assert (moved["E.x"], moved["E.y"], moved["E.z"]) == pytest.approx((2e-3, -1e-3, 0.0),
                                                                        abs=1e-13)
    assert max(abs(moved[f"E_r.lambda{k}"]) for k in range(1, 4)) < 1e-12


def test_moving_the_bodies_inward_lifts_the_end_effector_as_the_legs_say():
    """Each slanted spring keeps its elongation e1 = |l| - l0 + e5^2 / (10 l0) zero, bent in
    an S between its parallel end frames (e6 = -e5, the offset of the chord across the leg);
    the lift that does so, solved here from that formula alone."""
    inward = 1e-3
    radial = [(math.cos(math.radians(a)), math.sin(math.radians(a)))
              for a in manipulator.BODY_ANGLES]
    _, moved = stage_moved([[-inward * c, -inward * s] for c, s in radial])
    length = manipulator.value("slant_length")
    run = rise = length / math.sqrt(2.0)
    across = np.array([rise, run]) / length  # normal to the leg (inward and up), radial plane

    def elongation(lift):
        chord = np.array([-(run - inward), rise + lift])
        offset = chord @ across
        return np.linalg.norm(chord) - length + offset**2 / (10 * length)

    lift = brentq(elongation, 0.0, 5 * inward, xtol=1e-16)
    assert moved["E.z"] == pytest.approx(lift, rel=1e-9)
    assert abs(moved["E.x"]) < 1e-13 and abs(moved["E.y"]) < 1e-13


def test_a_freezable_set_is_exactly_what_builds():
    """`freezable` against building each frozen model: for every released deformation of the
    released guidance, alone, it takes the deformation when and only when the scene with it
    prescribed zero passes the exact-constraint check."""
    data = guidance_with(["g1_leaf2.e4", "g1_leaf4.e4", "g1_pivotT.e4"])
    model = build_model(data)
    for d in model.released_deformations:
        element, deformation = model.deformation_names[d].rsplit(".", 1)
        frozen = copy.deepcopy(data)
        frozen["elements"][element]["released"].remove(deformation)
        try:
            build_model(frozen)
            builds = True
        except ConstraintError:
            builds = False
        assert (freezable(model, [[d]]) == [0]) == builds, model.deformation_names[d]


def test_freezable_takes_a_set_in_order_and_skips_what_conflicts():
    """The two thin-direction bendings of a guidance leaf: either can be frozen (the guidance
    keeps its stroke in the other), both together lock the stroke, which over-constrains the
    model: the second is skipped, and building confirms both."""
    data = guidance_with(["g1_leaf2.e4", "g1_leaf4.e4", "g1_pivotT.e4"])
    model = build_model(data)
    index = {name: d for d, name in enumerate(model.deformation_names)}
    assert freezable(model, [[index["g1_leaf1.e5"]], [index["g1_leaf1.e6"]]]) == [0]
    for frozen, builds in ((["e5"], True), (["e6"], True), (["e5", "e6"], False)):
        scene = copy.deepcopy(data)
        leaf = scene["elements"]["g1_leaf1"]
        leaf["released"] = [d for d in leaf["released"] if d not in frozen]
        try:
            build_model(scene)
            assert builds
        except ConstraintError:
            assert not builds


@pytest.fixture(scope="module")
def frequencies():
    """The lowest ten natural frequencies (Hz) of the full, elongation-frozen and reduced
    manipulators."""
    return {name: natural_frequencies(load_scene(name), 10).frequencies_hz
            for name in ("manipulator", "manipulator_e1", "manipulator_reduced")}


@pytest.mark.slow
def test_six_suspension_modes_below_30_hz_and_the_first_parasitic_far_above(frequencies):
    full = frequencies["manipulator"]
    assert load_scene("manipulator").ndof == 816
    assert np.all(full[:6] < 30.0) and np.all(full[:6] > 5.0)
    crossover_hz = 300.0 / (2 * math.pi)
    assert full[6] > 3 * crossover_hz


@pytest.mark.slow
def test_the_reduced_models_keep_the_lowest_seven_within_one_percent(frequencies):
    full = frequencies["manipulator"]
    np.testing.assert_allclose(frequencies["manipulator_e1"][:6], full[:6], rtol=1e-3)
    # the reduction keeps seven: the six and the first parasitic mode
    np.testing.assert_allclose(frequencies["manipulator_reduced"][:7], full[:7], rtol=1e-2)
    assert load_scene("manipulator_reduced").ndof < load_scene("manipulator_e1").ndof


@pytest.mark.slow
def test_the_six_by_six_state_space_has_the_static_compliance_as_its_dc_gain():
    """G(0) = -C A^-1 B of the reduced manipulator against six static equilibria, each under
    1 mN on one actuator: the same compliance to 2e-5 (what differs is the mechanism's
    nonlinearity, 7e-6 of the gain at 1 mN, 7e-5 at 10 mN: proportional to the force)."""
    model = load_scene("manipulator_reduced")
    sys = state_space(model)
    assert (sys.ninputs, sys.noutputs) == (6, 6)
    dc = -sys.C @ np.linalg.solve(sys.A, sys.B)
    x0 = model.initial_coordinates
    outputs = [port.coordinate for port in model.outputs]
    force = 1e-3
    for k, port in enumerate(model.inputs):
        loads = np.zeros(model.nx)
        loads[port.coordinate] = force
        x = static_equilibrium(model, loads=loads).x
        np.testing.assert_allclose((x[outputs] - x0[outputs]) / force, dc[:, k], rtol=2e-5,
                                   atol=2e-5 * np.abs(dc).max())


def table_rows(text):
    """The rows of the markdown tables in text, each as its cells (stripped), separators
    and headers left out (a header is the row just above a separator)."""
    lines = text.splitlines()
    rows = []
    for k, line in enumerate(lines):
        if not line.startswith("| ") or line.startswith("| ---"):
            continue
        if k + 1 < len(lines) and lines[k + 1].startswith("| ---"):
            continue
        rows.append([cell.strip() for cell in line.split("|")[1:-1]])
    return rows


def same_figure(printed, documented):
    """Whether two table cells say the same: equal text, or numbers (a trailing unit such as
    "%" alike) within one unit of the last digit printed, so that a round-off which moves a
    value across a rounding boundary does not fail."""
    if printed == documented:
        return True
    a, unit_a = (printed.split(" ", 1) + [""])[:2]
    b, unit_b = (documented.split(" ", 1) + [""])[:2]
    try:
        x, y = float(a), float(b)
    except ValueError:
        return False
    decimals = len(b.partition(".")[2])
    return unit_a == unit_b and abs(x - y) <= 1.0001 * 10.0**-decimals


@pytest.mark.slow
def test_the_report_prints_the_figures_the_docs_show(tmp_path):
    """examples/manipulator_report.py, run as a user runs it, prints docs/manipulator.md's
    tables: Table 3.1's frequencies of the three models and the workspace's 21 poses
    (displacements, rotations, the lowest seven frequencies and the gains), every cell the
    same to one unit of its last printed digit, every row in the docs' order; and it draws
    the two figures the docs show."""
    import sys

    import children

    script = Path(manipulator.__file__).with_name("manipulator_report.py")
    done = children.run([sys.executable, str(script), "--figures", str(tmp_path)],
                        capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    printed = table_rows(done.stdout)
    docs = (Path(__file__).resolve().parents[1] / "docs" / "manipulator.md").read_text()
    report_part = docs[docs.index("## Natural frequencies"):
                       docs.index("## The six-actuator loop")]
    documented = table_rows(report_part)
    assert len(printed) == 10 + 21, done.stdout
    assert len(documented) == len(printed)
    for got, shown in zip(printed, documented, strict=True):
        assert len(got) == len(shown), (got, shown)
        assert all(same_figure(a, b) for a, b in zip(got, shown, strict=True)), (got, shown)
    assert (tmp_path / "manipulator_sigma.png").stat().st_size > 10_000
    assert (tmp_path / "manipulator_workspace.png").stat().st_size > 10_000


@pytest.mark.slow
def test_angle_outputs_are_optional_and_only_add_the_end_effector_angles():
    """The generator's angle outputs leave the committed scenes as they are and add E_rx,
    E_ry, E_rz (rad) on the end effector's rotational node to the dynamic scenes, after the
    six encoders; they read the scene's unrotated end effector as zero."""
    from flexure.core import output_value

    plain, angled = manipulator.all_scenes(), manipulator.all_scenes(angle_outputs=True)
    assert plain == manipulator.all_scenes(angle_outputs=False)
    extra = {f"E_{a}": {"node": "E_r", "coordinate": a, "quantity": "position"}
             for a in ("rx", "ry", "rz")}
    for file_name, scene in angled.items():
        changed = copy.deepcopy(scene)
        if file_name in ("manipulator.toml", "manipulator_e1.toml"):  # the dynamic ones
            assert list(scene["outputs"])[-3:] == list(extra)
            for name in extra:
                assert changed["outputs"].pop(name) == extra[name]
        assert changed == plain[file_name]
    model = build_model(angled["manipulator_e1.toml"])
    angles = [p for p in model.outputs if p.about_axis]
    assert [(p.name, p.unit) for p in angles] == [("E_rx", "rad"), ("E_ry", "rad"),
                                                  ("E_rz", "rad")]
    assert [output_value(model, p, model.initial_coordinates) for p in angles] == [0.0] * 3


@pytest.mark.slow
def test_the_end_effector_angles_have_the_static_compliance_as_their_dc_gain():
    """The reduced manipulator with the end effector's angle outputs: the state space's DC
    gain from each actuator force to the three angles against static equilibria under 1 mN
    on that actuator (the angle outputs' Jacobian in C), to 2e-5 of the largest gain as the
    encoders' test."""
    from flexure.core import output_value

    data = parse_toml(scene_path("manipulator_reduced"))
    data["outputs"] = {f"E_{a}": {"node": "E_r", "coordinate": a} for a in ("rx", "ry", "rz")}
    model = build_model(data)
    sys = state_space(model)
    assert (sys.ninputs, sys.noutputs) == (6, 3)
    dc = -sys.C @ np.linalg.solve(sys.A, sys.B)
    assert np.abs(dc).max() > 0.0
    force = 1e-3
    for k, port in enumerate(model.inputs):
        x = static_equilibrium(model, inputs={port.name: force}).x
        angles = [output_value(model, p, x) for p in model.outputs]
        np.testing.assert_allclose(np.array(angles) / force, dc[:, k], rtol=2e-5,
                                   atol=2e-5 * np.abs(dc).max())
