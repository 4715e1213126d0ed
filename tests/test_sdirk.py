"""Alexander's two-stage SDIRK ("sdirk2"), written as an ESDIRK whose first stage nothing
reads: the kernel knows it by that column, it converges at order 2 on an analytic linear
oscillator, and a sampled loop's changed input costs it no input response. (Its order
conditions, L-stability and predictor: tests/test_esdirk.py's tableau tests; the integrator
contract: tests/test_integrator_contract.py.)"""

import numpy as np
from scipy.linalg import expm

from flexure.core import Simulator, load_scene
from flexure.core.simulation import esdirk_kernels, esdirk_layout
from flexure.core.simulation.esdirk import Esdirk
from flexure.core.simulation.esdirk_method import TABLEAUS
from tests.compiled_loops import run_compiled_loop


def test_only_a_tableau_whose_first_column_is_zero_skips_its_first_stage():
    for name, tableau in TABLEAUS.items():
        A, EW, _ = tableau.arrays()
        assert esdirk_kernels.first_stage_unread(A, EW) == (name == "sdirk2"), name


def oscillator_position(t):
    """truss_1dof_x from rest under its 1 N load: x(t) - x(0) (m) of m x'' + c x' + k x = 1 N
    with k = EA / l0, c = EdA / l0 and m the bar plus a third of the truss (the scene's
    numbers), by the matrix exponential."""
    m, k, c = 0.206 + 0.1413 * 0.1 / 3, 94.5 / 0.1, 0.0036494 / 0.1
    A = np.array([[0.0, 1.0], [-k / m, -c / m]])
    return np.linalg.solve(A, (expm(A * t) - np.eye(2)) @ [0.0, 1.0 / m])[0]


def test_order_two_on_a_linear_oscillator():
    """Fixed steps h (rtol so loose that none is rejected or resized) over 0.05 s, a third of
    the oscillator's period, omega h from 0.21 to 0.026: halving h divides the error against
    the exact solution by 2^2 (within 0.2; measured 1.91, 1.96, 1.98, and 1.76 from omega h =
    0.42, before the asymptotic range). The matrix exponential agrees with CVODE at rtol 1e-12
    to 2e-11 of the motion; the errors here are 1e-5 of it and more."""
    model = load_scene("truss_1dof_x")
    exact = oscillator_position(0.05)
    errors = []
    for h in (0.05 / 16, 0.05 / 32, 0.05 / 64, 0.05 / 128):
        sim = Simulator(model)
        data = sim.data
        data.float_array("q_ref")[:] = sim.q_ref  # what Simulator.advance sets before a run
        integrator = Esdirk(data, rtol=0.5, atol=np.full(2, 1.0), max_step=h, method="sdirk2")
        integrator.restart_memory = {"initial_step": h}
        integrator.reset(0.0, np.zeros(2))
        t, y = integrator.advance(0.05)
        assert t == 0.05 and integrator.statistics()["steps"] == round(0.05 / h)
        errors.append(abs(data.float_array("q_ref")[0] - 0.1 + y[0] - exact))
    observed = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(np.abs(observed - 2.0) < 0.2), observed


def test_a_changed_input_costs_no_input_response_in_the_compiled_loop():
    """stage_planar_3dof's 1 mm move at 4 kHz, a new force at every sample: TR-BDF2 asks the
    engine for an input response at each (its explicit first stage needs f(y_n, u_new)), the
    SDIRK for none."""
    from flexure.controllers import build_loop

    model = load_scene("stage_planar_3dof")
    controller, design = build_loop(model, stroke=1e-3, duration=0.02, settle=0.005,
                                    fs=4000.0)
    responses, moved = {}, {}
    for method in ("esdirk2", "sdirk2"):
        sim = Simulator(model, method=method, rtol=1e-5)
        _, position, force = run_compiled_loop(sim, controller, design)
        assert np.count_nonzero(np.diff(force[:, 0])) > 50  # the input changed
        responses[method] = int(sim.integrator.flags[esdirk_layout.I_RESPONSES])
        moved[method] = position[-1, 0] - position[0, 0]
    assert responses["esdirk2"] > 50 and responses["sdirk2"] == 0, responses
    np.testing.assert_allclose(moved["sdirk2"], moved["esdirk2"], rtol=1e-3)
