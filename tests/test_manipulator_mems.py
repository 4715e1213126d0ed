"""The manipulator at the micromanipulator's scale, in silicon (examples/manipulator_mems.py,
issue 31): its scene written from the design, its frequencies against the scaling law
f ~ sqrt(E / rho) / s, each process choice's deviation within its stiffness and mass bounds,
the same exact-constraint verdicts as the macro design, and its step against the
linearisation and the static deflection. SI units: m, kg, N, s, Hz."""

import math
from pathlib import Path

import numpy as np
import pytest
from cli_runs import run

from examples import manipulator, manipulator_mems
from flexure.core import (
    build_model,
    load_scene,
    natural_frequencies,
    output_value,
    simulate,
    static_equilibrium,
)
from flexure.core.mechanics.constraints import check_exact_constraint
from flexure.core.scene.building import parse_toml, scene_path
from flexure.core.scene.scene_writer import scene_toml

MODES = 12


def test_the_scene_is_written_from_the_design(tmp_path, capsys):
    """The committed scene is what the generator writes, byte for byte; the docs show its
    table."""
    assert parse_toml(scene_path("manipulator_mems")) == manipulator_mems.scene_mems()
    assert manipulator_mems.main(["--out", str(tmp_path)]) == 0
    written = (tmp_path / "manipulator_mems.toml").read_text()
    assert written == scene_path("manipulator_mems").read_text()
    assert manipulator_mems.main(["--table"]) == 0
    table = manipulator.parameter_table(manipulator_mems.mems_parameters())
    assert capsys.readouterr().out.endswith(table)
    docs = Path(__file__).resolve().parents[1] / "docs" / "manipulator.md"
    assert table in docs.read_text()


def test_the_mechanism_is_a_few_mm_with_flexures_the_process_makes():
    """4.4 mm across its nodes, 1.8 mm tall (0.54 m with the bodies, scaled by 1/100); every
    flexure's thin dimension a line of 2 um or more, at most 20 times thinner than the 50 um
    device layer it is as wide as."""
    scene = manipulator_mems.scene_mems()
    positions = np.array([n["position"] for n in scene["nodes"].values() if "position" in n])
    span = positions.max(axis=0) - positions.min(axis=0)
    assert 4e-3 < span[:2].max() < 6e-3 and span[2] < 2e-3
    for name in ("leaf", "pivot", "push", "slant", "wire"):
        section = scene["sections"][name]
        assert section["height"] >= 2e-6 and section["width"] <= 50e-6
        assert section["width"] / section["height"] <= 20.0
        assert (section["E"], section["rho"], section["nu"]) == (169e9, 2330.0, 0.28)


@pytest.fixture(scope="module")
def frequencies():
    """{what: the lowest MODES natural frequencies (Hz)}: the macro control model, and each
    table of `manipulator_mems.process_steps` as that model."""
    out = {"macro": natural_frequencies(load_scene("manipulator_control"),
                                        MODES).frequencies_hz}
    for what, table in manipulator_mems.process_steps():
        model = build_model(manipulator.scene_control(table))
        out[what] = natural_frequencies(model, MODES).frequencies_hz
    return out


@pytest.mark.slow  # a variant of manipulator_control (docs/verification.md, the tiers)
def test_exactly_scaled_frequencies_follow_sqrt_e_over_rho_over_s(frequencies):
    """Lengths by s = 1/100, E 210 -> 169 GPa, every density by 2330 / 7850: every
    frequency times sqrt((169 / 210) / (2330 / 7850)) / 0.01 = 164.66. To 2e-9: the design
    rounds positions to 1e-12 m (`manipulator.design`), 1e-8 of the shortest 100 um offsets
    at most; measured 5.3e-10."""
    factor = math.sqrt((169e9 / 210e9) / (2330.0 / 7850.0)) / 0.01
    assert manipulator_mems.frequency_factor() == pytest.approx(factor, rel=1e-15)
    np.testing.assert_allclose(frequencies["exactly scaled"], frequencies["macro"] * factor,
                               rtol=2e-9, atol=0.0)


def _step(frequencies, k):
    what = [w for w, _ in manipulator_mems.PROCESS_STEPS]
    before = "exactly scaled" if k == 0 else what[k - 1]
    return frequencies[before], frequencies[what[k]]


@pytest.mark.slow  # a variant of manipulator_control (docs/verification.md, the tiers)
def test_each_process_choice_moves_the_frequencies_within_its_bounds(frequencies):
    """K <= K' <= a K and M <= M' <= b M give f / sqrt(b) <= f' <= f sqrt(a) mode by mode
    (Courant-Fischer). Poisson's ratio 0.3 -> 0.28 raises only G, by 1.3 / 1.28; silicon
    bodies instead of aluminium ones raise the lumped masses by 7850 / 2700 and leave the
    flexures' (each mode within 1 % of the bound: the flexures carry under 2 % of the modal
    mass); beta moves no undamped frequency. The device layer and the square wires change
    stiffness and mass together: their measured ratios (docs/manipulator.md) only checked to
    lower every suspension mode (the layer: wide 100 to 300 um -> 50 um) and raise them
    (the wires: I of a square of side d is 1.7 times the circle's)."""
    before, after = _step(frequencies, 0)
    assert np.all(after >= before * (1 - 1e-9))
    assert np.all(after <= before * math.sqrt(1.3 / 1.28) * (1 + 1e-9))
    before, after = _step(frequencies, 1)
    assert np.all(after[:6] < 0.7 * before[:6])
    before, after = _step(frequencies, 2)
    assert np.all(after[:6] > 1.05 * before[:6])
    before, after = _step(frequencies, 3)
    bound = before / math.sqrt(7850.0 / 2700.0)
    assert np.all(after >= bound * (1 - 1e-9)) and np.all(after <= bound * 1.01)
    before, after = _step(frequencies, 4)
    np.testing.assert_allclose(after, before, rtol=1e-12)
    assert frequencies[manipulator_mems.PROCESS_STEPS[-1][0]][0] == pytest.approx(
        manipulator_mems.FIRST_MODE_HZ, rel=1e-5)
    np.testing.assert_allclose(natural_frequencies(load_scene("manipulator_mems"), MODES)
                               .frequencies_hz, after, rtol=1e-12)


@pytest.mark.slow  # a variant of manipulator_control (docs/verification.md, the tiers)
def test_the_exact_constraint_check_says_what_it_says_of_the_macro_design(tmp_path, capsys):
    """At 1/100 of the size the rank decisions are the macro design's, word for word: the
    dynamic model has NDOF = 816 - 144 - 597 = 75 and flexure chooses the same 75 DOFs, the
    kinematic guidance is refused with NDOF = 120 - 24 - 98 = -2 naming the same three
    redundancies and proposing the same release, the kinematic stage has its six DOFs (the
    rotation columns of the rank decisions are in metres through 1 / the length scale:
    constraints.column_scale)."""
    macro, mems = load_scene("manipulator_control"), load_scene("manipulator_mems")
    counts = ("nx", "nxo", "neo", "ndof")
    assert [check_exact_constraint(mems)[k] for k in counts] == \
        [check_exact_constraint(macro)[k] for k in counts] == [816, 144, 597, 75]
    assert mems.dof_names == macro.dof_names
    table = manipulator_mems.mems_parameters()
    refusals = []
    for name, scene in (("macro", manipulator.scene_guidance()),
                        ("mems", manipulator.scene_guidance(table))):
        path = tmp_path / f"{name}.toml"
        path.write_text(scene_toml(scene))
        code, out, err = run(capsys, "analyze", path)
        assert code != 0 and "so 3 of them are redundant" in err
        refusals.append(err.replace(str(path), "SCENE"))
    assert refusals[0] == refusals[1]  # the redundancies named and the release proposed
    assert "g1_leaf2.e4, g1_leaf4.e4, g1_pivotT.e4 (released instead of prescribed zero" in \
        refusals[0]
    assert "NDOF = NX - NXO - NEO = 120 - 24 - 98 = -2" in refusals[1]
    stage = build_model(manipulator.scene_stage(table))
    assert stage.ndof == 6 and stage.dof_names == ["C1.x", "C1.y", "C2.x", "C2.y", "C3.x",
                                                   "C3.y"]


def _x1(model, x):
    return output_value(model, model.outputs[0], x) - output_value(
        model, model.outputs[0], model.initial_coordinates)


@pytest.mark.slow
def test_a_short_step_is_the_linearisation_plus_a_second_order_part():
    """The first 1 ms of the step (the first peak is at 0.46 ms) against the linearisation
    stepped exactly: they differ by the geometric nonlinearity, which is proportional to the
    force (1.2 % of the peak at 10 uN, 0.12 % at 1 uN, measured); the first peak of a lightly
    damped step lies below twice the static deflection."""
    model = load_scene("manipulator_mems")
    force = manipulator_mems.STEP_FORCE
    deviations = []
    for f in (force, force / 10):
        result = simulate(model, 1e-3, inputs={"F1": f}, rtol=1e-8)
        times, linear = manipulator_mems.linear_step(model, 1e-3, sample=1e-5, force=f)
        linear = linear - linear[0]
        x1 = np.interp(times, result.times, result.outputs["x1"]) - result.outputs["x1"][0]
        deviations.append(np.abs(x1 - linear).max() / linear.max())
        static = _x1(model, static_equilibrium(model, inputs={"F1": f}).x)
        assert 1.8 * static < x1.max() < 2.0 * static
    assert deviations[0] < 0.02 and deviations[1] < 0.002
    assert deviations[0] / deviations[1] == pytest.approx(10.0, rel=0.2)


@pytest.mark.slow
def test_the_step_settles_as_its_linearisation_to_the_static_deflection(tmp_path, capsys):
    """`flexure simulate manipulator_mems --t-end 0.1 --input F1=1e-5 --method esdirk3 --rtol
    1e-7` as docs/manipulator.md runs it (about a minute): x1 settles into 2 % of the static
    deflection within the linearisation's settling time (0.0746 s, 0.4 s stepped exactly)
    +- 5 %; the plot is written. (The decay over some 60 periods needs an integrator whose
    error stays small against the 2 % band: CVODE's BDF at rtol 1e-6 settles at 83.5 ms.)"""
    model = load_scene("manipulator_mems")
    csv, png = tmp_path / "step.csv", tmp_path / "step.png"
    code, out, err = run(capsys, "simulate", "manipulator_mems", "--t-end", 0.1, "--input",
                         f"F1={manipulator_mems.STEP_FORCE}", "--method", "esdirk3", "--rtol",
                         1e-7, "--samples",
                         5000, "--out", csv, "--plot", png)
    assert code == 0, err
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    x1 = data[:, 1] - data[0, 1]
    static = _x1(model, static_equilibrium(model, inputs={"F1": manipulator_mems.STEP_FORCE}).x)
    settled = manipulator_mems.settle_time(data[:, 0], x1, static)
    times, linear = manipulator_mems.linear_step(model, 0.4)
    expected = manipulator_mems.settle_time(times, linear - linear[0], linear[-1] - linear[0])
    assert settled == pytest.approx(expected, rel=0.05)
    assert 1.8 * static < x1.max() < 2.0 * static
    assert png.stat().st_size > 10_000
