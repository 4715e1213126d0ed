"""IDA with kinematic inputs (`engine.prescribed_residual`): the residual form's Jacobian
against finite differences, a base-driven mass-spring against its closed form, IDA against
CVODE and the ESDIRK on the scene's move and on a host's steps (`move_to`), SUNDIALS' own
finite-difference Jacobian, and a state it cannot evaluate.

The chain (tests/kinematic_scenes.py): ground -k1, c1- node 1 (m1, the kinematic input u)
-k2, c2- node 2 (m2, free): along x the springs are linear, so with z = x2 - x1 - 0.1 m

    m2 z'' + c2 z' + k2 z = -m2 u'',   F = m1 u'' + c1 u' + k1 (u - 0.1) - k2 z - c2 z'

(F, N: the effort that moves node 1), from rest; for the quintic u this is a cubic
particular solution plus the damped free response.
"""

import numpy as np
import pytest
from kinematic_scenes import C1, C2, K1, K2, M1, M2, X0, chain, motion, with_motion

from flexure.core import build_model
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.errors import SimulationError
from flexure.core.simulation.simulator import Simulator
from flexure.core.simulation.sundials import Ida

D, T = 1e-3, 0.04  # the chain's move: 1 mm in 40 ms


def moved_chain(rho_A=0.0):
    data = chain(rho_A=rho_A)
    data["inputs"]["u"]["value"] = X0 + D
    return build_model(data)


def quintic(t):
    """u - X0, u', u'' (m, m/s, m/s^2) of the rest-to-rest move of D in T, held after."""
    s = min(t, T) / T
    return (D * (10 * s**3 - 15 * s**4 + 6 * s**5),
            D / T * (30 * s**2 - 60 * s**3 + 30 * s**4) if t < T else 0.0,
            D / T**2 * (60 * s - 180 * s**2 + 120 * s**3) if t < T else 0.0)


def free_response(z0, v0, t):
    """z, z' (m, m/s) of m2 z'' + c2 z' + k2 z = 0 from z0, v0 after t s (underdamped)."""
    a, w2 = C2 / (2 * M2), K2 / M2
    wd = np.sqrt(w2 - a * a)
    decay, c, s = np.exp(-a * t), np.cos(wd * t), np.sin(wd * t)
    return (decay * (z0 * c + (v0 + a * z0) / wd * s),
            decay * (v0 * c - (w2 * z0 + a * v0) / wd * s))


def closed_form(t):
    """x2 (m), x2' (m/s) and the effort F (N) of the chain at t (module docstring)."""
    # the cubic p(t) = sum b_j t^j with m2 p'' + c2 p' + k2 p = -m2 u''(t) = sum r_j t^j
    r = -M2 * D / T**2 * np.array([0.0, 60 / T, -180 / T**2, 120 / T**3])
    A = np.zeros((4, 4))  # row: power of t; column: b_j
    for j in range(4):
        A[j, j] += K2
        if j >= 1:
            A[j - 1, j] += C2 * j
        if j >= 2:
            A[j - 2, j] += M2 * j * (j - 1)
    b = np.linalg.solve(A, r)
    p = np.polynomial.Polynomial(b)

    def moving(t):
        z, v = free_response(-p(0.0), -p.deriv()(0.0), t)
        return z + p(t), v + p.deriv()(t)

    z, v = moving(t) if t <= T else free_response(*moving(T), t - T)
    u, rate, acceleration = quintic(t)
    effort = M1 * acceleration + C1 * rate + K1 * u - K2 * z - C2 * v
    return X0 + u + 0.1 + z, rate + v, effort


def test_the_closed_form_solves_its_equation():
    """The reference itself: its z'' by central differences (h = 1e-5 s) satisfies
    m2 z'' + c2 z' + k2 z = -m2 u'' within 1e-6 of m2 |u''|'s largest, 0.9 N (measured
    1.6e-7: the differences' truncation), and it starts at rest."""
    h, largest = 1e-5, M2 * 10 / np.sqrt(3) * D / T**2
    for t in (0.005, 0.02, 0.035, 0.05):
        z = [closed_form(s)[0] - X0 - quintic(s)[0] - 0.1 for s in (t - h, t, t + h)]
        v = closed_form(t)[1] - quintic(t)[1]
        accel = (z[0] - 2 * z[1] + z[2]) / h**2
        assert abs(M2 * accel + C2 * v + K2 * z[1] + M2 * quintic(t)[2]) <= 1e-6 * largest
    x2, v2, _ = closed_form(0.0)
    assert abs(x2 - 0.2) <= 1e-15 and abs(v2) <= 1e-15


def test_ida_drives_the_base_of_a_mass_spring_as_its_closed_form():
    """The chain's node 1 moved 1 mm in 40 ms and held to 80 ms, IDA at rtol 1e-10: the free
    mass's x2 within 1e-10 m of the closed form (it moves 1.2 mm), its velocity within 1e-8
    m/s, the effort (1.9 N from least to most) within 1e-8 N (measured 1.9e-12 m, 7.6e-11 m/s,
    9.2e-10 N); the path's position within 1e-15 m of the quintic, the state's own entry
    (integrated from u'') within 1e-10 m (measured 1.1e-13 m)."""
    sim = Simulator(moved_chain(), method="ida", rtol=1e-10, motion_duration=T)
    for t in np.linspace(0.01, 0.08, 8):
        sim.advance_to(t)
        x2, v2, effort = closed_form(t)
        assert abs(sim.q[1] - x2) <= 1e-10, t
        assert abs(sim.qdot[1] - v2) <= 1e-8, t
        assert abs(sim.efforts()[0] - effort) <= 1e-8, t
        assert abs(sim.prescribed_values()[0][0] - X0 - quintic(t)[0]) <= 1e-15
        assert abs(sim.q[0] - X0 - quintic(t)[0]) <= 1e-10  # the state's: integrated


@pytest.mark.parametrize("t", [0.0, 0.013, 0.05])
def test_the_prescribed_residual_jacobian_against_finite_differences(t):
    """stage_planar_3dof with 3.x prescribed, mid-move and at rest, at a state and yp off
    the solution: IDA's Jacobian d res / d y + cj d res / d yp against central differences
    of the residual (relative step 1e-7 of each state's scale) within 1e-5 of each column's
    largest entry; the input's rows and columns of the dynamic balance exactly zero but cj on
    its diagonal."""
    model = build_model(with_motion("stage_planar_3dof", "3", "x", value=0.001))
    sim = Simulator(model, method="ida", rtol=1e-8, motion_duration=0.04)
    n, N, cj = sim.ndof, 2 * sim.ndof, 250.0
    rng = np.random.default_rng(7)
    y = np.concatenate([1e-5 * rng.standard_normal(n), 1e-3 * rng.standard_normal(n)])
    yp = np.concatenate([1e-3 * rng.standard_normal(n), 10.0 * rng.standard_normal(n)])

    def residual(y, yp):
        res = np.empty(N)
        assert engine.call(sim.data, engine.OP_RESIDUAL, y, yp, res, t=t) == ed.OK
        return res

    J = np.empty(N * N)
    assert engine.call(sim.data, engine.OP_RESIDUAL_JACOBIAN, y, yp, J, s=cj, t=t) == ed.OK
    J = J.reshape(N, N).T  # column-major
    for j in range(N):
        h = 1e-7 * (1e-3 if j < n else 1.0)
        up, down, up_p, down_p = y.copy(), y.copy(), yp.copy(), yp.copy()
        up[j] += h
        down[j] -= h
        up_p[j] += cj * h  # d/dy + cj d/dyp: yp moves with y at the rate cj
        down_p[j] -= cj * h
        column = (residual(up, up_p) - residual(down, down_p)) / (2 * h)
        scale = max(np.max(np.abs(column)), 1.0)
        assert np.max(np.abs(J[:, j] - column)) <= 1e-5 * scale, j
    k = int(model.prescribed_dofs[0])
    assert np.all(np.delete(J[n + k], n + k) == 0.0) and J[n + k, n + k] == cj
    assert np.all(np.delete(J[n:, k], k) == 0.0)
    assert np.all(np.delete(J[n:, n + k], k) == 0.0)


@pytest.mark.parametrize("rho_A", [0.0, 0.6])
def test_ida_agrees_with_cvode_and_the_esdirk_on_the_scenes_move(rho_A):
    """The chain moved 1 mm in 40 ms, with b a spring or a truss with consistent mass (M_fk
    coupling the input's acceleration into the free row), at rtol 1e-10: IDA's DOFs within
    1e-10 m, velocities within 1e-8 m/s and effort within 1e-8 N of CVODE BDF's and the
    ESDIRK's at each of 6 times (measured at most 1.8e-12 m, 1.4e-10 m/s, 1.0e-9 N)."""
    runs = {}
    for method in ("ida", "cvode-bdf", "esdirk"):
        sim = Simulator(moved_chain(rho_A), method=method, rtol=1e-10, motion_duration=T)
        rows = []
        for t in np.linspace(0.01, 0.06, 6):
            sim.advance_to(t)
            rows.append((sim.q.copy(), sim.qdot.copy(), sim.efforts().copy()))
        runs[method] = [np.array(part) for part in zip(*rows, strict=True)]
    for other in ("cvode-bdf", "esdirk"):
        for part, bound in zip(range(3), (1e-10, 1e-8, 1e-8), strict=True):
            difference = np.max(np.abs(runs["ida"][part] - runs[other][part]))
            assert difference <= bound, (other, part, difference)


def test_ida_agrees_with_cvode_on_a_hosts_steps():
    """A host's steps (`stepwise_motion`, `move_to`: what the displacement-driven FMU does)
    on a variable grid, the chain's node 1 on the smooth motion: IDA at rtol 1e-9 against
    CVODE BDF and the ESDIRK at rtol 1e-9: x2 within 1e-9 m (it moves about 1 mm), v2 within
    1e-7 m/s, the effort within 1e-7 N (of up to 10.7 N; measured 6.2e-12 m, 6.0e-10 m/s,
    3.1e-9 N)."""
    steps = np.array([1e-3, 2.5e-3, 0.4e-3, 1.7e-3, 3e-3, 0.9e-3, 1e-3, 2e-3] * 3)
    times = np.concatenate([[0.0], np.cumsum(steps)])
    runs = {}
    for method in ("ida", "cvode-bdf", "esdirk"):
        sim = Simulator(build_model(chain()), method=method, rtol=1e-9, stepwise_motion=True)
        rows = []
        for t1 in times[1:]:
            sim.move_to([motion(t1)[0]], t1)
            rows.append([*sim.outputs(), *sim.efforts()])
        runs[method] = np.array(rows)
    for other in ("cvode-bdf", "esdirk"):
        difference = np.max(np.abs(runs["ida"] - runs[other]), axis=0)
        assert np.all(difference <= [1e-9, 1e-7, 1e-7]), (other, difference)


def test_a_state_ida_cannot_evaluate_is_named():
    """With kinematic inputs, a non-finite state: the residual answers the engine's status
    (NONFINITE_STATE), and IDA's restart is refused naming the time and the cause."""
    sim = Simulator(moved_chain(), method="ida", motion_duration=T)
    y = np.array([np.nan, 0.0, 0.0, 0.0])
    res = np.empty(4)
    status = engine.call(sim.data, engine.OP_RESIDUAL, y, np.zeros(4), res, t=0.01)
    assert status == ed.NONFINITE_STATE
    integrator = Ida(sim.data, rtol=1e-6, atol=np.full(4, 1e-9))
    with pytest.raises(SimulationError, match=r"t = 0.01 s: IDA could not start: the state "
                                              r"became non-finite"):
        integrator.reset(0.01, y)


def test_ida_with_finite_differences_agrees_with_its_analytic_jacobian():
    """jacobian="finite-difference" (SUNDIALS' own, on the prescribed residual) on the
    chain's move at rtol 1e-10: x2 within 1e-10 m and the effort within 1e-8 N of the
    analytic Jacobian's run (measured 2.7e-15 m, 1.0e-12 N, in the same 375 steps)."""
    runs = []
    for jacobian in ("analytic", "finite-difference"):
        sim = Simulator(moved_chain(), method="ida", rtol=1e-10, motion_duration=T,
                        jacobian=jacobian)
        rows = []
        for t in (0.02, 0.04, 0.06):
            sim.advance_to(t)
            rows.append([sim.q[1], sim.efforts()[0]])
        runs.append(np.array(rows))
    difference = np.max(np.abs(runs[0] - runs[1]), axis=0)
    assert np.all(difference <= [1e-10, 1e-8]), difference


def test_ida_takes_a_force_input_changed_while_the_kinematic_input_moves():
    """The chain (b a truss with consistent mass) with a force F on node 2 set to 0, 0.5 and
    1 N in turn every 5 ms while node 1 moves, at rtol 1e-10: IDA's DOFs within 1e-10 m and
    effort within 1e-7 N of CVODE BDF's at each of 12 times (measured 9.4e-12 m, 4.9e-9 N)."""
    data = chain(rho_A=0.6)
    data["inputs"]["u"]["value"] = X0 + D
    data["inputs"]["F"] = {"node": "2", "coordinate": "x"}
    model = build_model(data)
    runs = {}
    for method in ("ida", "cvode-bdf"):
        sim = Simulator(model, method=method, rtol=1e-10, motion_duration=T)
        rows = []
        for k, t in enumerate(np.linspace(0.005, 0.06, 12)):
            sim.set_inputs([(k % 3) * 0.5])
            sim.advance_to(t)
            rows.append([*sim.q, *sim.efforts()])
        runs[method] = np.array(rows)
    difference = np.max(np.abs(runs["ida"] - runs["cvode-bdf"]), axis=0)
    assert np.all(difference <= [1e-10, 1e-10, 1e-7]), difference


def test_ida_agrees_with_cvode_and_the_esdirk_on_the_stage():
    """stage_planar_3dof with 3.x moved 1 mm in 20 ms and held to 30 ms (3.y and 4.phi free,
    its 3.6 kHz mode excited) at rtol 1e-9: IDA's DOFs within 1e-9 m or rad of CVODE BDF's
    and the ESDIRK's at 6 times (measured 2.0e-10), the effort (5 N over the move) within
    5e-5 N (measured 7.8e-6: M_kf qddot_f of the stiff mode, as against the numpy
    reference in tests/test_prescribed_motion.py)."""
    model = build_model(with_motion("stage_planar_3dof", "3", "x", value=0.001))
    runs = {}
    for method in ("ida", "cvode-bdf", "esdirk"):
        sim = Simulator(model, method=method, rtol=1e-9, motion_duration=0.02)
        rows = []
        for t in np.linspace(0.005, 0.03, 6):
            sim.advance_to(t)
            rows.append([*sim.q, *sim.efforts()])
        runs[method] = np.array(rows)
    for other in ("cvode-bdf", "esdirk"):
        difference = np.max(np.abs(runs["ida"] - runs[other]), axis=0)
        assert np.all(difference[:-1] <= 1e-9) and difference[-1] <= 5e-5, (other, difference)
