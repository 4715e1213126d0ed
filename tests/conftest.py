"""Fixtures shared by the test modules: the scene FMUs, each built once per session, and the
1-DOF stage that the loop, profile and inverse-statics tests take.

The imports are inside the fixtures, so that a run of tests that use none of them does not
load flexure.fmu or fmpy."""

import os

import pytest

# The suite's FMUs run where flexure is installed, which stands in for their copy of it: they
# are built without the compiled engine an FMU carries for other hosts (a minute of CPU for
# the first build, seconds for each later one). tests/test_fmu_engine.py builds with it.
os.environ.setdefault("FLEXURE_FMU_ENGINE", "0")

# One OpenBLAS thread in each test process and the processes it starts (set before numpy is
# imported: OpenBLAS reads it when it loads). pytest -n auto already runs a worker per core;
# OpenBLAS's own threads (two on the 2-core machine) then only wait for a core, spinning: the
# numpy reference's 16-BEAM kinematics test took 15 to 18 s of CPU with two threads beside
# the other worker, 1.7 to 2.2 s with one. tests/test_blas.py sets its host's threads itself.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def pytest_sessionstart(session):
    """Each pytest-xdist worker compiles its share of the engine's first entries before its
    first test, so that on an empty cache the workers compile side by side instead of one
    waiting for the other (tests/shared_compilation.py)."""
    from shared_compilation import compile_this_workers_share

    compile_this_workers_share()


@pytest.fixture(scope="session")
def scene_fmus(tmp_path_factory):
    """get(scene name, binary="auto"): its FMU's path, each built once, on first use; binary
    "stock" carries pythonfmu's stock binary instead of flexure's corrected build (the
    fallback, flexure.fmu.pythonfmu_binary)."""
    from flexure.fmu import build_scene_fmu

    folder = tmp_path_factory.mktemp("fmus")
    cache = {}

    def get(name, binary="auto"):
        if (name, binary) not in cache:
            stem = name if binary == "auto" else f"{name}-{binary}"
            cache[name, binary] = build_scene_fmu(name, folder / f"{stem}.fmu",
                                                  pythonfmu_binary=binary)
        return cache[name, binary]

    return get


@pytest.fixture(scope="session")
def motion_fmus(tmp_path_factory):
    """{name: FMU path} of the displacement-driven FMUs' scenes (tests/kinematic_scenes.py):
    "chain" (moved at node 1), "leader" (force-driven) and "follower" (displacement-driven),
    built once."""
    from kinematic_scenes import chain, follower, leader

    from flexure.core import scene_toml
    from flexure.fmu import build_scene_fmu

    folder = tmp_path_factory.mktemp("motion_fmus")
    paths = {}
    for data in (chain(), leader(), follower()):
        name = data["scene"]["name"]
        scene = folder / f"{name}.toml"
        scene.write_text(scene_toml(data, "a test of displacement-driven FMUs"))
        paths[name] = build_scene_fmu(scene, folder / f"{name}.fmu")
    return paths


@pytest.fixture(scope="session")
def fmus(tmp_path_factory):
    """The extracted folders of stage_planar_3dof.fmu and truss_1dof_x.fmu for the abuse cases
    (test_fmu_abuse.py, test_fmu_memory.py), built once. Every case's process loads the FMUs
    from these folders, so what the bundled flexure compiles and caches next to its sources
    (numba) is compiled once, by the warm-up run."""
    from fmpy import extract
    from fmu_abuse_runs import run

    from flexure.fmu import build_scene_fmu

    folder = tmp_path_factory.mktemp("abuse")
    paths = []
    for scene in ("stage_planar_3dof", "truss_1dof_x"):
        fmu = build_scene_fmu(scene, folder / f"{scene}.fmu")
        paths.append(extract(str(fmu), unzipdir=str(folder / scene)))
    warm_up = run("interleaved", paths, timeout=1200)
    assert warm_up.code == 0, warm_up.out[-2000:] + warm_up.err[-2000:]
    return paths


@pytest.fixture(scope="session")
def stock_fmus(tmp_path_factory, fmus):
    """As `fmus`, with pythonfmu's stock binary (the fallback) instead of flexure's corrected
    build: test_fmu_abuse.py shows what still crashes the host with it."""
    from fmpy import extract

    from flexure.fmu import build_scene_fmu

    folder = tmp_path_factory.mktemp("abuse-stock")
    return [extract(str(build_scene_fmu(scene, folder / f"{scene}.fmu",
                                        pythonfmu_binary="stock")),
                    unzipdir=str(folder / scene))
            for scene in ("stage_planar_3dof", "truss_1dof_x")]


@pytest.fixture(scope="module")
def stage():
    """stage_planar_1dof, the loops' and the profiles' plant, loaded once per test module."""
    from flexure.core import load_scene

    return load_scene("stage_planar_1dof")


@pytest.fixture(scope="session")
def stage_fmu(tmp_path_factory):
    """stage_planar_1dof.fmu with its default tunables and, beyond them, section dimensions
    and a modulus (test_fmu_requirements.GEOMETRY), built once."""
    import tomllib

    from test_fmu_requirements import GEOMETRY, SCENE

    from flexure.core import scene_path
    from flexure.fmu import build_scene_fmu, default_tunable

    data = tomllib.loads(scene_path(SCENE).read_text())
    return build_scene_fmu(SCENE, tmp_path_factory.mktemp("fmu") / f"{SCENE}.fmu",
                           tunable=default_tunable(data) + GEOMETRY)
