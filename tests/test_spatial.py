"""The spatial leaf-spring stage of the course notes against the planar models and figures.

Figures (shared/reference/figures.md, course notes "Three-dimensional model"): NDOF =
24 - 12 - 11 = 1 and 42 - 12 - 11 = 19 with 25 released deformations; first frequency about
10.6 Hz (10.645 Hz with the consistent beam mass, as the planar pf2db); the 3-D stage without
the local cut is over-constrained. Independent references: the planar scenes (the same
mechanism in the x-y plane), and the linear clamped-guided spring for the stresses.
"""

import copy
import json
import tomllib

import numpy as np
import pytest

from flexure.core import (
    ConstraintError,
    buckling_load_factors,
    build_model,
    load_scene,
    natural_frequencies,
    scene_path,
    static_equilibrium,
)
from flexure.core.analysis.stresses import beam_stresses
from flexure.core.cli import main

PLANAR_FREQUENCY = 10.64484738  # Hz, stage_planar_1dof (the planar figures check)


def scene_data(name):
    return tomllib.loads(scene_path(name).read_text())


def sideways(model, force=1.0):
    """The model's loads plus `force` N along x on node 3."""
    loads = model.loads.copy()
    loads[model.coordinate_index("3.x")] += force
    return loads


def test_dof_counts_follow_the_course_notes():
    one = load_scene("stage_spatial_1dof")
    assert one.dof_count() == {"nx": 24, "nxo": 12, "neo": 11, "ndof": 1}
    nineteen = load_scene("stage_spatial_19dof")
    assert nineteen.dof_count() == {"nx": 42, "nxo": 12, "neo": 11, "ndof": 19}
    released = nineteen.released_deformations.size + nineteen.dof_deformations.size
    assert released == 25


def test_1dof_spatial_stage_has_the_planar_frequency_and_buckling_load():
    model = load_scene("stage_spatial_1dof")
    frequency = natural_frequencies(model).frequencies_hz
    np.testing.assert_allclose(frequency, [PLANAR_FREQUENCY], rtol=1e-9)
    np.testing.assert_allclose(buckling_load_factors(model), [78.75], rtol=1e-9)


@pytest.mark.parametrize("force", [1.0, 30.0])
def test_planar_motion_of_the_spatial_model_equals_the_planar_model(force):
    """1 N (linear) and 30 N (x = 27 mm: geometrically nonlinear) sideways, to 1e-9."""
    planar, spatial = load_scene("stage_planar_1dof"), load_scene("stage_spatial_1dof")
    p = static_equilibrium(planar, loads=sideways(planar, force))
    s = static_equilibrium(spatial, loads=sideways(spatial, force))
    for name in ("3.x", "3.y", "5.x", "5.y"):
        assert abs(s.x[spatial.coordinate_index(name)]
                   - p.x[planar.coordinate_index(name)]) < 1e-9 * 0.1
    for name in ("3.z", "5.z"):
        assert abs(s.x[spatial.coordinate_index(name)]) < 1e-15
    # the stress resultants: planar e2, e3 are e5, e6 of the spatial beam (the sign change
    # of the definitions and that of the axes cancel: the planar beam's y axis is -x, y' is x)
    for element in ("leaf_left", "leaf_right"):
        for planar_e, spatial_e in (("e2", "e5"), ("e3", "e6"), ("e1", "e1")):
            a = p.stresses()[f"{element}.{planar_e}"]
            b = s.stresses()[f"{element}.{spatial_e}"]
            assert abs(a - b) <= 1e-9 * max(1.0, abs(a))
    if force == 1.0:
        np.testing.assert_allclose(p.x[planar.coordinate_index("3.x")], 1.0 / 945.0, rtol=1e-4)


def test_planar_motion_in_time_equals_the_planar_model():
    """The same VCM force on the planar and the spatial 1-DOF stage.

    The equations of motion agree to 1e-9: the accelerations of both models in every state of
    the planar trajectory. The trajectories, each integrated with rtol = 1e-10, agree to
    1e-9 m on a 3.6 mm motion: what is left is the integrators' own error.
    """
    from flexure.core.simulation.simulation import Simulator, simulate

    def force(t):
        return 2.0 * np.sin(2 * np.pi * 5.0 * t)

    times = np.linspace(0.0, 0.2, 41)
    models = [load_scene(name) for name in ("stage_planar_1dof", "stage_spatial_1dof")]
    results = [simulate(m, 0.2, inputs={"F": force}, rtol=1e-10, output_times=times)
               for m in models]
    planar, spatial = (r.outputs for r in results)
    assert np.max(np.abs(planar["x"])) > 3e-3  # it moves
    np.testing.assert_allclose(spatial["x"], planar["x"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(spatial["y"], planar["y"], rtol=0, atol=1e-9)
    simulators = [Simulator(m) for m in models]
    trajectory = results[0]
    n = trajectory.q.shape[1]
    for q, qdot, u in zip(trajectory.q, trajectory.qdot, trajectory.inputs, strict=True):
        accelerations = []
        for sim in simulators:  # qddot: the second half of ydot at the deviation state
            sim.set_inputs(u)
            accelerations.append(sim.derivative(0.0, np.concatenate([q - sim.q_ref, qdot]))[n:])
        np.testing.assert_allclose(accelerations[1], accelerations[0], rtol=1e-9, atol=1e-12)


def test_19dof_stage_gives_the_planar_frequency_and_deflection():
    model = load_scene("stage_spatial_19dof")
    modes = natural_frequencies(model)
    assert modes.frequencies_hz.size == 19
    np.testing.assert_allclose(modes.frequencies_hz[0], PLANAR_FREQUENCY, rtol=5e-3)
    assert modes.frequencies_hz[1] > 10 * modes.frequencies_hz[0]
    solution = static_equilibrium(model)  # its own load: 1 N sideways on node 3
    planar = load_scene("stage_planar_1dof")
    reference = static_equilibrium(planar, loads=sideways(planar))
    # linear: the cubic beam is exact for a clamped-guided spring; the refined spring
    # differs only in the second-order shortening (3e-5 of the deflection)
    np.testing.assert_allclose(solution.x[model.coordinate_index("3.x")],
                               reference.x[planar.coordinate_index("3.x")], rtol=1e-4)


def test_3d_stage_without_the_local_cut_is_refused_naming_the_redundant_constraints():
    data = scene_data("stage_spatial_1dof")
    data["elements"]["leaf_right"]["released"] = ["e5", "e6"]
    with pytest.raises(ConstraintError) as error:
        build_model(data, source="no_cut.toml")
    message = str(error.value)
    assert "no_cut.toml" in message
    assert "NDOF = NX - NXO - NEO = 24 - 12 - 14 = -2" in message
    assert "over-constrained" in message
    # the constraints that the cut releases are named among the redundant ones
    for name in ("leaf_right.e2", "leaf_right.e3", "leaf_right.e4"):
        assert name in message


def test_von_mises_stresses_for_1n_sideways_match_the_clamped_guided_spring():
    """Each spring carries 0.5 N shear: end moments F l / 4 = 0.025 N m, sigma = M / W with
    W = b h^2 / 6 = 7.5e-10 m^3: 33.33 MPa at both ends, zero mid-spring but for the normal
    force +-0.5 N (the overturning couple F h / d) over A = 9e-6 m^2: 0.0556 MPa."""
    model = load_scene("stage_spatial_19dof")
    solution = static_equilibrium(model)
    stresses = beam_stresses(model, solution.x, solution.stress_resultants)
    assert stresses.names == ["leaf_left_1", "leaf_left_2", "leaf_left_3", "leaf_left_4",
                              "leaf_right"]
    bending = 0.025 / (0.018 * 0.0005**2 / 6)
    vm = stresses.as_dict()
    np.testing.assert_allclose(vm["leaf_left_1"][0], bending, rtol=5e-3)
    np.testing.assert_allclose(vm["leaf_left_4"][1], bending, rtol=5e-3)
    np.testing.assert_allclose(vm["leaf_right"], [bending, bending], rtol=5e-3)
    np.testing.assert_allclose(vm["leaf_left_1"][1], bending / 2, rtol=5e-3)
    np.testing.assert_allclose(vm["leaf_left_2"][1], 0.5 / 9e-6, rtol=2e-2)
    assert stresses.maximum()[0] == "leaf_left_1"


def test_cli_lists_19_frequencies_and_plots_the_stresses(tmp_path, capsys):
    plot = tmp_path / "stresses.png"
    code = main(["analyze", str(scene_path("stage_spatial_19dof")), "--static", "--modes",
                 "--json", "--plot", str(plot)])
    assert code in (0, None)
    result = json.loads(capsys.readouterr().out)
    assert result["dof_count"] == {"nx": 42, "nxo": 12, "neo": 11, "ndof": 19}
    assert len(result["modes"]["frequencies_hz"]) == 19
    von_mises = result["static"]["von_mises_pa"]
    assert set(von_mises) == {"leaf_left_1", "leaf_left_2", "leaf_left_3", "leaf_left_4",
                              "leaf_right"}
    assert 33e6 < von_mises["leaf_left_1"][0] < 34e6
    assert plot.stat().st_size > 10_000
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_plot_without_beam_sections_is_an_error(tmp_path, capsys):
    """truss_1dof_x gives its truss's EA alone, no dimensions."""
    code = main(["analyze", "truss_1dof_x", "--plot", str(tmp_path / "s.png")])
    assert code == 2
    assert "no beam or truss with section dimensions" in capsys.readouterr().err


def test_19dof_stage_simulates_for_one_second_with_cvode_and_ida():
    """From the static equilibrium under the scene's 1 N, a VCM force rising smoothly from 0
    to 1 N in 0.5 s (a fifth-order smooth step), then held: at 1 s the stage is at the static
    deflection under 2 N (to the small residual vibration) and the two integrators agree; the
    von Mises stresses follow along the motion."""
    from flexure.core.analysis.stresses import stresses_along
    from flexure.core.simulation.simulation import simulate

    def vcm(t):
        s = min(t / 0.5, 1.0)
        return s * s * s * (10 - 15 * s + 6 * s * s)

    model = load_scene("stage_spatial_19dof")
    start = static_equilibrium(model)
    times = np.linspace(0.0, 1.0, 11)
    results = {method: simulate(model, 1.0, inputs={"F": vcm}, method=method, rtol=1e-8,
                                output_times=times, q0=start.q)
               for method in ("cvode-bdf", "ida")}
    static = static_equilibrium(model, loads=sideways(model, 1.0))
    x_static = static.x[model.coordinate_index("3.x")]
    for result in results.values():
        x_end = result.outputs["x"][-1]
        assert abs(x_end - x_static) < 0.02 * x_static
    np.testing.assert_allclose(results["ida"].outputs["x"], results["cvode-bdf"].outputs["x"],
                               rtol=0, atol=1e-4 * x_static)
    final = results["cvode-bdf"]
    states = np.hstack([final.q, final.qdot])[-1:]
    names, along = stresses_along(model, states, inputs=final.inputs[-1:])
    assert names[0] == "leaf_left_1"
    # twice the 1 N clamp stress, within the residual vibration
    np.testing.assert_allclose(along[0, 0, 0], 2 * 33.4e6, rtol=0.03)


def test_spatial_scene_errors_name_the_key():
    from flexure.core import SceneError

    def broken(edit):
        data = copy.deepcopy(scene_data("stage_spatial_1dof"))
        edit(data)
        with pytest.raises(SceneError) as error:
            build_model(data, source="s.toml")
        return str(error.value)

    msg = broken(lambda d: d["elements"]["leaf_left"].pop("y_axis"))
    assert "elements.leaf_left" in msg and "y_axis" in msg
    msg = broken(lambda d: d["elements"]["leaf_left"].update(y_axis=[0.0, 2.0, 0.0]))
    assert "elements.leaf_left.y_axis" in msg and "along the beam" in msg
    msg = broken(lambda d: d["nodes"]["2"].update(fixed=["lambda1"]))
    assert "nodes.2.fixed" in msg and "as a whole" in msg
    msg = broken(lambda d: d["nodes"]["4"].pop("rotation"))
    assert "nodes.4" in msg and "'rotation'" in msg
    msg = broken(lambda d: d["sections"]["leaf"].pop("height"))
    assert "sections.leaf" in msg and "height" in msg
    msg = broken(lambda d: d["inputs"].update(M={"node": "4", "coordinate": "lambda1"}))
    assert "inputs.M.coordinate" in msg and "Euler parameters" in msg
    msg = broken(lambda d: d["scene"].update(dimension=4))
    assert "scene.dimension" in msg and "3 (spatial)" in msg


def test_spatial_speed_benchmark_runs():
    from examples import benchmark_spatial

    rows = benchmark_spatial.benchmark(t_end=0.05, scenes=("stage_spatial_19dof",),
                                       rtols=(1e-6,))
    assert [row[1] for row in rows] == ["cvode-bdf", "ida"]
    for row in rows:
        assert row[3] > 0 and row[6] > 0
        assert 1.0 < row[7] < 1.2  # mm: the bar has started to move from 1.058 mm


@pytest.mark.parametrize("direction", [[1.0, 0.0, 0.0], [1.0, -2.0, 2.0]])
def test_spatial_truss_model_gives_the_truss_figures(direction):
    """pf1dtrx as a spatial TRUSS: 10.6584 Hz and x = 0.1 + 1 / 945 under 1 N (figures.md).

    Along x the sideways coordinates of node 2 are fixed (exactly the planar model, to 1e-9).
    Along a skew axis two rigid massless 10 m TRUSS guides, normal to it, hold node 2 on its
    line; they let it leave the line by (1 mm)^2 / 20 m = 5e-8 m, hence the looser tolerance.
    """
    axis = np.array(direction) / np.linalg.norm(direction)
    data = scene_data("truss_1dof_x")
    data["scene"]["dimension"] = 3
    data["nodes"]["1"].update(position=[0.0, 0.0, 0.0], fixed=["x", "y", "z"])
    data["nodes"]["2"].update(position=(0.1 * axis).tolist(), force=axis.tolist())
    data["elements"]["spring"]["type"] = "TRUSS"
    skew = direction != [1.0, 0.0, 0.0]
    if skew:
        normal = np.cross(axis, [0.0, 0.0, 1.0])
        normal /= np.linalg.norm(normal)
        binormal = np.cross(axis, normal)
        del data["nodes"]["2"]["fixed"], data["nodes"]["2"]["dof"]
        data["elements"]["spring"].update(dof=["e1"], released=[])
        data["sections"]["rigid"] = {"EA": 0.0}
        for name, vector in (("n", normal), ("b", binormal)):
            data["nodes"][name] = {"position": (0.1 * axis + 10.0 * vector).tolist(),
                                   "fixed": ["x", "y", "z"]}
            data["elements"][f"guide_{name}"] = {"type": "TRUSS", "nodes": ["2", name],
                                                 "section": "rigid"}
        del data["inputs"], data["outputs"]
    else:
        data["nodes"]["2"]["fixed"] = ["y", "z"]
    model = build_model(data)
    assert model.dof_count()["ndof"] == 1
    tolerance = 1e-7 if skew else 1e-9
    np.testing.assert_allclose(natural_frequencies(model).frequencies_hz, [10.65843552],
                               rtol=tolerance)
    solution = static_equilibrium(model)
    tip = solution.x[[model.coordinate_index(f"2.{c}") for c in "xyz"]]
    np.testing.assert_allclose(tip, (0.1 + 1.0 / 945.0) * axis, rtol=0, atol=tolerance)
