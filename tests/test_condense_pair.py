"""OP_RIGID_CONDENSE's paired job (s = WITH_FORCE: T^T of a vector and of slot force in one
walk of T's terms, which the refined evaluation's first residual asks for its round-off
scale, `refined_accelerations`) against two plain calls, bitwise, and against a plain
formula of T^T, on manipulator_control.
"""

import numpy as np

from flexure.core import Mechanics, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.engine.operations import ALONE, OP_RIGID_CONDENSE, WITH_FORCE
from flexure.core.mechanics.rigid_bodies import DEPENDENCIES


def _state(model, data, rng):
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    q, qdot = q0 + 1e-4 * rng.standard_normal(q0.size), 0.05 * rng.standard_normal(q0.size)
    return np.concatenate([q - data.float_array("q_ref"), qdot])


def test_the_paired_condensation_is_two_condensations():
    """OP_RIGID_CONDENSE with s = WITH_FORCE (the refinement's first residual: T^T of its
    vector and of slot force in one pass) gives bitwise what two plain calls give, and
    T^T v against a plain formula: v on the free coordinates plus each slave coordinate's
    weights times v there, to 1e-15 of the largest term."""
    model = load_scene("manipulator_control")
    data = EngineData(model, augmented=True)
    y = _state(model, data, np.random.default_rng(9))
    assert engine.call(data, engine.OP_RHS, y, np.zeros_like(y)) == ed.OK
    rng = np.random.default_rng(1)
    nx, nf = data.float_array("x").size, data.int_array("free").size
    v, force = rng.normal(size=nx), rng.normal(size=nx)
    v[rng.random(nx) < 0.2] = 0.0  # the zeros each walk skips
    data.float_array("force")[:] = force
    paired = np.full(nf, np.nan)
    assert engine.call(data, OP_RIGID_CONDENSE, v, paired, s=WITH_FORCE) == ed.OK
    paired_force = data.float_array("dx")[:nf].copy()
    alone, alone_force = np.full(nf, np.nan), np.full(nf, np.nan)
    assert engine.call(data, OP_RIGID_CONDENSE, v, alone, s=ALONE) == ed.OK
    assert engine.call(data, OP_RIGID_CONDENSE, force, alone_force, s=ALONE) == ed.OK
    assert np.array_equal(paired, alone) and np.array_equal(paired_force, alone_force)
    free, column = data.int_array("free"), data.int_array("column_of_coordinate")
    coords, deps = data.int_array("rigid_coordinates"), data.int_array("rigid_dependencies")
    W = data.float_array("rigid_weights")
    expected, magnitude = v[free].copy(), np.abs(v[free])
    for s, c in enumerate(coords):
        for d in range(DEPENDENCIES):
            dep = deps[s * DEPENDENCIES + d]
            if dep >= 0 and column[dep] >= 0:
                expected[column[dep]] += W[s * DEPENDENCIES + d] * v[c]
                magnitude[column[dep]] += abs(W[s * DEPENDENCIES + d] * v[c])
    assert np.max(np.abs(paired - expected)) <= 1e-15 * np.max(magnitude)
