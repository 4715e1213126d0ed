"""`examples.benchmarks.evaluation_trace`: the tracer between compiled callers and the engine
changes no result and logs every nested call under its caller; the log's arithmetic
(exclusive time, the Newton iterations by stage) on made-up logs with known answers."""

import numpy as np

from examples.benchmarks.evaluation_trace import (
    L_DEPTH,
    L_END,
    L_OP,
    L_PARENT,
    L_S,
    L_START,
    L_TIME,
    L_TOP,
    WIDTH,
    Tracer,
    call_label,
    exclusive,
    stage_iterations,
)
from flexure.core.engine import operations as ops


def test_the_tracer_changes_no_result_and_logs_the_nested_calls():
    """OP_RHS through the tracer equals the untraced call bit for bit at a moving state of
    stage_planar_3dof, and its log has the RHS at depth 0 with the kinematics
    (CONFIGURATION) under the accelerations below it, each call's end not before its start,
    exclusive times at most the inclusive ones."""
    from flexure.core import Simulator, load_scene
    from flexure.core.engine import engine as e

    sim = Simulator(load_scene("stage_planar_3dof"), method="esdirk", rtol=1e-6)
    y = np.linspace(1e-5, 2e-5, sim.nstate)
    plain, traced = np.zeros(sim.nstate), np.zeros(sim.nstate)
    assert e.call(sim.data, e.OP_RHS, y, plain) == 0
    tracer = Tracer(sim.data)
    tracer.install()
    assert tracer.call(e.OP_RHS, y + 1e-7, traced) == 0  # moved away, then back
    tracer.clear()
    assert tracer.call(e.OP_RHS, y, traced) == 0
    tracer.remove()
    rows = tracer.rows()
    assert traced.tobytes() == plain.tobytes()
    assert rows[-1, L_OP] == ops.OP_RHS and rows[-1, L_DEPTH] == 0
    assert np.sum(rows[:, L_DEPTH] == 0) == 1
    assert "CONFIGURATION in ACCELERATIONS" in [call_label(r) for r in rows]
    assert np.all(rows[:, L_END] >= rows[:, L_START])
    inclusive, own = exclusive(rows)
    assert np.all(own <= inclusive) and own.sum() == inclusive[-1]


def made_up_log(calls):
    """A log of (op, s, depth, start, end, top, parent code, t in ps) rows."""
    rows = np.zeros((len(calls), WIDTH), dtype=np.int64)
    for k, call in enumerate(calls):
        rows[k, [L_OP, L_S, L_DEPTH, L_START, L_END, L_TOP, L_PARENT, L_TIME]] = call
    return rows


def test_exclusive_time_subtracts_each_calls_callees():
    """A top call of 100 cycles with two callees (30, and 20 with its own callee of 5):
    exclusive 50, 30, 15 and 5."""
    sf, conf, solve = ops.OP_STAGE_FORCE, ops.OP_CONFIGURATION, ops.OP_SPARSE_SOLVE
    rows = made_up_log([(solve, 0, 1, 10, 40, 1, 4 * sf, 0),
                        (solve, 0, 2, 50, 55, 1, 4 * conf, 0),
                        (conf, 0, 1, 45, 65, 1, 4 * sf, 0),
                        (sf, 0, 0, 0, 100, 1, -1, 7)])
    inclusive, own = exclusive(rows)
    assert inclusive.tolist() == [30, 5, 20, 100]
    assert own.tolist() == [30.0, 5.0, 15.0, 50.0]
    assert call_label(rows[1]) == "SPARSE_SOLVE (J) in CONFIGURATION"


def test_stage_iterations_group_the_stage_forces_by_their_time():
    """Two stage forces at t = 7 ps, then one at t = 9, each followed by its force solve,
    the first with two J solves in its kinematics and a J factorisation: iterations 0, 1
    and 0, with their counts and times (cycles at rate 1)."""
    sf, conf, solve, factor = (ops.OP_STAGE_FORCE, ops.OP_CONFIGURATION, ops.OP_SPARSE_SOLVE,
                               ops.OP_SPARSE_FACTOR)
    fs = ops.OP_NEWTON_FORCE_SOLVE
    rows = made_up_log([(solve, 0, 2, 1, 2, 1, 4 * conf, 0), (solve, 0, 2, 2, 3, 1, 4 * conf, 0),
                        (factor, 0, 2, 3, 5, 1, 4 * conf, 0), (conf, 0, 1, 1, 6, 1, 4 * sf, 0),
                        (sf, 0, 0, 0, 10, 1, -1, 7), (fs, 0, 0, 10, 13, 2, -1, 7),
                        (sf, 0, 0, 13, 20, 3, -1, 7), (fs, 0, 0, 20, 22, 4, -1, 7),
                        (sf, 0, 0, 22, 30, 5, -1, 9), (fs, 0, 0, 30, 31, 6, -1, 9)])
    its = stage_iterations(rows, 1.0)
    assert [(t, i, s, j, f, g) for t, i, s, j, f, g in its] == [
        (7, 0, 10.0, 2, 1, 3.0), (7, 1, 7.0, 0, 0, 2.0), (9, 0, 8.0, 0, 0, 1.0)]


def test_the_lu_counts_read_the_packed_header_and_pointers():
    """`lu_counts` on manipulator_control's packed J and A: their orders are the free
    coordinates and those with the rigid rows, the nonzeros those of the pattern read back by
    `sparse_lu_pattern`, and L and U hold at least a diagonal each but no more than room."""
    from examples.benchmarks.evaluation_trace import lu_counts
    from flexure.core import load_scene
    from flexure.core.engine import data as ed
    from flexure.core.engine.data import EngineData
    from flexure.core.numerics.sparse_lu_pattern import pattern

    data = EngineData(load_scene("manipulator_control"))
    dims = data.int_array("dims")
    for key, order in (("j_sparse", dims[ed.NFREE]),
                       ("aug_sparse", dims[ed.NFREE] + dims[ed.NRIGID])):
        ints = data.int_array(key)
        n, nnz, in_l, in_u = lu_counts(ints)
        assert n == order and nnz == pattern(ints)[1].size
        assert n <= in_l <= ints[2] and n <= in_u <= ints[3]
