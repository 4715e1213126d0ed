"""BLAS threads: limited while flexure's own analyses run, the host's limits before and after.

The host's limit in these tests is 2 threads, so that flexure's limit (1) is seen to be set
and taken away again.
"""

import json
import os
import sys

import children
import numpy as np
import pytest
import scipy.linalg
from threadpoolctl import threadpool_info, threadpool_limits

from flexure.core import (
    buckling_load_factors,
    check_exact_constraint,
    default_atol,
    linearize,
    load_scene,
    natural_frequencies,
    state_space,
    static_equilibrium,
    stresses_along,
)
from flexure.core.mechanics.energy import mechanical_energy
from flexure.core.numerics.blas import blas_threads

HOST_THREADS = 2


def blas_limits():
    """The thread counts of the loaded BLAS libraries (a set: one value when all agree)."""
    return {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}


@pytest.fixture
def host():
    """A host process whose BLAS libraries run HOST_THREADS threads."""
    with threadpool_limits(limits=HOST_THREADS, user_api="blas"):
        assert blas_limits() == {HOST_THREADS}
        yield


def test_import_changes_no_environment_and_no_thread_pool():
    """A host that imported numpy first keeps its variables and its BLAS threads through
    `import flexure.core` and the import of every public name."""
    code = ("import json, os\nimport numpy, scipy.linalg\n"
            "from threadpoolctl import threadpool_info\n"
            "def state():\n"
            "    return ({k: v for k, v in os.environ.items() if k.endswith('_NUM_THREADS')},\n"
            "            sorted(i['num_threads'] for i in threadpool_info()))\n"
            "before = state()\n"
            "import flexure.core\n"
            "for name in flexure.core.__all__:\n"
            "    getattr(flexure.core, name)\n"
            "print(json.dumps([before, state()]))")
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    env["OPENBLAS_NUM_THREADS"] = str(HOST_THREADS)
    completed = children.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True, env=env)
    before, after = json.loads(completed.stdout.splitlines()[-1])
    assert before[0] == {"OPENBLAS_NUM_THREADS": str(HOST_THREADS)}
    assert before == after


@pytest.fixture
def spy(monkeypatch):
    """The BLAS limits seen by every call of the dense solvers flexure uses (a list)."""
    seen = []
    for module, name in [(scipy.linalg, "lu_factor"), (scipy.linalg, "eigh"),
                         (np.linalg, "solve"), (np.linalg, "svd"), (np.linalg, "inv"),
                         (np.linalg, "cholesky"), (np.linalg, "eigvalsh")]:
        original = getattr(module, name)

        def probe(*args, _original=original, **kwargs):
            seen.append(blas_limits())
            return _original(*args, **kwargs)

        monkeypatch.setattr(module, name, probe)
    return seen


@pytest.fixture(scope="module")
def entry_points():
    """{name: call} of flexure's public analyses that do dense linear algebra."""
    model = load_scene("stage_planar_1dof")
    lin = linearize(model)
    state = np.concatenate([lin.solution.q, np.zeros_like(lin.solution.q)])
    return {
        "static_equilibrium": lambda: static_equilibrium(model),
        "linearize": lambda: linearize(model),
        "natural_frequencies": lambda: natural_frequencies(model, linear_model=lin),
        "buckling_load_factors": lambda: buckling_load_factors(model),
        "state_space": lambda: state_space(model, linear_model=lin),
        # the numpy path's (the engine's, the default, calls no BLAS)
        "stresses_along": lambda: stresses_along(model, [state], compiled=False),
        # a model of its own: the scales it evaluates are kept per live model (a second
        # call on one model makes no solver call)
        "default_atol": lambda: default_atol(load_scene("stage_planar_1dof"), 1e-6),
        "check_exact_constraint": lambda: check_exact_constraint(model),
        "mechanical_energy": lambda: mechanical_energy(model, lin.solution.q,
                                                       np.zeros_like(lin.solution.q)),
    }


ENTRY_POINTS = ["static_equilibrium", "linearize", "natural_frequencies",
                "buckling_load_factors", "state_space", "stresses_along", "default_atol",
                "check_exact_constraint", "mechanical_energy"]


@pytest.mark.parametrize("name", ENTRY_POINTS)
def test_analysis_runs_with_one_thread_and_restores_the_host(name, entry_points, host, spy):
    assert set(entry_points) == set(ENTRY_POINTS)
    entry_points[name]()
    assert spy, f"{name} made no dense solver call"
    assert all(limits == {1} for limits in spy), spy
    assert blas_limits() == {HOST_THREADS}


def test_nested_contexts_keep_the_outermost_limit(host):
    with blas_threads():
        assert blas_limits() == {1}
        with blas_threads(3):  # the outermost context decides
            assert blas_limits() == {1}
        assert blas_limits() == {1}
    assert blas_limits() == {HOST_THREADS}


def test_an_exception_restores_the_host(host):
    with pytest.raises(ZeroDivisionError), blas_threads():
        assert blas_limits() == {1}
        1 / 0  # noqa: B018
    assert blas_limits() == {HOST_THREADS}
    with blas_threads():  # and the depth count is back to zero
        assert blas_limits() == {1}
    assert blas_limits() == {HOST_THREADS}


def test_flexure_blas_threads_is_honoured(monkeypatch):
    monkeypatch.setenv("FLEXURE_BLAS_THREADS", "2")
    with threadpool_limits(limits=1, user_api="blas"):
        with blas_threads():
            assert blas_limits() == {2}
        assert blas_limits() == {1}


@pytest.mark.parametrize("value", ["0", "two", ""])
def test_a_bad_flexure_blas_threads_names_the_variable(monkeypatch, value):
    monkeypatch.setenv("FLEXURE_BLAS_THREADS", value)
    with pytest.raises(ValueError, match="FLEXURE_BLAS_THREADS: expected a positive integer"):
        with blas_threads():
            pass
    with blas_threads(1):  # nothing was left open
        pass


def test_decorated_functions_keep_their_name_and_documentation():
    assert static_equilibrium.__name__ == "static_equilibrium"
    assert "static equilibrium" in static_equilibrium.__doc__


def test_a_controller_looked_up_again_leaves_no_cyclic_garbage(monkeypatch):
    """After an import the libraries are looked up again; the replaced threadpoolctl
    controller is freed by reference counting (its libraries pointed back at it), which a
    host running with the cyclic collector off relies on."""
    import gc
    import types
    import weakref

    from flexure.core.numerics import blas

    with blas.blas_threads():
        pass
    replaced = weakref.ref(blas.blas_libraries())
    monkeypatch.setitem(sys.modules, "flexure_test_new_module", types.ModuleType("new"))
    gc.collect()
    gc.disable()
    try:
        with blas.blas_threads():
            pass
        assert replaced() is None
        assert gc.collect() == 0
    finally:
        gc.enable()


def test_the_loops_around_a_plant_run_with_one_blas_thread(host):
    """The Python sample loop (around the linear plant, the Simulator or an FMU) runs its
    per-sample BLAS calls with one thread, and the host's limit is back after it (a
    plant that records the limit at every step; docs/benchmarks.md: the linear 507-DOF loop
    under load, 2.4 to 17 s with two threads against 0.3 to 0.5 s with one)."""
    from types import SimpleNamespace

    from flexure.controllers.sample_loop import simulate_loop

    seen = set()

    class Plant:
        input_names, output_names = ["F"], ["x"]

        def reset(self):
            return np.zeros(1)

        def set_input(self, u):
            pass

        def advance(self, t_end):
            seen.update(blas_limits())

        def output(self):
            return np.zeros(1)

    class Controller:
        samples, fs, reference = 4, 1000.0, np.zeros((5, 1))

        def reset(self):
            pass

        def initial_output(self):
            return np.zeros(1)

        def step(self, k, y):
            return np.zeros(1), None

    design = SimpleNamespace(pairs=[SimpleNamespace(input_index=0, output_index=0)])
    simulate_loop(Plant(), Controller(), design)
    assert seen == {1}
    assert blas_limits() == {HOST_THREADS}
