"""Pictures of a model (core/analysis/pictures.py): the drawn centre lines against the
model's coordinates and the beam's analytic bending line, the magnification against the
model's known size, and the PNG and GIF files and their refusals on the command line."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from flexure.core import build_model, load_scene, natural_frequencies, static_equilibrium
from flexure.core.analysis import pictures
from tests.cli_runs import run

PNG = b"\x89PNG\r\n\x1a\n"
FIGURE = Path(__file__).resolve().parents[1] / "examples" / "figures" / \
    "stage_planar_3dof_modes.png"




def position(model, x, node):
    """The position (m) of a translational node from the named coordinates."""
    axes = "xyz"[: model.dimension]
    return np.array([x[model.coordinate_index(f"{node}.{a}")] for a in axes])


# -- what is drawn ---------------------------------------------------------------------------

def test_centre_lines_of_the_loaded_planar_stage_end_at_the_nodes():
    model = load_scene("stage_planar_3dof")
    loads = np.zeros(model.nx)
    loads[model.coordinate_index("3.x")] = 1.0  # N sideways: the leaves bend
    x = static_equilibrium(model, loads=loads).x
    left, bar, right = pictures.centre_lines(model, x)
    for line, (p, q) in zip((left, bar, right), [("1", "3"), ("3", "5"), ("7", "5")],
                            strict=True):
        assert line.shape == (pictures.POINTS, 2)
        np.testing.assert_allclose(line[0], position(model, x, p), atol=1e-15)
        np.testing.assert_allclose(line[-1], position(model, x, q), atol=1e-15)
    # the leaves are drawn bent: the middle point is off the chord by a fraction of the tip
    chord_middle = 0.5 * (left[0] + left[-1])
    assert abs(left[pictures.POINTS // 2, 0] - chord_middle[0]) < 0.1 * abs(left[-1, 0])
    assert 1e-4 < left[-1, 0] < 1e-2  # 1 N moves the stage by about 2 mm


def test_a_straight_unloaded_beam_is_drawn_straight_through_its_midpoint():
    for name in ("stage_planar_3dof", "stage_spatial_1dof"):
        model = load_scene(name)
        for line in pictures.centre_lines(model, model.initial_coordinates):
            middle = line[pictures.POINTS // 2]
            np.testing.assert_allclose(middle, 0.5 * (line[0] + line[-1]), atol=1e-15)
            # every point on the chord, evenly spaced
            s = np.linspace(0.0, 1.0, pictures.POINTS)[:, None]
            np.testing.assert_allclose(line, line[0] + s * (line[-1] - line[0]), atol=1e-15)


def test_a_cantilever_under_an_end_moment_is_drawn_as_its_bending_line():
    """An end moment M bends a cantilever into v(s) = M s^2 / (2 EI): quadratic, which the
    cubic Hermite curve holds exactly; so the drawn curve is the analytic one to the
    geometric nonlinearity of a 1e-5 rotation."""
    length, ei, moment = 0.1, 0.04, 4e-6  # m, N m^2, N m: a tip rotation of 1e-5 rad
    scene = {
        "scene": {"name": "cantilever", "dimension": 2},
        "sections": {"leaf": {"EA": 1e7, "EI": ei, "rho_A": 0.1}},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"angle": 0.0, "fixed": ["phi"]},
                  "3": {"position": [length, 0.0], "dof": ["x", "y"]},
                  "4": {"angle": 0.0, "dof": ["phi"], "moment": moment}},
        "elements": {"leaf": {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"],
                              "section": "leaf", "released": ["e1", "e2", "e3"]}},
    }
    model = build_model(scene)
    x = static_equilibrium(model).x
    (line,) = pictures.centre_lines(model, x, points=5)
    s = np.linspace(0.0, 1.0, 5)
    np.testing.assert_allclose(line[:, 1], moment * (s * length) ** 2 / (2 * ei),
                               rtol=1e-4, atol=1e-16)
    np.testing.assert_allclose(line[:, 0], s * length, rtol=1e-9)


def test_a_mode_shape_is_drawn_at_reference_plus_scale_times_shape():
    model = load_scene("stage_planar_3dof")
    modes = natural_frequencies(model, 3)
    reference = modes.linear_model.solution.x
    size = 0.1  # m: the stage is 0.1 m wide and 0.1 m high
    assert pictures.model_size(model, reference) == pytest.approx(size)
    for k in range(3):
        shape = modes.coordinate_shapes[:, k]
        scale = pictures.displacement_scale(model, reference, shape)
        drawn = pictures.centre_lines(model, pictures.scaled(model, reference, shape, scale))
        largest = 0.0
        for line, (p, q) in zip(drawn, [("1", "3"), ("3", "5"), ("7", "5")], strict=True):
            for point, node in ((line[0], p), (line[-1], q)):
                expected = position(model, reference, node) + scale * position(model, shape,
                                                                                node)
                np.testing.assert_allclose(point, expected, atol=1e-15)
                largest = max(largest, np.linalg.norm(point - position(model, reference, node)))
        # two significant digits of the scale: within 5 % of the stated 10 %
        assert largest / size == pytest.approx(pictures.FRACTION, rel=0.05)


def test_a_spatial_rotation_magnified_stays_a_rotation():
    model = load_scene("stage_spatial_1dof")
    modes = natural_frequencies(model, 1)
    reference = modes.linear_model.solution.x
    shape = modes.coordinate_shapes[:, 0]
    x = pictures.scaled(model, reference, shape, 1e3)
    for node in model.nodes:
        if node.kind == "rotational":
            assert np.linalg.norm(x[list(node.coordinates)]) == pytest.approx(1.0)


def test_an_unloaded_equilibrium_is_no_displacement_and_is_not_magnified():
    model = load_scene("stage_planar_3dof")
    x = static_equilibrium(model).x  # at rest where it was built, to round-off
    assert pictures.displacement_scale(model, model.initial_coordinates,
                                       x - model.initial_coordinates) == 1.0


def test_frames_are_at_most_a_hundred_nearest_to_even_times():
    times = np.sort(np.random.default_rng(1).uniform(0.0, 1.0, 5000))
    chosen = pictures.frame_indices(times)
    assert chosen.size <= pictures.MAX_FRAMES and chosen.size > 95
    assert np.all(np.diff(chosen) > 0) and chosen[0] == 0 and chosen[-1] == times.size - 1
    assert np.max(np.abs(times[chosen] - np.linspace(times[0], times[-1], chosen.size))) < 0.02
    assert pictures.frame_indices(np.arange(7.0)).tolist() == list(range(7))


# -- the files -------------------------------------------------------------------------------

def test_shape_and_modes_are_written_as_png_planar_and_spatial(tmp_path):
    for name in ("stage_planar_3dof", "stage_spatial_19dof"):
        model = load_scene(name)
        solution = static_equilibrium(model)
        pictures.plot_shape(model, solution.x, tmp_path / f"{name}_shape.png")
        scales = pictures.plot_modes(model, natural_frequencies(model, 2),
                                     tmp_path / f"{name}_modes.png", count=4)
        assert len(scales) == 2  # only two modes were computed
        for picture in ("shape", "modes"):
            path = tmp_path / f"{name}_{picture}.png"
            assert path.read_bytes()[:8] == PNG and path.stat().st_size > 10_000


def test_animation_is_a_gif_with_one_frame_per_chosen_time(tmp_path):
    model = load_scene("stage_planar_3dof")
    times = np.linspace(0.0, 0.1, 31)
    ramp = np.outer(np.sin(2 * np.pi * 10 * times), [1e-3, 0.0, 0.0])  # x of node 3, m
    q0 = static_equilibrium(model).q
    result = SimpleNamespace(times=times, q=q0 + ramp)
    path = tmp_path / "run.gif"
    scale = pictures.animate(model, result, path, frames=12)
    assert path.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    with Image.open(path) as image:
        assert image.format == "GIF" and image.n_frames == 12
    assert scale == pytest.approx(pictures.FRACTION * 0.1 / 1e-3, rel=0.05)


def test_a_spatial_animation_is_drawn_in_3d(tmp_path):
    model = load_scene("stage_spatial_1dof")
    q0 = static_equilibrium(model).q
    result = SimpleNamespace(times=np.linspace(0.0, 0.01, 4),
                             q=q0 + np.linspace(0.0, 1e-3, 4)[:, None])  # m along the DOF
    path = tmp_path / "spatial.gif"
    pictures.animate(model, result, path)
    with Image.open(path) as image:
        assert image.format == "GIF" and image.n_frames == 4
    xs = pictures.coordinates_along(model, result.q)
    assert xs.shape == (4, model.nx)  # each frame's configuration holds its DOF value
    np.testing.assert_allclose(xs[:, model.dof_coordinates[0]], result.q[:, 0], atol=1e-12)


# -- the command line ------------------------------------------------------------------------

def test_analyze_draws_the_shape_and_the_modes(tmp_path, capsys):
    shape, modes = tmp_path / "shape.png", tmp_path / "modes.png"
    code, out, err = run(capsys, "analyze", "stage_spatial_19dof", "--static", "--modes", "2",
                         "--plot-shape", shape, "--plot-modes", modes)
    assert code == 0 and "static equilibrium" in out
    # said where stdout (the tables, or the JSON) stays what it is
    assert f"flexure analyze: wrote {shape} (the static equilibrium's deformed shape)" in err
    assert f"flexure analyze: wrote {modes} (the 2 lowest mode shapes)" in err
    for path in (shape, modes):
        assert path.read_bytes()[:8] == PNG
    with Image.open(modes) as image:  # two panels side by side
        assert image.size[0] > 1.5 * image.size[1]


def test_simulate_animates_every_sample_of_a_short_run(tmp_path, capsys):
    path = tmp_path / "run.gif"
    code, out, _ = run(capsys, "simulate", "stage_planar_3dof", "--t-end", "0.02", "--input",
                       "F=1", "--rtol", "1e-6", "--samples", "20", "--animate", path)
    assert code == 0 and f"wrote {path}" in out
    with Image.open(path) as image:
        assert image.format == "GIF" and image.n_frames == 21


@pytest.mark.parametrize("argv, says", [
    (["analyze", "stage_planar_3dof", "--plot-modes", "modes.jpg"], "ending in .png or .pdf"),
    (["analyze", "stage_planar_3dof", "--plot-shape", "shape"], "ending in .png or .pdf"),
    (["simulate", "stage_planar_3dof", "--t-end", "1", "--animate", "run.png"],
     "ending in .gif (not '.png'"),
    (["analyze", "stage_planar_3dof", "--plot-shape", "same.png", "--plot-modes", "same.png"],
     "the same file as --plot-shape"),
    (["analyze", "stage_planar_3dof", "--plot", "same.png", "--sigma", "same.png"],
     "--sigma same.png: the same file as --plot same.png"),
])
def test_wrong_picture_files_are_refused_in_one_line(tmp_path, capsys, monkeypatch, argv, says):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *argv)
    assert code == 2 and says in err.strip().splitlines()[-1]  # one line after the usage
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("argv", [
    ["analyze", "{scene}", "--plot-shape", "{tmp}/shape.png"],
    ["analyze", "{scene}", "--modes", "--plot-modes", "{tmp}/modes.png"],
    ["simulate", "{scene}", "--t-end", "1", "--animate", "{tmp}/run.gif"],
])
def test_a_scene_without_elements_has_no_picture(tmp_path, capsys, monkeypatch, argv):
    scene = tmp_path / "lone.toml"
    scene.write_text('[scene]\nname = "lone"\ndimension = 2\n\n[nodes.a]\n'
                     'position = [0.0, 0.0]\nfixed = ["y"]\ndof = ["x"]\nmass = 1.0\n')
    import flexure.core.simulation.simulation as simulation

    monkeypatch.setattr(simulation, "simulate", lambda *a, **k: pytest.fail("it ran"))
    code, out, err = run(capsys, *[a.format(scene=scene, tmp=tmp_path) for a in argv])
    assert code == 2 and out == ""  # refused before any analysis or run
    assert err.strip().endswith("'lone' has no truss or beam element, so no picture to draw")
    assert len(err.strip().splitlines()) == 1
    with pytest.raises(Exception, match="no truss or beam"):
        pictures.plot_shape(load_scene(scene), np.zeros(2), tmp_path / "never.png")



def test_readme_figure_is_what_the_command_draws(tmp_path, capsys):
    """examples/figures/stage_planar_3dof_modes.png is the README's command's picture
    (compared in pixel size: the bytes differ between matplotlib versions)."""
    path = tmp_path / "modes.png"
    code, _, _ = run(capsys, "analyze", "stage_planar_3dof", "--modes", "3", "--plot-modes",
                     path)
    assert code == 0
    with Image.open(path) as drawn, Image.open(FIGURE) as committed:
        assert drawn.size == committed.size
    assert 0.5 < path.stat().st_size / FIGURE.stat().st_size < 2.0
