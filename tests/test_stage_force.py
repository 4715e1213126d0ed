"""The ESDIRK's stage residual in mass form (`engine.stage_force`) and the stages that take it.

On the sparse Newton path a stage iteration evaluates g = DF^T (r - M xddot_c) for the
candidate accelerations a_c = (v - base_v) / hg instead of the accelerations qddot, and the
Newton solve lifts hg g by J^T (NEWTON_FORCE_SOLVE). Checked here, on the 16-BEAM spatial
cantilever (96 DOFs, A banded) and manipulator_control (75 DOFs, A sparse), both on that path
by default, the manipulator packed both without eliminating its rigid clusters' slaves
(rigid=False) and with them ("manipulator_clusters", its default: the kinematics, the force
and the solves on the reduced coordinates z), and a rod with a body under a moment input (the
moment's force depends on x; tests/test_rotation_ports.py) with the path forced:

- g against M_bar (qddot - a_c), qddot from the full rhs (OP_RHS) and M_bar from OP_MASS
  (DF^T M DF) at the same state, at random states;
- NEWTON_FORCE_SOLVE of [r1; M_bar r2] against NEWTON_SOLVE of [r1; r2] at the Newton
  matrix's own state (where the two are the same equation);
- the input response after a stage force (A assembled there but not factored) against the
  difference of two full rhs;
- the 5 ms cantilever run and a short loop of the manipulator with the mass form against the
  same with the accelerations' form (flags[I_MASS_FORM] = 0).
"""

import numpy as np
import pytest

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Mechanics, Simulator, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine, newton_packing
from flexure.core.engine.data import EngineData
from flexure.core.engine.operations import (
    OP_MASS,
    OP_NEWTON_FACTOR,
    OP_NEWTON_FORCE_SOLVE,
    OP_NEWTON_JACOBIAN,
    OP_NEWTON_SOLVE,
    OP_STAGE_FORCE,
)
from flexure.core.simulation.esdirk_layout import I_ETA_HOLD, I_MASS_FORM
from tests.compiled_loops import run_compiled_loop
from tests.test_engine import close, random_states
from tests.test_rotation_ports import build_model, rod_body

MODELS = {"cantilever_16": lambda: spatial_cantilever(16),
          "manipulator_control": lambda: load_scene("manipulator_control"),
          "manipulator_clusters": lambda: load_scene("manipulator_control"),
          "rod_body": lambda: build_model(rod_body())}


def states(model, data, seed, count=3):
    """(y, u): states y = [q - q_ref, qdot] about the scene's DOFs (`random_states`: 1e-4 m or
    rad, 0.05 m/s or rad/s) and inputs u (N, N m)."""
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    q_ref = data.float_array("q_ref")
    return [(np.concatenate([q - q_ref, qdot]), u)
            for q, qdot, u in random_states(model, q0, seed=seed, count=count)]


def rhs(data, y, u):
    """qddot (m/s^2, rad/s^2) of the full rhs at y with inputs u."""
    data.float_array("inputs")[:] = u
    ydot = np.zeros_like(y)
    assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
    return ydot[y.size // 2:]


def stage_force(data, y, u, acc):
    """g (N, N m) of the stage force at y with inputs u for the candidate accelerations acc."""
    data.float_array("inputs")[:] = u
    g = np.full(acc.size, np.nan)
    assert engine.call(data, OP_STAGE_FORCE, y, acc.copy(), g) == ed.OK
    return g


def packed(name, monkeypatch):
    """(model, data) on the sparse Newton path: the rod's forced (below SPARSE_NEWTON_FROM
    DOFs), "manipulator_control" without slave elimination, "manipulator_clusters" with it."""
    model = MODELS[name]()
    if name == "rod_body":
        monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", 0)
    data = EngineData(model, rigid=name != "manipulator_control", augmented=True)
    assert data.int_array("dims")[ed.NEWTON_SPARSE] == 1
    return model, data


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_stage_force_is_the_mass_times_the_acceleration_defect(name, monkeypatch):
    """g = M_bar (qddot - a_c) at random states (moving and at rest) for candidate
    accelerations a_c = qddot + a random defect of qddot's size, to 1e-12 of the size of
    its terms, max_i sum_j |M_bar_ij| (|qddot_j| + |a_c_j|) (measured: 1.5e-16 on the
    cantilever, 7e-16 on the manipulator with and without its clusters, 1.4e-15 on the
    rod), and g = 0 at a_c = qddot.
    An evaluation, counted in counters[EVALUATIONS]."""
    model, data = packed(name, monkeypatch)
    n = data.int_array("dims")[ed.NDOF]
    rng = np.random.default_rng(11)
    for k, (y, u) in enumerate(states(model, data, seed=12)):
        if k == 0:
            y[n:] = 0.0  # at rest: no h, no g_conv
        qddot = rhs(data, y, u)
        assert engine.call(data, OP_MASS) == ed.OK
        mass = data.float_array("mass")[: n * n].reshape(n, n).copy()
        acc = qddot + np.max(np.abs(qddot)) * rng.standard_normal(n)
        before = data.int_array("counters")[ed.EVALUATIONS]
        g = stage_force(data, y, u, acc)
        assert data.int_array("counters")[ed.EVALUATIONS] == before + 1
        size = np.max(np.abs(mass) @ (np.abs(qddot) + np.abs(acc)))
        close(g, mass @ (qddot - acc), 1e-12, scale=size)
        close(stage_force(data, y, u, qddot), 0.0, 1e-12, scale=size)  # zero at the root


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_force_solve_is_the_solve_at_the_newton_matrix_state(name, monkeypatch):
    """At the Newton matrix's own state, M_bar there lifts r2 (hg g = M_bar r2):
    NEWTON_FORCE_SOLVE of [r1; M_bar r2] equals NEWTON_SOLVE of [r1; r2] to 1e-9 of the
    solution's size (the solves' round-off: tests/test_sparse_newton.py's bound; measured
    1.1e-11 on the cantilever, 4e-14 on the manipulator, 2.3e-14 with its clusters,
    3e-16 on the rod), for hg near and
    far from zero (s)."""
    model, data = packed(name, monkeypatch)
    n = data.int_array("dims")[ed.NDOF]
    (y, u), = states(model, data, seed=21, count=1)
    data.float_array("inputs")[:] = u
    assert engine.call(data, OP_NEWTON_JACOBIAN, y, np.zeros(1)) == ed.OK
    assert engine.call(data, OP_MASS) == ed.OK
    mass = data.float_array("mass")[: n * n].reshape(n, n).copy()
    rng = np.random.default_rng(22)
    for hg in (2e-8, 1e-5, 1e-3):
        r = rng.standard_normal(2 * n)
        assert engine.call(data, OP_NEWTON_FACTOR, s=hg) == ed.OK
        expected = r.copy()
        assert engine.call(data, OP_NEWTON_SOLVE, expected, s=hg) == ed.OK
        v = np.concatenate([r[:n], mass @ r[n:]])
        assert engine.call(data, OP_NEWTON_FORCE_SOLVE, v, s=hg) == ed.OK
        close(v, expected, 1e-9)


@pytest.mark.parametrize("name", ["manipulator_clusters", "manipulator_control", "rod_body"])
def test_the_input_response_after_a_stage_force_is_the_change_of_the_rhs(name, monkeypatch):
    """After a stage force (A neither assembled nor factored) the input response has A made and
    equals qddot(u1) - qddot(u0) of two full rhs at that state to 1e-12 of qddot's size
    (tests/test_input_response.py's bound); a second response reuses those factors."""
    model, data = packed(name, monkeypatch)
    for (y, u0), (_, u1) in zip(states(model, data, seed=31), states(model, data, seed=32),
                                strict=True):
        n = y.size // 2
        stage_force(data, y, u0, np.zeros(n))
        assert data.int_array("dims")[ed.A_FACTORS] == ed.A_AT_STAGE
        data.float_array("inputs")[:] = u1
        change = np.full(n, np.nan)
        assert engine.call(data, engine.OP_INPUT_RESPONSE, change) == ed.OK
        again = np.full(n, np.nan)
        data.float_array("inputs")[:] = 2.0 * u1
        assert engine.call(data, engine.OP_INPUT_RESPONSE, again) == ed.OK
        before, after, twice = rhs(data, y, u0), rhs(data, y, u1), rhs(data, y, 2.0 * u1)
        size = max(np.max(np.abs(before)), np.max(np.abs(after)))
        assert np.max(np.abs(after - before)) > 1e4 * 1e-12 * size  # resolved to 1e-4
        close(change, after - before, 1e-12, scale=size)
        close(again, twice - before, 1e-12, scale=size)


def cantilever_run(mass_form, rtol=1e-6):
    """The 16-BEAM cantilever's coordinates (m, 1) 5 ms after its 1 N tip load (ESDIRK at
    rtol) and its statistics, with the stages' mass form on or off; the Newton contraction
    estimate grown at every step (flags[I_ETA_HOLD] = 0), as when the figures below were
    measured: held (the sparse path's default, `esdirk_newton.ETA_HOLD`) the accelerations'
    form, whose contraction is faster, re-measures less often (437 against 483 rhs),
    which compares the forms' Newton controls rather than their iterates."""
    sim = Simulator(spatial_cantilever(16), method="esdirk", rtol=rtol)
    sim.integrator.flags[I_MASS_FORM] = int(mass_form)
    sim.integrator.flags[I_ETA_HOLD] = 0
    sim.advance_to(5e-3)
    return sim.data.float_array("x").copy(), sim.statistics


def test_the_cantilever_run_in_mass_form_is_the_run_in_accelerations():
    """The 5 ms run at rtol 1e-6 in mass form against the same run with the accelerations'
    residual. Each stage's Newton stops at eta |dz| <= 0.05 of the step's tolerance (rtol |y|
    + atol), so at each step the two runs differ by at most twice that, and over the steps by
    at most their sum: bound 2 x 0.05 x steps x rtol of the largest displacement (measured
    4.3e-11 m against a bound of 1.2e-9 m, 70 steps, 1.7e-4 m moved). Both within 1e-3 of
    the displacement of the converged run (the global error: tests/test_sparse_newton.py);
    the same steps; the mass form's rhs count within 10 % of the other's (measured 500
    against 473: its iterates differ by (M_bar(z) - M_bar_J) r2, a contraction a little
    slower)."""
    mass, mass_stats = cantilever_run(True)
    accelerations, stats = cantilever_run(False)
    converged, _ = cantilever_run(False, rtol=1e-10)
    moved = np.max(np.abs(converged - spatial_cantilever(16).initial_coordinates))
    assert moved > 1e-5  # m: the tip has moved
    assert np.max(np.abs(mass - accelerations)) <= 2 * 0.05 * stats["steps"] * 1e-6 * moved
    for run in (mass, accelerations):
        assert np.max(np.abs(run - converged)) <= 1e-3 * moved
    assert mass_stats["steps"] == stats["steps"]
    assert abs(mass_stats["rhs_evaluations"] / stats["rhs_evaluations"] - 1.0) <= 0.1


@pytest.mark.slow
@pytest.mark.parametrize("rigid", [False, True])
def test_the_manipulator_loop_in_mass_form_tracks_as_in_accelerations(rigid):
    """A 10 ms move of manipulator_control at 4 kHz (esdirk, rtol 1e-6, the compiled loop,
    whose first stage after each input change takes the input response from a stage force's
    A; without slave elimination and with it, both on the sparse Newton path) with the mass
    form against the accelerations' form: the positions within 0.05 rtol of the stroke (the
    Newton tolerance, as above; measured 3.5e-10 of the stroke, 3.5e-4 rtol, with and
    without elimination), the forces within 1e-5 of the largest (measured 2.4e-7 on both:
    the feedback's gain from the loops' outputs, the held loops' with them, to the
    forces)."""
    from flexure.controllers import build_loop

    model = load_scene("manipulator_control")
    controller, design = build_loop(model, stroke=1e-3, duration=0.01, settle=0.0025,
                                    fs=4000.0)
    runs = []
    for mass_form in (True, False):
        sim = Simulator(model, method="esdirk", rtol=1e-6, rigid=rigid)
        assert sim.data.int_array("dims")[ed.NEWTON_SPARSE] == 1
        assert (sim.data.int_array("dims")[ed.NSLAVES] > 0) == rigid
        sim.integrator.flags[I_MASS_FORM] = int(mass_form)
        runs.append(run_compiled_loop(sim, controller, design))
    (_, position, force), (_, position_a, force_a) = runs
    stroke = np.ptp(position_a)
    assert stroke > 5e-4
    close(position, position_a, 0.05 * 1e-6, scale=stroke)
    close(force, force_a, 1e-5)
