"""Principal gains: the singular values of the transfer matrix from the inputs to the outputs
against frequency (`flexure analyze --sigma`), against python-control's own frequency response
and the static compliance of the nonlinear statics."""

import copy
import json

import numpy as np
import pytest

from flexure.core import (
    build_model,
    linearize,
    load_scene,
    state_space,
    state_space_matrices,
    static_equilibrium,
    static_gain,
)
from flexure.core.analysis.statespace import frequency_grid, principal_gains
from flexure.core.cli import main
from flexure.core.scene.building import parse_toml, scene_path


def two_by_two():
    """stage_planar_3dof with a second input, a vertical force on the bar: 2 x 2."""
    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    data["inputs"]["Fy"] = {"node": "3", "coordinate": "y"}
    return build_model(data)


@pytest.mark.parametrize("model", [load_scene("stage_planar_3dof"), two_by_two()],
                         ids=["1x2", "2x2"])
def test_gains_are_the_singular_values_of_python_controls_response(model):
    frequencies = frequency_grid([10.6, 2129.0, 3586.0], points=60)
    gains = principal_gains(model, frequencies)
    system = state_space(model)
    for f, sigma in zip(frequencies, gains, strict=True):
        G = np.atleast_2d(system(2j * np.pi * f))
        expected = np.linalg.svd(G.reshape(len(model.outputs), len(model.inputs)),
                                 compute_uv=False)
        np.testing.assert_allclose(sigma, expected, rtol=1e-8)


def test_low_frequency_gains_are_the_static_compliance():
    """At 0 Hz the gains are the singular values of the compliance (m/N) that the nonlinear
    statics give for 1 mN on each input (its nonlinearity about 1e-6 of it)."""
    model = two_by_two()
    compliance = np.zeros((2, 2))
    x0 = model.initial_coordinates[[p.coordinate for p in model.outputs]]
    for column, port in enumerate(model.inputs):
        loads = model.loads.copy()
        loads[port.coordinate] += 1e-3
        x = static_equilibrium(model, loads=loads).x[[p.coordinate for p in model.outputs]]
        compliance[:, column] = (x - x0) / 1e-3
    expected = np.linalg.svd(compliance, compute_uv=False)
    np.testing.assert_allclose(principal_gains(model, [0.0])[0], expected, rtol=1e-4)


def with_velocity_outputs():
    """two_by_two with the velocities of the bar's x and y as outputs too: 4 x 2."""
    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    data["inputs"]["Fy"] = {"node": "3", "coordinate": "y"}
    for axis in "xy":
        data["outputs"][f"v{axis}"] = {"node": "3", "coordinate": axis, "quantity": "velocity"}
    return build_model(data)


@pytest.mark.parametrize("make", [lambda: load_scene("stage_planar_3dof"), two_by_two,
                                  with_velocity_outputs], ids=["1x2", "2x2", "4x2"])
def test_the_static_gain_is_d_minus_c_a_inverse_b(make):
    """The static gain through the tangent K is the state space's D - C A^-1 B (A's solve
    carries cond(A), 5e8 here; measured 2e-18 of the largest gain), and a velocity output's
    gain is exactly zero."""
    model = make()
    A, B, C, D = state_space_matrices(model)
    expected = D - C @ np.linalg.solve(A, B)
    gain = static_gain(model)
    assert gain.shape == (len(model.outputs), len(model.inputs))
    np.testing.assert_allclose(gain, expected, rtol=0.0, atol=1e-9 * np.abs(expected).max())
    velocity = [p.quantity == "velocity" for p in model.outputs]
    assert np.all(gain[velocity] == 0.0)
    np.testing.assert_allclose(np.linalg.svd(gain, compute_uv=False),
                               principal_gains(model, [0.0])[0], rtol=1e-7)


def test_the_static_gain_of_a_voltage_driven_coil_is_km_over_r_k():
    """With a coil's current in the state the gain is D - C A^-1 B: Km / (R k) m/V for the
    truss driven through a voltage-driven actuator (its spring k = EA / l)."""
    data = parse_toml(scene_path("truss_1dof_x"))
    data["nodes"]["2"].pop("force")
    data["actuators"] = {"VCM1": {"input": "F", "force_constant": 2.0, "resistance": 2.0,
                                  "inductance": 0.01}}
    model = build_model(data)
    k = linearize(model).K[0, 0]
    expected = 2.0 / (2.0 * k)
    assert abs(static_gain(model).item() - expected) <= 1e-12 * expected


def test_the_solve_path_gives_the_same_gains(monkeypatch):
    """Where the eigenvectors of A are ill-conditioned the gains come from a solve per
    frequency: the same numbers."""
    model = two_by_two()
    frequencies = [1.0, 10.6, 100.0, 3586.0]
    modal = principal_gains(model, frequencies)
    monkeypatch.setattr(np.linalg, "cond", lambda matrix: np.inf)
    np.testing.assert_allclose(principal_gains(model, frequencies), modal, rtol=1e-9)


def test_a_repeated_natural_frequency_is_one_point_of_the_grid():
    """Copies of a natural frequency within round-off (a symmetric mechanism's repeated
    mode) add one point, whichever copies round-off made distinct; distinct ones add one
    each."""
    plain = frequency_grid([10.0, 444.86], points=50)
    assert plain.size == 52 and 10.0 in plain and 444.86 in plain
    for copies in ([444.86, 444.86, 444.86], [444.86, 444.86 * (1 + 3e-12), 444.86 * (1 - 2e-12)]):
        grid = frequency_grid([10.0, *copies], points=50)
        assert grid.size == 52 and np.all(np.diff(grid) > 0.0)
    assert frequency_grid([10.0, 444.86, 444.86 * 1.001], points=50).size == 53


def test_a_bad_frequency_is_refused():
    with pytest.raises(ValueError, match="expected finite frequencies >= 0"):
        principal_gains(load_scene("stage_planar_3dof"), [-1.0])


def test_analyze_plots_the_gains_and_names_the_peaks(tmp_path, capsys):
    path = tmp_path / "sigma.png"
    assert main(["analyze", "stage_planar_3dof", "--sigma", str(path)]) == 0
    out = capsys.readouterr().out
    assert "principal gains from F to x, y" in out and "10.6447" in out
    assert path.stat().st_size > 10_000


def test_analyze_sigma_over_a_band_of_ones_choice(tmp_path, capsys):
    """--sigma-range FMIN:FMAX: the gains over that band only, the natural frequencies inside
    it named (the 3-DOF stage's 2129 and 3586 Hz modes lie outside 1 to 100 Hz)."""
    path = tmp_path / "sigma.png"
    assert main(["analyze", "stage_planar_3dof", "--sigma", str(path), "--sigma-range",
                 "1:100", "--json"]) == 0
    gains = json.loads(capsys.readouterr().out)["principal_gains"]
    assert min(gains["frequencies_hz"]) == pytest.approx(1.0, rel=1e-12)
    assert max(gains["frequencies_hz"]) == pytest.approx(100.0, rel=1e-12)
    assert main(["analyze", "stage_planar_3dof", "--sigma", str(path), "--sigma-range",
                 "1:100"]) == 0
    out = capsys.readouterr().out
    assert "(401 frequencies, 1 to 100 Hz)" in out and "10.6447" in out and "2128" not in out


@pytest.mark.parametrize("argv, says", [
    (["--sigma-range", "1:100"], "--sigma-range: it sets the frequencies of --sigma, which is "
                                 "not given"),
    (["--sigma", "s.png", "--sigma-range", "100:1"], "argument --sigma-range: expected "
                                                      "FMIN:FMAX in Hz with 0 < FMIN < FMAX, "
                                                      "got '100:1'"),
    (["--sigma", "s.png", "--sigma-range", "0:5"], "expected FMIN:FMAX in Hz"),
    (["--sigma", "s.png", "--sigma-range", "5"], "expected FMIN:FMAX in Hz"),
])
def test_a_bad_sigma_range_is_refused(argv, says, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(["analyze", "stage_planar_3dof", *argv])
    except SystemExit as exit_:  # argparse refuses an option's value itself
        code = exit_.code
    err = capsys.readouterr().err
    assert code == 2 and says in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())


def test_analyze_sigma_needs_inputs_and_outputs(tmp_path, capsys):
    from flexure.core.scene.scene_writer import scene_toml

    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    del data["inputs"]
    scene = tmp_path / "no_inputs.toml"
    scene.write_text(scene_toml(data))
    plot = tmp_path / "never.png"
    assert main(["analyze", str(scene), "--sigma", str(plot)]) == 2
    err = capsys.readouterr().err
    assert "a state-space model needs [inputs] and [outputs]" in err and "Traceback" not in err
    assert not plot.exists()
