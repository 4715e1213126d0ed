"""Parameter overrides (`load_scene(..., overrides=...)`, `--set KEY=VALUE` on every command
that takes a scene): the value reaches the model, and every mistake is one line naming it."""

import json
import math
import tomllib
import zipfile

import pytest

from flexure.core import SceneError, build_model, load_scene, natural_frequencies, scene_path
from flexure.core.cli import main
from flexure.core.scene.overrides import apply_overrides, parse_assignment, parse_value

SCENE = "stage_planar_1dof"
SOURCE = str(scene_path(SCENE))
# the stage of stage_planar_1dof.toml: two steel leaves (E, width w, length L) guiding a rigid
# bar of 0.206 kg. With massless leaves (rho = 0) its one mode is the bar on the two guided
# leaves, k = 2 * 12 E I / L^3 with I = w h^3 / 12, exactly (a cubic beam is exact here).
E, WIDTH, LENGTH, BAR = 2.1e11, 0.018, 0.1, 0.206
MASSLESS_LEAVES = {"sections.leaf.rho": 0.0}


def stage_hz(height, mass):
    """The analytic frequency (Hz) of the stage: f = sqrt(24 E w h^3 / 12 / (L^3 m)) / 2 pi."""
    stiffness = 24.0 * E * WIDTH * height**3 / 12.0 / LENGTH**3
    return math.sqrt(stiffness / mass) / (2.0 * math.pi)


def frequency(**overrides):
    model = load_scene(SCENE, overrides={**MASSLESS_LEAVES, **overrides})
    return natural_frequencies(model).frequencies_hz[0]


def test_leaf_thickness_scales_the_frequency_as_its_power_three_halves():
    thin, thick = 0.3e-3, 0.8e-3
    ratio = frequency(**{"sections.leaf.height": thick}) / frequency(
        **{"sections.leaf.height": thin})
    assert ratio == pytest.approx((thick / thin) ** 1.5, rel=1e-6)
    assert frequency(**{"sections.leaf.height": thin}) == pytest.approx(stage_hz(thin, BAR),
                                                                         rel=1e-9)


def test_an_override_may_add_a_key_the_file_leaves_out():
    assert "mass" not in tomllib.loads(scene_path(SCENE).read_text())["nodes"]["3"]
    payload = 0.2  # kg on node 3, which moves with the bar in x and y
    assert frequency(**{"nodes.3.mass": payload}) == pytest.approx(
        stage_hz(0.5e-3, BAR + payload), rel=1e-9)


def test_build_model_leaves_its_dictionary_as_it_was():
    data = tomllib.loads(scene_path(SCENE).read_text())
    before = json.dumps(data, sort_keys=True)
    build_model(data, overrides={"sections.leaf.height": 0.3e-3, "nodes.3.mass": 0.2})
    assert json.dumps(data, sort_keys=True) == before


def test_numpy_values_and_tuples_become_what_a_toml_file_holds():
    import numpy as np

    data = apply_overrides({"nodes": {"3": {}}},
                           {"nodes.3.mass": np.float64(0.2), "nodes.3.position": (0.0, 1),
                            "nodes.3.force": np.array([1.0, 2.0])})
    node = data["nodes"]["3"]
    assert node == {"mass": 0.2, "position": [0.0, 1], "force": [1.0, 2.0]}
    assert type(node["mass"]) is float and type(node["force"][0]) is float


ERRORS = {
    "a misspelt key": ({"sections.leaf.hieght": 1e-3},
                       "--set sections.leaf.hieght: unknown key; expected one of E, EA"),
    "an unknown node": ({"nodes.99.mass": 0.1},
                        "--set nodes.99.mass: unknown node '99'; the scene's nodes: 1, 2, 3"),
    "an unknown section": ({"sections.steel.E": 2e11},
                           "--set sections.steel.E: unknown section 'steel'; the scene's "
                           "sections: leaf, bar"),
    "an unknown element": ({"elements.leaf.released": []},
                           "--set elements.leaf.released: unknown element 'leaf'"),
    "an unknown table": ({"node.3.mass": 0.1}, "--set node.3.mass: unknown table 'node'"),
    "an entry as a whole": ({"nodes.3": {"mass": 0.1}},
                            "--set nodes.3: expected nodes.NAME.KEY"),
    "a plain table too deep": ({"scene.name.x": "a"}, "--set scene.name.x: expected scene.KEY"),
    "an empty part": ({"nodes..mass": 0.1}, "--set nodes..mass: expected a dotted scene key"),
    "a key that is no string": ({3: 0.1}, "--set 3: expected a dotted scene key"),
    "a string for a number": ({"sections.leaf.height": "thick"},
                              "--set sections.leaf.height: expected a number, got 'thick'"),
    "a negative mass": ({"nodes.3.mass": -0.2},
                        "--set nodes.3.mass: expected a value >= 0.0, got -0.2"),
    "a zero thickness": ({"sections.leaf.height": 0.0},
                         "--set sections.leaf.height: expected a value > 0, got 0.0"),
    "a list of the wrong length": ({"nodes.3.position": [0.0, 0.1, 0.0]},
                                   "--set nodes.3.position: expected a list of 2 numbers"),
    "a bad list entry": ({"nodes.3.position": [0.0, "y"]},
                        "--set nodes.3.position[1]: expected a number, got 'y'"),
    "an infinite value": ({"nodes.3.mass": math.inf},
                          "--set nodes.3.mass: expected a finite number, got inf"),
    "a bad scene name": ({"scene.name": "two words"},
                         "--set scene.name: expected an identifier"),
    "a date": ({"nodes.3.mass": __import__("datetime").date(2026, 1, 1)},
               "--set nodes.3.mass: a date or time has no place in a scene"),
    "an object": ({"nodes.3.mass": object()},
                  "--set nodes.3.mass: expected a number, string, boolean or a list of them, "
                  "got a object"),
}


@pytest.mark.parametrize("case", ERRORS)
def test_a_bad_override_is_one_line_naming_it(case):
    overrides, message = ERRORS[case]
    with pytest.raises(SceneError) as raised:
        load_scene(SCENE, overrides=overrides)
    assert str(raised.value).startswith(f"{SOURCE}: {message}")
    assert "\n" not in str(raised.value)


def test_an_override_of_a_file_whose_table_is_not_one_is_refused():
    with pytest.raises(SceneError, match=r"^x.toml: --set scene.name: the scene's scene is not "
                                         r"a table$"):
        build_model({"scene": 1}, overrides={"scene.name": "a"}, source="x.toml")
    with pytest.raises(SceneError, match=r"^x.toml: scene file: expected a table, got list$"):
        apply_overrides([], {"scene.name": "a"}, source="x.toml")


def test_a_mistake_the_file_makes_is_not_blamed_on_an_override():
    data = tomllib.loads(scene_path(SCENE).read_text())
    data["nodes"]["5"]["mass"] = -1.0
    with pytest.raises(SceneError, match=r"^x.toml: nodes.5.mass: expected a value >= 0.0"):
        build_model(data, overrides={"nodes.3.mass": 0.2}, source="x.toml")


@pytest.mark.parametrize("text, value", [
    ("0.3e-3", 0.3e-3), ("2", 2), ("[0, 1.5]", [0, 1.5]), ('"text"', "text"), ("true", True),
    ("PLTRUSS", "PLTRUSS"), ("", ""), ("1\nx = 2", "1\nx = 2"), ("{ a = 1 }", {"a": 1}),
])
def test_a_set_value_is_toml_or_else_a_string(text, value):
    assert parse_value(text) == value
    assert type(parse_value(text)) is type(value)


def test_an_assignment_without_a_key_is_refused():
    assert parse_assignment(" nodes.3.mass = 0.2") == ("nodes.3.mass", 0.2)
    for text in ("nodes.3.mass", "=0.2"):
        with pytest.raises(ValueError, match="expected KEY=VALUE"):
            parse_assignment(text)


# -- every command that takes a scene accepts --set --------------------------------------------

@pytest.mark.parametrize("argv, message", [
    (["--set", "nodes.3.mass"], "argument --set: expected KEY=VALUE"),
    (["--set", "nodes.3.mass=1", "--set", "nodes.3.mass=2"],
     "argument --set: nodes.3.mass is given twice"),
    (["--set", "nodes.3.mass=" + "[" * 5000],
     "argument --set: a value nested deeper than Python's recursion limit"),
])
def test_a_malformed_set_option_is_refused_by_the_parser(argv, message, capsys):
    with pytest.raises(SystemExit) as raised:
        main(["analyze", SCENE, *argv])
    assert raised.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_a_scene_file_nested_beyond_the_recursion_limit_is_refused(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    path.write_text('[scene]\nname = "deep"\n[nodes.1]\nmass = ' + "[" * 5000 + "\n")
    assert main(["analyze", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: not a scene: its arrays or inline tables are nested deeper" in err


COMMANDS = {  # a quick run of each, before the --set options
    "analyze": ["analyze", SCENE, "--modes", "--json"],
    "simulate": ["simulate", SCENE, "--t-end", "0.002"],
    "bench": ["bench", SCENE, "--t-end", "0.002", "--methods", "cvode-bdf", "--rtols", "1e-4",
              "--reference-rtol", "1e-6", "--samples", "3"],
    "reduce": ["reduce", SCENE, "--keep", "1"],
    "loop": ["loop", SCENE, "--duration", "0.01", "--settle", "0.0", "--no-plot", "--json"],
    "fmu build": ["fmu", "build", SCENE, "--no-validate", "-o"],
}


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_refuses_a_bad_set_in_one_line(command, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = COMMANDS[command] + (["x.fmu"] if command == "fmu build" else [])
    assert main([*argv, "--set", "sections.leaf.hieght=1e-3"]) == 2
    err = capsys.readouterr().err
    assert err == (f"flexure {command.split()[0]}: error: {SOURCE}: --set sections.leaf.hieght: "
                   "unknown key; expected one of E, EA, EI, EdA, EdI, GAs, height, rho, "
                   "rho_A, width, yield_stress\n")
    assert not list(tmp_path.iterdir())  # nothing written


def test_analyze_with_set_reports_the_changed_frequency(capsys):
    assert main([*COMMANDS["analyze"], "--set", "sections.leaf.rho=0",
                 "--set", "nodes.3.mass=0.2"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["modes"]["frequencies_hz"][0] == pytest.approx(stage_hz(0.5e-3, BAR + 0.2),
                                                                 rel=1e-9)


def test_simulate_and_bench_run_the_changed_scene(tmp_path, capsys):
    from flexure.core import simulate

    out = tmp_path / "step.csv"
    assert main([*COMMANDS["simulate"], "--input", "F=1", "--out", str(out),
                 "--set", "nodes.3.mass=0.2"]) == 0
    final_x = float(out.read_text().splitlines()[-1].split(",")[1])  # 12 digits
    model = load_scene(SCENE, overrides={"nodes.3.mass": 0.2})
    expected = simulate(model, 0.002, inputs={"F": 1.0}, rtol=1e-8).outputs["x"][-1]
    assert final_x == pytest.approx(expected, rel=1e-10)
    # early in a 1 N step x = F t^2 / 2 m: nearly double the mass, nearly half the travel
    unchanged = simulate(load_scene(SCENE), 0.002, inputs={"F": 1.0}, rtol=1e-8)
    assert final_x / unchanged.outputs["x"][-1] == pytest.approx(0.211 / 0.411, rel=0.02)
    assert main([*COMMANDS["bench"], "--set", "nodes.3.mass=0.2"]) == 0
    assert "cvode-bdf" in capsys.readouterr().out


def test_reduce_writes_the_scene_with_the_override(tmp_path, capsys):
    out = tmp_path / "reduced.toml"
    assert main([*COMMANDS["reduce"], "--out", str(out), "--set", "sections.leaf.height=3e-4",
                 "--set", "elements.bar.segments=2"]) == 0
    text = out.read_text()
    assert "with --set sections.leaf.height=0.0003 --set elements.bar.segments=2" in text
    reduced = tomllib.loads(text)
    assert reduced["sections"]["leaf"]["height"] == 3e-4
    assert reduced["elements"]["bar"]["segments"] == 2


def test_loop_runs_on_the_changed_scene(capsys):
    # on this 10 ms move the largest force is nearly all inertial, m a, with m the moving mass:
    # the bar and 13/35 of each leaf (a guided cantilever's kinetic energy), 0.2 kg more on
    # node 3; the spring force k x (a few % of the peak) makes the rest
    assert main(COMMANDS["loop"]) == 0
    plain = json.loads(capsys.readouterr().out)["max_abs_force"]
    assert main([*COMMANDS["loop"], "--set", "nodes.3.mass=0.2"]) == 0
    heavier = json.loads(capsys.readouterr().out)["max_abs_force"]
    moving = BAR + 2 * 13 / 35 * 7850.0 * WIDTH * 0.5e-3 * LENGTH
    assert heavier / plain == pytest.approx((moving + 0.2) / moving, rel=0.01)


def embedded_scene(path):
    """The scene dictionary a scene FMU carries (the string literal its slave script holds;
    resources/<scene>_<digest>.py is the launcher that runs it)."""
    with zipfile.ZipFile(path) as archive:
        script = next(name for name in archive.namelist()
                      if name.startswith(f"resources/{SCENE}_") and name.endswith(".slave.py"))
        source = archive.read(script).decode()
    namespace = {}
    exec("scene_toml = " + source.split("scene_toml = ", 1)[1].split("\n", 1)[0], namespace)
    return tomllib.loads(namespace["scene_toml"])


def test_fmu_build_carries_the_overridden_scene(tmp_path, capsys):
    path = tmp_path / "stage.fmu"
    assert main([*COMMANDS["fmu build"], str(path), "--set", "sections.leaf.height=3e-4"]) == 0
    original = tomllib.loads(scene_path(SCENE).read_text())
    original["sections"]["leaf"]["height"] = 3e-4
    assert embedded_scene(path) == original


def test_the_loop_builds_its_fmu_plants_from_the_overridden_scene(tmp_path):
    # the plants run the same integrator on the same scene: they agree to round-off, here
    # exactly, and only if the FMU is of the overridden scene (0.2 kg more on node 3), though
    # the workdir already holds the FMU of the scene as its file has it
    import numpy as np

    from flexure.controllers import run_loop

    stroke = 1e-3
    move = {"stroke": stroke, "duration": 0.01, "settle": 0.0, "workdir": tmp_path}
    plain = run_loop(SCENE, plant="fmu", **move)
    heavier = {"overrides": {"nodes.3.mass": 0.2}, **move}
    reference = run_loop(SCENE, plant="inprocess", **heavier)
    for plant in ("fmu", "libcosim"):
        result = run_loop(SCENE, plant=plant, **heavier)
        assert np.max(np.abs(result.position - reference.position)) < 1e-9 * stroke, plant
    # the loop on the scene as the file has it ends 3e-6 of the stroke away from this one
    assert np.max(np.abs(plain.position - reference.position)) > 1e-6 * stroke
    from flexure.controllers.cosim import scene_fmu_path

    model = load_scene(SCENE)
    built = scene_fmu_path(SCENE, model, tmp_path, overrides=heavier["overrides"])
    assert embedded_scene(built)["nodes"]["3"]["mass"] == 0.2
    assert "mass" not in embedded_scene(scene_fmu_path(SCENE, model, tmp_path))["nodes"]["3"]
    assert len(list(tmp_path.glob(f"*/{SCENE}.fmu"))) == 2


def test_the_loop_refuses_overrides_of_a_built_model():
    from flexure.controllers import run_loop
    from flexure.controllers.runner import LoopError

    with pytest.raises(LoopError, match="overrides apply to a scene file or name, not to a "
                                        "built Model"):
        run_loop(load_scene(SCENE), overrides={"nodes.3.mass": 0.2})


def test_overrides_that_are_not_a_mapping_are_named():
    with pytest.raises(SceneError, match="overrides: expected a mapping .* got a str"):
        load_scene("stage_planar_1dof", overrides="sections.leaf.height=1e-3")
