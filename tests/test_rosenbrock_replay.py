"""The W-methods of examples.benchmarks.rosenbrock_replay on small problems with known answers:
their orders on a damped oscillator's closed form with the exact Jacobian and, as W-methods,
with a wrong one on a nonlinear problem; their embedded estimates' order; their stiff
damping."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from examples.benchmarks.rosenbrock_replay import METHODS, w_step

ORDERS = {"ros2": 2, "ros34pw2": 3}


def integrate(method, f, jacobian, y0, T, N):
    """y(T) by N equal steps, W = I - hg jacobian(y) at each step's start (dense)."""
    tableau = METHODS[method][0]
    y = np.array(y0, float)
    identity = np.eye(y.size)
    for _ in range(N):
        J = jacobian(y)

        def solve(v, hg, J=J):
            return np.linalg.solve(identity - hg * J, v)
        y = w_step(tableau, y, T / N, f, solve)[0]
    return y


def observed_orders(errors):
    errors = np.asarray(errors)
    return np.log2(errors[:-1] / errors[1:])


OMEGA, ZETA = 3.0, 0.1  # rad/s; x'' + 2 zeta omega x' + omega^2 x = 0, x(0) = 1, x'(0) = 0
A_OSC = np.array([[0.0, 1.0], [-OMEGA ** 2, -2 * ZETA * OMEGA]])


def oscillator(t):
    """[x, x'] of the damped oscillator at t (s), in closed form."""
    wd = OMEGA * np.sqrt(1 - ZETA ** 2)
    s = ZETA * OMEGA
    x = np.exp(-s * t) * (np.cos(wd * t) + s / wd * np.sin(wd * t))
    v = -np.exp(-s * t) * (OMEGA ** 2 / wd) * np.sin(wd * t)
    return np.array([x, v])


@pytest.mark.parametrize("method", sorted(ORDERS))
def test_order_on_the_damped_oscillator(method):
    exact = oscillator(1.0)
    errors = [np.max(np.abs(integrate(method, lambda y: A_OSC @ y, lambda y: A_OSC,
                                      [1.0, 0.0], 1.0, N) - exact)) for N in (80, 160, 320)]
    assert np.all(np.abs(observed_orders(errors) - ORDERS[method]) < 0.12)


def van_der_pol(y):
    return np.array([y[1], (1 - y[0] ** 2) * y[1] - y[0]])


def van_der_pol_jacobian(y):
    return np.array([[0.0, 1.0], [-2 * y[0] * y[1] - 1, 1 - y[0] ** 2]])


@pytest.mark.parametrize("method", sorted(ORDERS))
@pytest.mark.parametrize("jacobian", ["exact", "frozen", "zero"])
def test_order_as_a_w_method(method, jacobian):
    """The order holds with any W: J at each step, J of the start, or none."""
    y0 = np.array([2.0, 0.0])
    J = {"exact": van_der_pol_jacobian, "frozen": lambda y: van_der_pol_jacobian(y0),
         "zero": lambda y: np.zeros((2, 2))}[jacobian]
    reference = solve_ivp(lambda t, y: van_der_pol(y), (0.0, 1.0), y0, method="DOP853",
                          rtol=1e-13, atol=1e-13).y[:, -1]
    errors = [np.max(np.abs(integrate(method, van_der_pol, J, y0, 1.0, N) - reference))
              for N in (80, 160, 320)]
    assert np.all(np.abs(observed_orders(errors) - ORDERS[method]) < 0.2)


@pytest.mark.parametrize("method", sorted(ORDERS))
def test_embedded_estimate_order(method):
    """One step's estimate falls as h^(p_hat + 1), p_hat the embedded order (1 and 2)."""
    tableau, p_hat = METHODS[method]
    y0 = np.array([2.0, 0.0])
    J = van_der_pol_jacobian(y0)
    estimates = []
    for h in (0.01, 0.005, 0.0025):
        err = w_step(tableau, y0, h, van_der_pol,
                     lambda v, hg: np.linalg.solve(np.eye(2) - hg * J, v))[1]
        estimates.append(np.max(np.abs(err)))
    assert np.all(np.abs(observed_orders(estimates) - (p_hat + 1)) < 0.15)


@pytest.mark.parametrize("method", sorted(ORDERS))
def test_stiff_modes_damped_in_one_step(method):
    """L-stability: y' = lambda y with h lambda = -1e8 leaves under 1e-6 of y."""
    lam = -1e8
    y_new = w_step(METHODS[method][0], np.array([1.0]), 1.0, lambda y: lam * y,
                   lambda v, hg: v / (1 - hg * lam))[0]
    assert abs(y_new[0]) < 1e-6
