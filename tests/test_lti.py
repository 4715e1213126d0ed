"""The plain-numpy LTI layer (controllers/lti.py) against python-control on the real designs.

Each operation the loop's design uses is computed both ways on the built-in stages' plants
and controllers: the zero-order hold and the Tustin discretisation, the realisation of a
transfer function, series and block-diagonal connections, the delays, the frequency response
at a point and the poles of the loop closed with -I. Both sides compute the same arithmetic
in another order, so they agree to round-off: the tolerances below are relative to the
largest entry of each matrix (or of each response), a few hundred ulps.
"""

import control
import numpy as np
import pytest

from flexure.controllers.feedback import (
    colocated_pairs,
    design_feedback,
    pid_lowpass,
    pid_lowpass_polynomials,
)
from flexure.controllers.lti import (
    LinearSystem,
    append,
    delay,
    series,
    transfer_function,
    tustin,
    unity_feedback_poles,
    zoh,
)
from flexure.core import load_scene, state_space, state_space_matrices

FS, CROSSOVER = 4000.0, 300.0
TS = 1.0 / FS
MATRIX_RTOL = 1e-12  # of the largest entry of the matrix compared


def assert_same_matrices(ours, theirs, rtol=MATRIX_RTOL):
    for name in "ABCD":
        a, b = np.asarray(getattr(ours, name), float), np.asarray(getattr(theirs, name), float)
        assert a.shape == b.shape, name
        scale = max(np.max(np.abs(b), initial=0.0), np.finfo(float).tiny)
        np.testing.assert_allclose(a, b, rtol=0, atol=rtol * scale, err_msg=name)


@pytest.fixture(scope="module", params=["stage_planar_1dof", "stage_planar_3dof"])
def scene(request):
    """(model, its loops' continuous plant as python-control and as numpy, the design)."""
    model = load_scene(request.param)
    pairs = colocated_pairs(model)
    outputs, inputs = [p.output_index for p in pairs], [p.input_index for p in pairs]
    theirs = control.ss(state_space(model)[outputs, inputs])
    ours = LinearSystem(*state_space_matrices(model)).subsystem(outputs, inputs)
    return model, theirs, ours, design_feedback(model, crossover=CROSSOVER, fs=FS)


def test_the_plain_matrices_are_the_state_space_of_python_control(scene):
    model = scene[0]
    assert_same_matrices(LinearSystem(*state_space_matrices(model)), state_space(model), rtol=0)


def test_the_zero_order_hold_is_control_c2d(scene):
    _, theirs, ours, _ = scene
    sampled = zoh(ours, TS)
    assert sampled.dt == TS
    # the same matrix exponential of the same augmented matrix: the same bits
    assert_same_matrices(sampled, control.c2d(theirs, TS, method="zoh"), rtol=0)


# python-control's route solves with I - (dt / 2) A of the continuous companion matrix, whose
# entries span 1 to 1e13 at a 3000 rad/s cross-over: scipy warns of its condition; ours
# substitutes the polynomials and solves nothing
@pytest.mark.filterwarnings("ignore::scipy.linalg.LinAlgWarning")
def test_the_prewarped_tustin_realisation_is_control_c2d_then_ss():
    """The PID-lowpass shape: its Tustin discretisation pre-warped at the cross-over, realised
    in the controllable canonical form, is python-control's c2d then ss, matrix by matrix."""
    for crossover in (30.0, 300.0, 3000.0):
        num, den = pid_lowpass_polynomials(crossover, lowpass_damping=0.3)
        theirs = control.ss(control.c2d(pid_lowpass(crossover, lowpass_damping=0.3), TS,
                                        method="tustin", prewarp_frequency=crossover))
        ours = transfer_function(*tustin(num, den, TS, prewarp=crossover), TS)
        assert_same_matrices(ours, theirs)
        # pre-warped: the discrete response at the cross-over is the continuous one (to
        # 1e-9: at 30 rad/s z lies 0.0075 from the integrator's pole at 1, and the solve of
        # (z I - A) loses digits as 1 / |z - 1| grows)
        z = np.exp(1j * crossover * TS)
        assert complex(ours.response(z)[0, 0]) == pytest.approx(
            np.polyval(num, 1j * crossover) / np.polyval(den, 1j * crossover), rel=1e-9)
    # without pre-warping, k = 2 / dt: control's plain Tustin
    ours = transfer_function(*tustin(num, den, TS), TS)
    assert_same_matrices(ours, control.ss(control.c2d(pid_lowpass(3000.0, lowpass_damping=0.3),
                                                      TS, method="tustin")))


def test_the_designed_controller_is_the_python_control_recipe(scene):
    """The controller the loop runs against the design done with python-control throughout
    (c2d, the gain set at the cross-over, ss, append): the same matrices and responses."""
    _, theirs, _, design = scene
    plant_d = control.c2d(theirs, TS, method="zoh")
    z = np.exp(1j * CROSSOVER * TS)
    parts = []
    for k in range(plant_d.ninputs):
        c_d = control.c2d(pid_lowpass(CROSSOVER), TS, method="tustin",
                          prewarp_frequency=CROSSOVER)
        p_kk = control.ss(plant_d.A, plant_d.B[:, [k]], plant_d.C[[k], :], plant_d.D[[k], [k]],
                          TS)
        parts.append(control.ss(c_d / abs(complex(p_kk(z)) * complex(c_d(z)))))
    expected = control.append(*parts) if len(parts) > 1 else parts[0]
    assert_same_matrices(design.feedback, expected)
    omega = np.geomspace(1.0, np.pi * FS * 0.999, 50)
    for w in omega:
        zk = np.exp(1j * w * TS)
        np.testing.assert_allclose(design.feedback.response(zk), expected(zk), rtol=1e-10)
    # the python-control views of the design
    assert isinstance(design.controller, control.StateSpace) and design.controller.dt == TS
    assert_same_matrices(design.controller, design.feedback, rtol=0)
    for shape, (num, den) in zip(design.continuous, design.shapes, strict=True):
        w = 1j * CROSSOVER
        assert complex(shape(w)) == pytest.approx(np.polyval(num, w) / np.polyval(den, w),
                                                  rel=1e-12)


def test_series_append_delay_and_the_closed_loop_poles_are_python_controls(scene):
    _, theirs, _, design = scene
    n = len(design.pairs)
    plant_d = control.c2d(theirs, TS, method="zoh")
    delays = control.ss(control.tf([1], [1, 0], TS))
    delays = control.append(*[delays] * n) if n > 1 else delays
    assert_same_matrices(delay(n, 1, TS), delays, rtol=0)
    assert_same_matrices(delay(1, 3, TS), control.ss(control.tf([1], [1, 0, 0, 0], TS)),
                         rtol=0)
    assert_same_matrices(delay(n, 0, TS), control.ss([], [], [], np.eye(n), TS), rtol=0)
    controller = design.controller
    ours = series(design.feedback, delay(n, 1, TS), LinearSystem.of(plant_d))
    theirs_loop = plant_d * delays * controller  # python-control's order: last * ... * first
    assert_same_matrices(ours, theirs_loop)
    # the first loop's gain, the others open
    first = (control.ss(plant_d.A, plant_d.B[:, [0]], plant_d.C[[0], :], 0, TS)
             * control.ss(control.tf([1], [1, 0], TS))
             * control.ss(controller.A, controller.B[:, [0]], controller.C[[0], :],
                          controller.D[[0], [0]], TS))
    assert_same_matrices(design.first_loop, first)
    # block-diagonal: the controllers side by side
    parts = [design.feedback.subsystem([k], [k]) for k in range(n)]
    if n > 1:
        assert_same_matrices(append(*parts), control.append(*[p.to_control() for p in parts]),
                             rtol=0)
    # the poles of all loops closed together, |z| < 1 near the unit circle: to round-off of 1
    expected = control.feedback(theirs_loop, np.eye(n)).poles()
    poles = unity_feedback_poles(ours)
    assert poles.size == expected.size
    for pole in expected:  # each of python-control's poles is one of ours
        assert np.min(np.abs(poles - pole)) <= 1e-9
    np.testing.assert_allclose(design.closed_loop_poles, poles, rtol=0, atol=1e-12)
    assert design.spectral_radius == pytest.approx(np.max(np.abs(expected)), abs=1e-12)


def test_the_response_at_a_point_is_python_controls(scene):
    _, theirs, ours, _ = scene
    sampled = zoh(ours, TS)
    expected = control.c2d(theirs, TS, method="zoh")
    for w in (1.0, CROSSOVER, 0.99 * np.pi * FS):
        z = np.exp(1j * w * TS)
        np.testing.assert_allclose(sampled.response(z), expected(z), rtol=1e-10)
        np.testing.assert_allclose(ours.response(1j * w), theirs(1j * w), rtol=1e-10)


def test_a_python_control_transfer_function_and_a_wrong_one_are_told():
    tf = control.tf([1.0, 2.0], [1.0, 3.0, 2.0], TS)
    system = LinearSystem.of(tf)
    assert system.dt == TS and system.states == 2
    assert_same_matrices(system, control.ss(tf), rtol=0)
    assert LinearSystem.of(control.ss(tf)).discrete
    assert not LinearSystem.of(control.ss(-1.0, 1.0, 1.0, 0.0)).discrete
    with pytest.raises(ValueError, match="improper"):
        transfer_function([1.0, 0.0, 0.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="delay_samples"):
        delay(2, -1, TS)
    with pytest.raises(ValueError, match="one sample period"):
        series(delay(1, 1, TS), delay(1, 1, 2 * TS))
