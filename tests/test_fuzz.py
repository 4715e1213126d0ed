"""Property-based fuzzing: no user input gives a traceback.

The scene loader gets the shipped scenes with one to three mutations (a value replaced by one
of another type or an absurd number, a key deleted, an unknown key added) and TOML texts with
random bytes inserted or flipped; the command line gets random option values. Either the
input is accepted, or the project's own error (FlexureError) or argparse's exit (SystemExit
with a message on stderr) answers it: any other exception is a failure.

Cases per run: 700 scene dictionaries, 300 scene texts, 400 command lines (about 10 s); the
hypothesis database is off, so every run draws new cases and a failure prints its example.

The command-line cases replace the long runs (simulation, work-precision study, closed loop,
FMU build and check) by stubs: what is fuzzed is the validation of the options and of the
output paths, which all happens before those runs.
"""

import datetime
import json
import math
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flexure.core import FlexureError, build_model, builtin_scenes, load_scene, scene_path
from tests.cli_runs import StubResult

pytestmark = pytest.mark.slow  # the slow tier (hypothesis runs ~1000 cases); .ci/run runs it

# the manipulator's scenes (hundreds of DOFs, one refused by design): tests/test_manipulator.py
SCENES = {name: scene_path(name).read_bytes() for name in builtin_scenes()
          if not name.startswith("manipulator")}
DATA = {name: tomllib.loads(text.decode()) for name, text in SCENES.items()}
FAST = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow], database=None)

absurd_floats = st.sampled_from([0.0, -0.0, 1e308, -1e308, 1e-308, 5e-324, math.inf, -math.inf,
                                 math.nan, 1e21, -1e21, 1e20, 1e300, 1e-300, -1.0, 1e3, 1e4])
numbers = st.one_of(st.integers(min_value=-10**30, max_value=10**30),
                    st.just(10**400), absurd_floats,
                    st.floats(allow_nan=True, allow_infinity=True))
scalars = st.one_of(numbers, st.booleans(), st.text(max_size=8),
                    st.sampled_from(["x", "y", "z", "phi", "e1", "e2", "lambda0", "1", "3",
                                     "BEAM", "PLBEAM", "PLTRUSS", "TRUSS", "position",
                                     "velocity", "leaf", "bar", "rotation"]),
                    st.just(datetime.date(2024, 1, 1)), st.just(datetime.time(12, 0)))
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=5), st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=8)


def _paths(data, prefix=()):
    """Every path (tuple of keys and list indices) to a value in `data`, tables included."""
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        yield (*prefix, key)
        if isinstance(value, (dict, list)):
            yield from _paths(value, (*prefix, key))


def _copy(value):
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_copy(v) for v in value]
    return value


@st.composite
def mutated_scenes(draw):
    name = draw(st.sampled_from(sorted(DATA)))
    data = _copy(DATA[name])
    for _ in range(draw(st.integers(1, 3))):
        paths = list(_paths(data))
        kind = draw(st.sampled_from(["replace", "replace", "number", "delete", "add"]))
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = data
        for key in path[:-1]:
            parent = parent[key]
        last = path[-1]
        if kind == "replace":
            parent[last] = draw(values)
        elif kind == "number":
            parent[last] = draw(numbers)
        elif kind == "delete":
            del parent[last]
        else:
            target = parent[last] if isinstance(parent[last], dict) else parent
            if isinstance(target, dict):
                target[draw(st.text(max_size=6))] = draw(values)
            else:
                target.append(draw(values))
    return name, data


def _accepts_or_explains(load):
    try:
        load()
    except FlexureError as error:
        assert str(error), f"{type(error).__name__} without a message"


@settings(FAST, max_examples=700)
@given(mutated_scenes())
def test_mutated_scene_dictionaries(case):
    _, data = case
    _accepts_or_explains(lambda: build_model(data, source="fuzz.toml"))


@st.composite
def mutated_texts(draw):
    text = bytearray(SCENES[draw(st.sampled_from(sorted(SCENES)))])
    for _ in range(draw(st.integers(1, 4))):
        position = draw(st.integers(0, len(text) - 1))
        kind = draw(st.sampled_from(["flip", "insert", "delete", "invalid"]))
        if kind == "flip":
            text[position] = draw(st.integers(0, 255))
        elif kind == "insert":
            text[position:position] = draw(st.binary(min_size=1, max_size=4))
        elif kind == "delete":
            del text[position:position + draw(st.integers(1, 20))]
        else:
            text[position:position] = draw(st.sampled_from([b"\xff", b"\xc3", b"\xed\xa0\x80",
                                                             b"\x00", b"\xe2\x82"]))
    return bytes(text)


@settings(FAST, max_examples=300)
@given(mutated_texts())
def test_mutated_scene_bytes(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("fuzz") / "scene.toml"
    path.write_bytes(text)
    _accepts_or_explains(lambda: load_scene(path))


@pytest.mark.parametrize("name", sorted(SCENES))
def test_the_shipped_scenes_still_load(name):
    load_scene(name)


# -- the command line --------------------------------------------------------------------------

NUMBER_TEXTS = st.one_of(
    st.sampled_from(["0", "-0", "1", "-1", "-5", "2", "5", "13", "0.5", "1e-9", "1e300", "-1e300",
                     "1e-320", "nan", "inf", "-inf", "1e400", "x", "", " ", "1,2", "0x10",
                     "1_000", "10000000000000000000000"]),
    st.floats().map(repr), st.integers(-10**6, 10**6).map(str), st.text(max_size=5))
PATH_TEXTS = st.sampled_from([
    "out.csv", "out.png", "out.PNG", "out.pdf", "out.jpg", "out", "folder", "folder/x.png",
    "folder/x.csv", "missing/x.csv", "missing/deeper/x.png", "file", "file/x.png", "/dev/full",
    "/dev/null", ".", "..", "", "/", "x.fmu", "folder/x.fmu", "ref.csv", "in.csv", "scene.toml"])
INPUT_TEXTS = st.one_of(NUMBER_TEXTS.map(lambda v: f"F={v}"),
                        st.sampled_from(["F", "=1", "G=1", "F=in.csv", "F=bad.csv", "F=folder",
                                         "F=scene.toml", "F=missing.csv"]))
FLAG = None
SET_TEXTS = st.sampled_from([
    "nodes.2.mass=0.3", "nodes.2.mass=-1", "nodes.9.mass=1", "nodes.2.mass", "=1",
    "sections.springs.EA=abc", "nodes.2.mass=inf", "nodes.2.mass=1979-05-27", "nodes.2=1",
    "scene.name=x y", "elements.spring.released=[]", "nodes.2.position=[0.1]"])
COMMANDS = {
    "simulate": {"--t-end": NUMBER_TEXTS, "--input": INPUT_TEXTS,
                 "--method": st.sampled_from(["cvode-bdf", "ida", "euler"]),
                 "--max-order": NUMBER_TEXTS, "--rtol": NUMBER_TEXTS, "--atol": NUMBER_TEXTS,
                 "--max-step": NUMBER_TEXTS, "--samples": NUMBER_TEXTS, "--out": PATH_TEXTS,
                 "--plot": PATH_TEXTS},
    "analyze": {"--static": FLAG, "--modes": NUMBER_TEXTS, "--buckling": NUMBER_TEXTS,
                "--state-space": FLAG, "--json": FLAG, "--plot": PATH_TEXTS},
    "bench": {"--t-end": NUMBER_TEXTS, "--input": INPUT_TEXTS, "--rtols": NUMBER_TEXTS,
              "--methods": st.sampled_from(["ida", "ida,ida", "cvode-bdf:2", "cvode-bdf:9",
                                            "scipy-bdf:2", "foo", "", "ida,scipy-dop853"]),
              "--reference-rtol": NUMBER_TEXTS, "--samples": NUMBER_TEXTS,
              "--time-limit": NUMBER_TEXTS, "--csv": PATH_TEXTS, "--markdown": PATH_TEXTS,
              "--plot": PATH_TEXTS},
    "loop": {"--stroke": NUMBER_TEXTS, "--duration": NUMBER_TEXTS, "--fs": NUMBER_TEXTS,
             "--crossover": NUMBER_TEXTS, "--settle": NUMBER_TEXTS, "--rtol": NUMBER_TEXTS,
             "--plot": PATH_TEXTS, "--no-plot": FLAG, "--json": FLAG, "--workdir": PATH_TEXTS},
    "fmu build": {"-o": PATH_TEXTS, "--tunable": st.sampled_from(
        ["nodes.2.mass", "sections.springs.EdA", "nodes", "x.y"]), "--no-tunable": FLAG},
    "fmu check": {"--rtol": NUMBER_TEXTS, "--atol": NUMBER_TEXTS, "--update": FLAG,
                  "--interval": NUMBER_TEXTS},
    "sweep": {"--param": st.sampled_from(
        ["nodes.2.mass=0:1:3", "nodes.2.mass=0.1,0.2", "sections.springs.EA=-1,1", "x=1:2",
         "nodes.2.mass=1:1:2", "nodes.2.mass=", "nodes.9.mass=1,2", "nodes.2.mass=0:1:0"]),
        "--analyses": st.sampled_from(["static", "modes,buckling", "loop", "x", ""]),
        "--modes": NUMBER_TEXTS, "--out": PATH_TEXTS, "--resume": FLAG, "--no-plot": FLAG},
}
for _options in COMMANDS.values():  # every command that takes a scene takes --set
    if "--t-end" in _options or "--modes" in _options or "--stroke" in _options \
            or "--tunable" in _options:
        _options["--set"] = SET_TEXTS
SCENE_ARGS = st.sampled_from(["truss_1dof_x", "truss_1dof_x", "no_such_scene", "scene.toml",
                              "bad.toml", "folder", ""])
CSV_TEXTS = st.one_of(
    st.sampled_from(["time,F\n0,0\n0.1,1\n", "time,x\n0,0.1\n0.001,0.1\n", "", "time,F\n",
                     "time,F\n0,a\n", "t,F\n0,0\n", "time,F\n1,0\n0,0\n", "time,F,F\n0,0,0\n"]),
    st.text(alphabet="time,Fx0123456789.-e\n\" ", max_size=40))


@st.composite
def command_lines(draw):
    command = draw(st.sampled_from(sorted(COMMANDS)))
    argv = command.split()
    if command == "fmu check":
        argv += [draw(st.sampled_from(["m.fmu", "notzip.fmu", "missing.fmu", "folder"])),
                 draw(st.sampled_from(["in.csv", "fuzz_in.csv", "missing.csv"])),
                 draw(st.sampled_from(["ref.csv", "fuzz_ref.csv", "new_ref.csv", "folder"]))]
    elif command != "loop" or draw(st.booleans()):
        argv.append(draw(SCENE_ARGS))
    if command == "simulate" and draw(st.booleans()):
        argv += ["--t-end", "0.1"]
    if command == "sweep":  # in this process: a Dask cluster per example would be minutes
        argv += ["--serial"]
    options = COMMANDS[command]
    for option in draw(st.lists(st.sampled_from(sorted(options)), max_size=4)):
        argv.append(option)
        if options[option] is not None:
            argv.append(draw(options[option]))
    return argv, draw(CSV_TEXTS), draw(CSV_TEXTS)


def _fake_build(scene, dest, **kwargs):
    built = Path(dest) / "truss_1dof_x.fmu"
    built.write_bytes(b"PK")
    return built


@pytest.fixture(scope="module")
def cli_folder(tmp_path_factory):
    import zipfile

    from test_cli_abuse import MODEL_DESCRIPTION

    folder = tmp_path_factory.mktemp("cli_fuzz")
    (folder / "folder").mkdir()
    (folder / "file").write_text("a file")
    (folder / "scene.toml").write_bytes(SCENES["truss_1dof_x"])
    (folder / "bad.toml").write_bytes(SCENES["truss_1dof_x"].replace(b"springs", b"spr\xffngs"))
    (folder / "in.csv").write_text("time,F\n0,0\n0.1,1\n")
    (folder / "ref.csv").write_text('"time","x"\n0,0.1\n0.05,0.1\n0.1,0.1\n')
    (folder / "bad.csv").write_text("time,F\n0,a\n")
    (folder / "notzip.fmu").write_text("not a zip")
    with zipfile.ZipFile(folder / "m.fmu", "w") as archive:
        archive.writestr("modelDescription.xml", MODEL_DESCRIPTION)
    return folder


def _run_cli(argv):
    """(exit code, stderr) of main(argv) in this process; any other exception propagates."""
    import contextlib
    import io

    from flexure.core.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as stop:
            code = stop.code
    return code, out.getvalue(), err.getvalue()


@settings(FAST, max_examples=400)
@given(command_lines())
def test_random_command_lines(cli_folder, case):
    import flexure.controllers.cli as loop_cli
    import flexure.core.cli.bench as cli_bench
    import flexure.core.simulation.simulation as simulation
    import flexure.fmu.cli as fmu_cli

    argv, input_text, reference_text = case
    (cli_folder / "fuzz_in.csv").write_text(input_text)
    (cli_folder / "fuzz_ref.csv").write_text(reference_text)
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(cli_folder)
        patch.setattr(simulation, "simulate", lambda *a, **k: StubResult())
        patch.setattr(cli_bench, "work_precision", lambda *a, **k: StubResult())
        patch.setattr(loop_cli, "run_loop", lambda *a, **k: StubResult())
        patch.setattr(fmu_cli, "build_scene_fmu", _fake_build)
        patch.setattr(fmu_cli, "write_reference", lambda fmu, i, ref, **k: Path(ref))
        code, out, err = _run_cli(argv)
    assert "Traceback" not in out + err
    assert code in (0, 1, 2), (argv, code, err)
    if code == 2:
        assert "error:" in err, (argv, err)
    if code == 0 and "--json" in argv:
        json.loads(out, parse_constant=lambda token: pytest.fail(f"{token} in the JSON"))


def test_a_few_command_lines_through_the_console_script(cli_folder):
    """The installed script, end to end, on misuses that stop before any run."""
    import sys

    import children

    flexure = str(Path(sys.executable).with_name("flexure"))
    for argv in (["simulate", "bad.toml", "--t-end", "1"],
                 ["simulate", "truss_1dof_x", "--t-end", "1", "--plot", "folder"],
                 ["bench", "truss_1dof_x", "--rtols", "1e300"],
                 ["fmu", "check", "notzip.fmu", "in.csv", "ref.csv"]):
        completed = children.run([flexure, *argv], capture_output=True, text=True,
                                 cwd=cli_folder)
        assert completed.returncode == 2, (argv, completed.stderr)
        assert "error:" in completed.stderr and "Traceback" not in completed.stderr
