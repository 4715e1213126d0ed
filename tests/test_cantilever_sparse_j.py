"""The spatial cantilevers of 16 BEAMs and more factor their constraint Jacobian J with the
sparse LU (`sparse_packing.SPARSE_FROM`: measured faster from 96 DOFs on) and keep the
augmented system banded; on that path the engine's kinematics, accelerations, M_bar and
tangent match the plain-numpy twin (`test_engine_sparse.check_against_the_twin`), and one
rhs matches the one of the same model packed banded throughout."""

import numpy as np
import pytest

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Mechanics
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from tests.test_engine import random_states
from tests.test_engine_sparse import check_against_the_twin


@pytest.mark.parametrize("segments, j_sparse", [(8, 0), (16, 1), (64, 1)])
def test_which_cantilevers_factor_j_sparse(segments, j_sparse):
    """From 16 BEAMs (banded LUs of 8.6e4 multiplications, above SPARSE_FROM) J sparse; the
    augmented system banded (its sparse LU weighs more by the cost counts); 8 BEAMs (4.3e4)
    not analysed: banded both."""
    dims = EngineData(spatial_cantilever(segments)).int_array("dims")
    assert (dims[ed.J_SPARSE], dims[ed.A_SPARSE]) == (j_sparse, 0)


def test_the_16_beam_cantilever_on_the_sparse_j_against_the_plain_twin():
    """At two displaced, moving states: x and DF to 1e-14 and 1e-12, qddot's backward error
    to 1e-14 of the force terms, M_bar to 1e-12, K and C to 1e-9 of their largest entries
    (the cantilever's axial rows make K's small entries ill-conditioned: the banded path
    meets the same bound)."""
    model = spatial_cantilever(16)
    mechanics = Mechanics(model)
    data = EngineData(model)
    assert data.int_array("dims")[ed.J_SPARSE] == 1
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    check_against_the_twin(model, mechanics, data, random_states(model, q0, seed=5),
                           tangent_rtol=1e-9)
    assert data.int_array("counters")[ed.SPARSE_FALLBACKS] == 0


def test_one_rhs_on_the_sparse_j_equals_the_banded_one():
    """One rhs of the 16-BEAM cantilever at a state 1 ms into its run after the tip load, J
    factored sparse against the same model packed banded throughout, both from a cold start:
    qddot within 1e-7 of its largest entry (measured 2.4e-8). Not round-off alone: the
    kinematics stop within their row tolerance, which the stiff axial rows amplify; on either
    path the same state evaluated after a warm start elsewhere moves qddot by 1.8e-5 of it
    (docs/benchmarks.md, session 27)."""
    from flexure.core import Simulator

    model = spatial_cantilever(16)
    sim = Simulator(model, method="esdirk", rtol=1e-6)
    sim.advance_to(1e-3)
    y = np.ascontiguousarray(sim.state, dtype=float)
    results = []
    for sparse in (None, False):
        data = EngineData(model, sparse=sparse)
        assert data.int_array("dims")[ed.J_SPARSE] == (1 if sparse is None else 0)
        ydot = np.empty_like(y)
        assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
        results.append(ydot)
    n = model.declared_dof_count
    sparse_qddot, banded_qddot = results[0][n:], results[1][n:]
    assert np.all(np.isfinite(sparse_qddot))
    scale = np.max(np.abs(banded_qddot))
    assert scale > 0.0
    assert np.max(np.abs(sparse_qddot - banded_qddot)) <= 1e-7 * scale
    np.testing.assert_array_equal(results[0][:n], results[1][:n])
