"""The BEAM's element mass in closed form (core/elements/beam_mass.py) and the engine's
operation that uses it for a group of BEAMs (core/engine/beam_mass_entry.py), against plain
numpy and the generic kernel.

Me = Dp^T Mp Dp with Dp and Mp from the numpy reference (`beam.inertia_points`,
`beam.inertia_matrix`) at random coordinates, section masses and y' axes; the structure checks
that guard the closed form (the mass pattern, Dp's non-zeros in their blocks); which models
run the operation (BEAMs without rigid clusters), that a planar model's process never
compiles it, and the cantilever's accelerations through it against the plain twin.
"""

import json
import sys

import children
import numpy as np
import pytest

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Mechanics, load_scene
from flexure.core.elements import beam
from flexure.core.elements.beam_mass import (
    PATTERN,
    beam_element_mass,
    beam_pattern,
    beam_structured,
)
from flexure.core.engine import beam_mass_entry, engine, operations
from flexure.core.engine import data as ed
from flexure.core.engine.data import EngineData
from flexure.core.engine.point_masses import element_mass, point_columns
from tests.test_engine import random_states
from tests.test_engine_sparse import check_against_the_twin


def beam_elements(n, seed):
    """(x (n, 14), Dp (n, 24, 14), Mp (n, 24, 24)) of n random BEAMs: random coordinates
    (rotated nodes, normalised Euler parameters), y' axes and section masses (kg/m, kg m)."""
    rng = np.random.default_rng(seed)
    x0, x = beam.random_coordinates(rng, n)
    y_axis = rng.standard_normal((n, 3))
    ref = beam.reference(x0, y_axis)
    props = {"rho_A": rng.uniform(0.1, 2.0, n), "rho_Iy": rng.uniform(1e-6, 1e-4, n),
             "rho_Iz": rng.uniform(1e-6, 1e-4, n)}
    _, Dp = beam.inertia_points(x, ref, order=1)
    return x, np.ascontiguousarray(Dp), beam.inertia_matrix(ref, props)


@pytest.mark.slow  # the kernel compiled for Python (13 s cold); the operation's test is below
def test_beam_element_mass():
    """Me = Dp^T Mp Dp to round-off (1e-13 of its largest entry), as the generic kernel
    gives it; the reference's Mp has the pattern and its Dp the structure the checks pass."""
    _, Dps, Mps = beam_elements(20, seed=1)
    for Dp, Mp in zip(Dps, Mps, strict=True):
        assert np.array_equal(np.flatnonzero(Mp.ravel()), PATTERN)
        assert beam_pattern(PATTERN)
        columns = np.zeros(24 * 15 + 14, dtype=np.int64)
        point_columns(24, 14, Dp, columns)
        assert beam_structured(Dp, columns)
        Me = np.full(14 * 14, np.nan)
        beam_element_mass(Mp.ravel(), Dp, Me)
        expected = Dp.T @ Mp @ Dp
        scale = np.max(np.abs(expected))
        assert np.max(np.abs(Me - expected.ravel())) <= 1e-13 * scale
        generic, w = np.zeros(14 * 14), np.zeros(24)
        element_mass(Mp.ravel(), PATTERN, 24, 14, Dp, np.ones(24), w, generic, columns)
        assert np.max(np.abs(Me - generic)) <= 1e-13 * scale


def test_structure_checks():
    """The pattern check refuses a pattern with an entry more, one less or moved; the Dp check
    refuses a non-zero outside its point's block (r^p on lambda_p, n_y'^q on x_q, l0 n_x'^p
    on lambda_q) and passes zeros inside one."""
    assert not beam_pattern(PATTERN[:-1])
    assert not beam_pattern(np.sort(np.append(PATTERN, 1)))
    moved = PATTERN.copy()
    moved[5] += 1
    assert not beam_pattern(moved)
    _, Dps, _ = beam_elements(1, seed=2)
    columns = np.zeros(24 * 15 + 14, dtype=np.int64)
    for row, column in ((0, 4), (19, 8), (4, 11)):
        Dp = Dps[0].copy()
        Dp[row, column] = 0.5
        point_columns(24, 14, Dp, columns)
        assert not beam_structured(Dp, columns)
    Dp = Dps[0].copy()
    Dp[3:6, 3:7] = 0.0  # an exact zero in a block (lambda_p = (1, 0, 0, 0) gives some)
    point_columns(24, 14, Dp, columns)
    assert beam_structured(Dp, columns)


def test_which_models_run_the_operation():
    """The cantilever (BEAMs, no clusters) does; the planar demo stage (PLBEAMs) and the
    manipulator (BEAMs on rigid clusters: their touching masses go on the z-coordinates) do
    not."""
    assert beam_mass_entry.uses(EngineData(spatial_cantilever(4)))
    assert not beam_mass_entry.uses(EngineData(load_scene("stage_planar_1dof")))
    assert not beam_mass_entry.uses(EngineData(load_scene("manipulator_control")))


PROBE = """
import json
from flexure.core import load_scene, simulate
from flexure.core.engine import engine, operations
simulate(load_scene("stage_planar_1dof"), 2e-3, inputs={"F": 1.0}, method="esdirk", rtol=1e-8)
print(json.dumps(engine.ENTRIES[operations.OP_BEAM_MASSES].is_compiled))
"""


def test_a_planar_models_process_does_not_compile_it():
    """In a fresh interpreter (the table of operations is the process's), the planar demo
    stage's simulation leaves OP_BEAM_MASSES uncompiled."""
    done = children.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                        check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) is False


def test_the_cantilever_through_the_operation_against_the_plain_twin():
    """The 8-BEAM cantilever at two displaced, moving states, its BEAM group's masses through
    OP_BEAM_MASSES: x and DF, qddot's backward error to 1e-14 of the force terms, M_bar to
    1e-12 and the tangent to 1e-9 of their largest entries (`check_against_the_twin`)."""
    model = spatial_cantilever(8)
    mechanics = Mechanics(model)
    data = EngineData(model)
    assert beam_mass_entry.uses(data)
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    check_against_the_twin(model, mechanics, data, random_states(model, q0, seed=7),
                           tangent_rtol=1e-9)
    op = operations.OP_BEAM_MASSES  # connected: `run` reaches the closed form
    assert engine.ENGINE_TABLE[op] == engine.ENTRIES[op].address
    # and the BEAM group takes it; the others (the nodes' Euler parameters) are not BEAMs'
    dims = data.int_array("dims")
    statuses = [beam_mass_entry.group_masses(data.address, g, 0, False)
                for g in range(dims[ed.NGROUPS])]
    assert statuses.count(ed.OK) == 1
    assert all(status in (ed.OK, ed.NOT_AVAILABLE) for status in statuses)
