"""Design sweeps (`flexure sweep`, flexure.core.sweep.grid): the grid, one point's quantities
against the analytic stage, Dask equal to the serial run, failed points, --resume, the files."""

import csv
import math
import re
import tomllib

import pytest

from flexure.core import scene_path
from flexure.core.cli import main
from flexure.core.sweep.grid import evaluate_point, grid, parse_parameter, run_sweep

SCENE = "stage_planar_1dof"
DATA = tomllib.loads(scene_path(SCENE).read_text())
SOURCE = str(scene_path(SCENE))
# the stage with massless leaves (see tests/test_overrides.py): one mode, the 0.206 kg bar on
# two guided leaves, f = sqrt(24 E I / L^3 / m) / 2 pi with I = w h^3 / 12
E, WIDTH, LENGTH, BAR = 2.1e11, 0.018, 0.1, 0.206
MASSLESS = {"sections.leaf.rho": 0.0}


def stage_hz(height, mass=BAR):
    return math.sqrt(24.0 * E * WIDTH * height**3 / 12.0 / LENGTH**3 / mass) / (2.0 * math.pi)


def read(path):
    with open(path, newline="") as handle:
        return list(csv.reader(handle))


# -- the grid -------------------------------------------------------------------------------

def test_linear_values_include_both_ends_and_read_plainly():
    key, values = parse_parameter("sections.leaf.height=0.3e-3:0.8e-3:6")
    assert key == "sections.leaf.height"
    assert values == [0.0003, 0.0004, 0.0005, 0.0006, 0.0007, 0.0008]  # not 0.00039999...
    assert parse_parameter("elements.bar.segments=1,2,4") == ("elements.bar.segments", [1, 2, 4])
    assert parse_parameter('elements.bar.type=PLBEAM,"PLTRUSS"')[1] == ["PLBEAM", "PLTRUSS"]


@pytest.mark.parametrize("text, message", [
    ("sections.leaf.height", "expected KEY=START:STOP:N or KEY=V1,V2,..."),
    ("=1,2", "expected KEY=START:STOP:N"),
    ("k=1:2", "expected START:STOP:N"),
    ("k=a:2:3", "expected START:STOP:N"),
    ("k=0:inf:3", "expected START:STOP:N"),
    ("k=0:1:1", "a count >= 2"),
    ("k=1:1:3", "START and STOP are equal"),
    ("k=1,2,1", "1 is listed 2 times"),
    ("k=1e-3:2e-3:1000000000", "1000000000 values, more than a sweep runs \\(100000\\)"),
])
def test_a_bad_parameter_says_what_is_expected(text, message):
    with pytest.raises(ValueError, match=message):
        parse_parameter(text)


def test_a_grid_too_large_to_run_is_refused_before_it_is_made():
    from flexure.core.errors import UsageError

    with pytest.raises(UsageError, match="a grid of 10000 x 10000 = 100000000 points, more "
                                         "than a sweep runs"):
        grid([("a", list(range(10_000))), ("b", list(range(10_000)))])


def test_the_grid_is_the_product_with_the_first_parameter_slowest():
    points = grid([("a", [1, 2]), ("b", ["x", "y", "z"])])
    assert points == [{"a": 1, "b": "x"}, {"a": 1, "b": "y"}, {"a": 1, "b": "z"},
                      {"a": 2, "b": "x"}, {"a": 2, "b": "y"}, {"a": 2, "b": "z"}]


# -- the points -----------------------------------------------------------------------------

def test_the_frequency_column_follows_the_analytic_stage_and_bad_points_fail_alone():
    heights = [0.3e-3, -0.1e-3, 0.5e-3, 0.0, 0.8e-3]
    rows = run_sweep(DATA, grid([("sections.leaf.height", heights)]), overrides=MASSLESS,
                     analyses=("static", "modes", "buckling"), source=SOURCE, workers=0)
    assert [row["status"] for row in rows] == [
        "ok", "--set sections.leaf.height: expected a value > 0, got -0.0001", "ok",
        "--set sections.leaf.height: expected a value > 0, got 0.0", "ok"]
    good = [(h, row) for h, row in zip(heights, rows, strict=True) if row["status"] == "ok"]
    for height, row in good:
        assert row["mode.1 [Hz]"] == pytest.approx(stage_hz(height), rel=1e-9)
        assert "mode.2 [Hz]" not in row  # one DOF: one frequency
        assert row["static.x [m]"] == pytest.approx(0.0, abs=1e-15)  # no load, no motion
    (h1, r1), (h2, r2) = good[0], good[-1]
    assert r2["mode.1 [Hz]"] / r1["mode.1 [Hz]"] == pytest.approx((h2 / h1) ** 1.5, rel=1e-6)
    # the buckling load of the guided leaves grows with EI, as h^3
    assert r2["buckling.1 [-]"] / r1["buckling.1 [-]"] == pytest.approx((h2 / h1) ** 3,
                                                                         rel=1e-6)


def test_a_static_displacement_is_that_of_the_output_coordinate():
    # truss_1dof_x: 1 N on a 0.2 kg node on a truss of EA = 94.5 N over 0.1 m: x = F L / EA
    data = tomllib.loads(scene_path("truss_1dof_x").read_text())
    row = evaluate_point(data, {"nodes.2.force": [2.0, 0.0]}, analyses=("static",))
    assert row == {"static.x [m]": pytest.approx(2.0 * 0.1 / 94.5, rel=1e-6), "status": "ok"}


def test_a_rotational_output_is_a_displacement_in_rad():
    # a cantilever (one PLBEAM, EI = 2 N m^2, L = 0.5 m) under a small tip moment M: the tip
    # turns by M L / EI and rises by M L^2 / (2 EI), up to terms of order phi^2 (1e-8)
    moment, length, stiffness = 4e-4, 0.5, 2.0
    scene = {
        "sections": {"s": {"EA": 1e6, "EI": stiffness}},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"angle": 0.0, "fixed": ["phi"]},
                  "3": {"position": [length, 0.0]}, "4": {"angle": 0.0, "moment": moment}},
        "elements": {"beam": {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                              "released": ["e1", "e2", "e3"]}},
        "outputs": {"tip_y": {"node": "3", "coordinate": "y"},
                    "tip_phi": {"node": "4", "coordinate": "phi"}}}
    row = evaluate_point(scene, {}, analyses=("static",))
    assert row == {
        "static.tip_y [m]": pytest.approx(moment * length**2 / (2 * stiffness), rel=1e-7),
        "static.tip_phi [rad]": pytest.approx(moment * length / stiffness, rel=1e-7),
        "status": "ok"}


def test_an_unforeseen_exception_is_the_status_of_its_point(monkeypatch):
    import flexure.core.analysis.statics as statics

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug\nover two lines")

    monkeypatch.setattr(statics, "static_equilibrium", broken)
    row = evaluate_point(DATA, {}, analyses=("static", "modes"))
    assert row == {"status": "ZeroDivisionError: a bug over two lines"}


# -- the command ----------------------------------------------------------------------------

ARGV = ["sweep", SCENE, "--param", "sections.leaf.height=0:0.8e-3:5", "--param",
        "nodes.3.mass=0,0.2", "--set", "sections.leaf.rho=0", "--analyses",
        "static,modes,buckling", "--modes", "2"]


@pytest.mark.slow
def test_dask_gives_the_serial_table_bit_for_bit(tmp_path, capsys):
    serial, dask = tmp_path / "serial.csv", tmp_path / "dask.csv"
    assert main([*ARGV, "--serial", "--out", str(serial), "--no-plot"]) == 0
    assert main([*ARGV, "--workers", "2", "--out", str(dask), "--no-plot"]) == 0
    assert "a local Dask cluster of 2 processes" in capsys.readouterr().out
    assert dask.read_bytes() == serial.read_bytes()
    rows = read(serial)
    assert rows[0] == ["sections.leaf.height", "nodes.3.mass", "static.x [m]", "static.y [m]",
                       "mode.1 [Hz]", "mode.2 [Hz]", "buckling.1 [-]", "status"]
    assert [row[:2] for row in rows[1:]] == [[h, m] for h in ("0.0", "0.0002", "0.0004",
                                                               "0.0006", "0.0008")
                                             for m in ("0", "0.2")]
    assert rows[1][-1] == "--set sections.leaf.height: expected a value > 0, got 0.0"
    assert rows[1][2:-1] == [""] * 5  # a failed point has no quantities
    for row in rows[3:]:
        height, mass = float(row[0]), float(row[1])
        assert float(row[4]) == pytest.approx(stage_hz(height, BAR + mass), rel=1e-9)
        assert row[5] == "" and row[-1] == "ok"


def test_a_running_scheduler_takes_the_points_and_a_lost_task_is_its_row(monkeypatch):
    from distributed import LocalCluster

    import flexure.core.sweep.grid as grid_module

    points = grid([("sections.leaf.height", [0.3e-3, 0.5e-3])])
    with LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                      dashboard_address=None) as cluster:
        rows = run_sweep(DATA, points, overrides=MASSLESS, scheduler=cluster.scheduler_address)
        assert rows == run_sweep(DATA, points, overrides=MASSLESS, workers=0)

        def lost(*args, **kwargs):  # what a task that dies with its worker gives
            raise RuntimeError("worker gone")

        monkeypatch.setattr(grid_module, "evaluate_point", lost)
        rows = run_sweep(DATA, points, scheduler=cluster.scheduler_address)
    assert rows == [{"status": "dask: RuntimeError: worker gone"}] * 2


def test_resume_computes_only_the_points_the_table_lacks(tmp_path, capsys):
    out, fresh = tmp_path / "sweep.csv", tmp_path / "fresh.csv"
    small = ["sweep", SCENE, "--param", "sections.leaf.height=0.3e-3,0.5e-3", "--serial",
             "--no-plot", "--out", str(out)]
    assert main(small) == 0
    rows = read(out)
    rows[1][2] = "123.0"  # a mark: a kept row is copied, not computed again
    with open(out, "w", newline="") as handle:
        csv.writer(handle, lineterminator="\n").writerows(rows)
    handle = open(out, "a")  # an interrupted write: half a row
    handle.write("0.0008,1.2")
    handle.close()
    capsys.readouterr()
    larger = [*small[:3], "sections.leaf.height=0.3e-3,0.5e-3,0.8e-3,1e-3", *small[4:]]
    assert main([*larger, "--resume"]) == 0
    report = capsys.readouterr().out
    assert re.search(r"\ncomputed now +2\n", report)
    assert re.search(r"\nunreadable rows computed again +1\n", report)
    resumed = read(out)
    assert resumed[1][2] == "123.0"
    assert main([*larger[:-1], str(fresh)]) == 0
    expected = read(fresh)
    expected[1][2] = "123.0"
    assert resumed == expected  # in the order of the grid


def test_resume_keeps_rows_outside_the_grid_and_refuses_other_columns(tmp_path, capsys):
    out = tmp_path / "sweep.csv"
    base = ["sweep", SCENE, "--serial", "--no-plot", "--out", str(out)]
    assert main([*base, "--param", "sections.leaf.height=0.3e-3,0.5e-3"]) == 0
    assert main([*base, "--param", "sections.leaf.height=0.4e-3", "--resume"]) == 0
    assert [row[0] for row in read(out)[1:]] == ["0.0004", "0.0003", "0.0005"]
    capsys.readouterr()
    assert main([*base, "--param", "nodes.3.mass=0,1", "--resume"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"flexure sweep: error: --resume: {out} has the columns "
                          "sections.leaf.height, static.x [m], ")
    assert "this sweep writes nodes.3.mass, static.x [m]" in err and err.count("\n") == 1


def test_resume_without_a_table_computes_everything(tmp_path, capsys):
    out = tmp_path / "new.csv"
    assert main(["sweep", SCENE, "--param", "nodes.3.mass=0,1", "--serial", "--no-plot",
                 "--out", str(out), "--resume"]) == 0
    assert len(read(out)) == 3


def test_a_table_that_cannot_be_read_is_refused(tmp_path, capsys):
    out = tmp_path / "sweep.csv"
    out.write_bytes(b"\xff\xfe not text")
    assert main(["sweep", SCENE, "--param", "nodes.3.mass=0,1", "--serial", "--no-plot",
                 "--out", str(out), "--resume"]) == 2
    assert capsys.readouterr().err.startswith(f"flexure sweep: error: --resume: cannot read "
                                              f"{out}: ")


def test_the_plot_and_parquet_are_written_beside_the_table(tmp_path, capsys):
    pyarrow = pytest.importorskip("pyarrow.parquet")
    out = tmp_path / "sweep.csv"
    assert main([*ARGV, "--serial", "--out", str(out)]) == 0
    assert (tmp_path / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = pyarrow.read_table(tmp_path / "sweep.parquet").to_pydict()
    rows = read(out)
    assert list(table) == rows[0]
    assert table["nodes.3.mass"] == [0, 0.2] * 5
    assert table["mode.1 [Hz]"][:2] == [None, None]  # the failed points
    assert table["mode.1 [Hz]"][2:] == [float(row[4]) for row in rows[3:]]
    assert table["status"] == [row[-1] for row in rows[1:]]


def test_values_of_mixed_kinds_are_text_in_parquet_and_categories_in_the_plot(tmp_path):
    pyarrow = pytest.importorskip("pyarrow.parquet")
    from flexure.core.sweep.table import SweepTable

    table = SweepTable(["elements.bar.type"], ["mode.1 [Hz]"])
    rows = [["PLBEAM", "10.5", "ok"], ["2", "", "elements.bar.type: expected a string"]]
    table.write_parquet(tmp_path / "t.parquet", rows)
    assert pyarrow.read_table(tmp_path / "t.parquet").to_pydict() == {
        "elements.bar.type": ["PLBEAM", "2"], "mode.1 [Hz]": [10.5, None],
        "status": ["ok", "elements.bar.type: expected a string"]}
    table.plot(tmp_path / "t.png", rows)
    assert (tmp_path / "t.png").read_bytes()[:4] == b"\x89PNG"


def test_without_pyarrow_no_parquet_and_with_no_plot_no_png(tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)  # import fails
    assert main([*ARGV, "--serial", "--out", str(tmp_path / "sweep.csv"), "--no-plot"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.csv"]


def test_the_default_table_is_named_after_the_scene(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", SCENE, "--param", "nodes.3.mass=0,1", "--serial"]) == 0
    assert (tmp_path / f"{SCENE}_sweep.csv").is_file()
    assert (tmp_path / f"{SCENE}_sweep.png").is_file()


def test_every_point_failing_is_an_error_after_the_table_is_written(tmp_path, capsys):
    out = tmp_path / "sweep.csv"
    assert main(["sweep", SCENE, "--param", "sections.leaf.hieght=1e-3,2e-3", "--serial",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == ("flexure sweep: error: sweep stage_planar_1dof: every point failed (2); "
                   "first: --set sections.leaf.hieght: unknown key; expected one of E, EA, EI, "
                   "EdA, EdI, GAs, height, rho, rho_A, width, yield_stress\n")
    assert len(read(out)) == 3 and (tmp_path / "sweep.png").is_file()


@pytest.mark.parametrize("argv, message", [
    (["--param", "k"], "argument --param: expected KEY=START:STOP:N"),
    (["--param", "nodes.3.mass=0,1", "--analyses", "modes,strain"], "unknown analysis 'strain'"),
    (["--param", "nodes.3.mass=0,1", "--analyses", "modes,modes"], "'modes' is listed 2 times"),
    (["--param", "nodes.3.mass=0,1", "--workers", "-1"], "argument --workers: expected an "
                                                         "integer >= 0"),
    (["--param", "nodes.3.mass=0,1", "--serial", "--scheduler", "tcp://x:1"],
     "not allowed with argument"),
    (["--param", "nodes.3.mass=0,1", "--out", "table.txt"], "expected a file name ending in "
                                                            ".csv"),
    ([], "the following arguments are required: --param"),
])
def test_bad_options_are_refused_by_the_parser(argv, message, capsys):
    with pytest.raises(SystemExit) as raised:
        main(["sweep", SCENE, *argv])
    assert raised.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [
    (["--param", "nodes.3.mass=0,1", "--param", "nodes.3.mass=2,3"],
     "--param nodes.3.mass: given 2 times; give each key once"),
    (["--param", "nodes.3.mass=0,1", "--set", "nodes.3.mass=2"],
     "--param nodes.3.mass: also given to --set; a key is either swept or set"),
    (["--param", "nodes.3.mass=0,1", "--set", "nodes.9.mass=2"],
     f"{SOURCE}: --set nodes.9.mass: unknown node '9'; the scene's nodes: 1, 2, 3, 4, 5, 6, "
     "7, 8"),
    (["--param", "nodes.3.mass=0,1", "--scheduler", "foo://x:1"],
     "--scheduler foo://x:1: cannot connect: unknown address scheme 'foo'"),
])
def test_bad_runs_are_one_line_before_any_point(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", SCENE, *argv, "--out", "sweep.csv"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"flexure sweep: error: {message}") and err.count("\n") == 1
    assert not (tmp_path / "sweep.csv").exists()


def test_an_unreachable_scheduler_is_given_up_after_the_timeout(monkeypatch, capsys, tmp_path):
    import flexure.core.sweep.grid as grid_module

    monkeypatch.setattr(grid_module, "CONNECT_TIMEOUT", "0.5s")
    assert main(["sweep", SCENE, "--param", "nodes.3.mass=0,1", "--scheduler",
                 "tcp://127.0.0.1:1", "--out", str(tmp_path / "s.csv")]) == 2
    assert capsys.readouterr().err == ("flexure sweep: error: --scheduler tcp://127.0.0.1:1: "
                                       "cannot connect: Timed out trying to connect to "
                                       "tcp://127.0.0.1:1 after 0.5 s\n")


def test_a_client_that_failed_to_connect_is_closed_before_the_error(tmp_path, capsys):
    """A failed Client left as cyclic garbage stops its IO loop under distributed's
    class-wide LoopRunner lock whenever the collector happens to run; if that is while the
    next Client starts (holding the lock), the process hangs. None may be left over.

    The objects are told apart by their type, not isinstance: isinstance asks a weak proxy
    its referent's class, and raises ReferenceError for one whose referent is gone, as other
    tests in the same process leave (one is made here, so that the check holds whatever ran
    before)."""
    import gc
    import weakref

    from distributed import Client

    class Referent:
        pass

    dead_proxy = weakref.proxy(Referent())  # its referent is gone at once (CPython)
    gc.collect()
    assert main(["sweep", SCENE, "--param", "nodes.3.mass=0,1", "--scheduler", "foo://x:1",
                 "--out", str(tmp_path / "s.csv")]) == 2
    assert "cannot connect" in capsys.readouterr().err
    assert [o for o in gc.get_objects() if issubclass(type(o), Client)] == []
    assert type(dead_proxy) is weakref.ProxyType


def test_the_local_cluster_is_closed_when_its_client_cannot_start(tmp_path, monkeypatch):
    """A Client that fails on the sweep's own LocalCluster: the cluster (worker processes) is
    closed before the error goes on, not left to its finalizer."""
    import distributed

    closed = []

    class Cluster:
        def __init__(self, **options):
            pass

        def close(self):
            closed.append(self)

    def failing_client(cluster):
        raise OSError("no client here")

    monkeypatch.setattr(distributed, "LocalCluster", Cluster)
    monkeypatch.setattr(distributed, "Client", failing_client)
    points = grid([("sections.leaf.height", [0.3e-3, 0.5e-3])])
    with pytest.raises(OSError, match="no client here"):
        run_sweep(DATA, points, overrides=MASSLESS, workers=2)
    assert len(closed) == 1
