"""Motion profiles, feedback design and feedforward, against analytic and independent results."""

import warnings

import control
import numpy as np
import pytest
from scipy.integrate import quad

from flexure.controllers import (
    ControlDesignError,
    DiscreteController,
    ProfileError,
    StableInverse,
    ThirdOrderProfile,
    design_feedback,
    low_frequency_model,
)
from flexure.controllers.feedforward import forces
from flexure.core import linearize, load_scene, natural_frequencies

warnings.filterwarnings("ignore", module="scipy.signal")


@pytest.fixture(scope="module")
def stage3():
    return load_scene("stage_planar_3dof")


# -- profiles -------------------------------------------------------------------------------


def test_profile_peaks_match_the_closed_form():
    S, T = 1e-3, 1.0
    p = ThirdOrderProfile(S, T)
    # t_j = t_a = T/8, t_v = T/4: v = S / (2 t_j + t_a + t_v), a = v / (t_j + t_a), J = a / t_j
    v = S / (5 * T / 8)
    assert p.peak_velocity == pytest.approx(v, rel=1e-12)
    assert p.peak_acceleration == pytest.approx(v / (T / 4), rel=1e-12)
    assert p.peak_jerk == pytest.approx(v / (T / 4) / (T / 8), rel=1e-12)
    pos, vel, acc, jerk = p.evaluate([-0.1, 0.0, T / 2, T, T + 0.3])
    assert pos == pytest.approx([0, 0, S / 2, S, S], abs=1e-18)
    assert vel == pytest.approx([0, 0, v, 0, 0], abs=1e-18)
    assert acc == pytest.approx([0, 0, 0, 0, 0], abs=1e-15)


@pytest.mark.parametrize("timing", [{}, {"jerk_time": 0.05, "acceleration_time": 0.2},
                                    {"jerk_time": 0.25, "acceleration_time": 0.0}])
def test_profile_derivatives_are_consistent(timing):
    p = ThirdOrderProfile(2e-3, 1.0, start=0.1, **timing)
    t = np.linspace(0.0, 1.2, 2401) + 1.234567e-5  # off the knots (jerk jumps there)
    pos, vel, acc, jerk = p.evaluate(t)
    h = 1e-6
    for f, df in ((0, vel), (1, acc)):
        numeric = (p.evaluate(t + h)[f] - p.evaluate(t - h)[f]) / (2 * h)
        assert numeric == pytest.approx(df, abs=1e-6 * np.max(np.abs(df)))
    # velocity and acceleration are continuous (no jumps larger than one sample of slope)
    assert np.max(np.abs(np.diff(acc))) <= p.peak_jerk * (t[1] - t[0]) * 1.0001
    assert np.max(np.abs(jerk)) == pytest.approx(p.peak_jerk)
    assert p.end == pytest.approx(1.1)


def test_interval_average_is_the_mean_over_the_interval():
    p = ThirdOrderProfile(1e-3, 1.0)
    t0 = np.array([0.0, 0.1, 0.12, 0.3, 0.99])
    t1 = t0 + 0.013  # some intervals straddle a knot (0.125)
    pos, vel, acc = p.interval_average(t0, t1)
    for i in range(t0.size):
        for k, mean in enumerate((pos, vel, acc)):
            exact = quad(lambda t, k=k: p.evaluate(t)[k], t0[i], t1[i], points=[0.125],
                         epsabs=1e-16)[0] / 0.013
            assert mean[i] == pytest.approx(exact, rel=1e-7, abs=1e-14)


def test_profile_sampling_and_errors():
    t, pos, *_ = ThirdOrderProfile(1e-3, 1.0).sample(1000.0)
    assert t.size == 1001 and t[-1] == pytest.approx(1.0) and pos[-1] == pytest.approx(1e-3)
    with pytest.raises(ProfileError, match="4 jerk_time"):
        ThirdOrderProfile(1e-3, 1.0, jerk_time=0.3)
    with pytest.raises(ProfileError, match="duration"):
        ThirdOrderProfile(1e-3, 0.0)
    with pytest.raises(ProfileError, match="sample rate"):
        ThirdOrderProfile(1e-3, 1.0).sample(-1.0)


# -- feedback -------------------------------------------------------------------------------


def _loop_response(design, model, omega):
    """L(e^(j w Ts)) computed here from the matrices: plant ZOH, one delay, controller."""
    Ts = 1 / design.sample_rate_hz
    sys = control.ss(control.c2d(_siso_plant(model), Ts, method="zoh"))
    z = np.exp(1j * omega * Ts)
    c = design.controller
    out = []
    for zk in z:
        P = (sys.C @ np.linalg.solve(zk * np.eye(sys.nstates) - sys.A, sys.B) + sys.D)[0, 0]
        C = (c.C @ np.linalg.solve(zk * np.eye(c.nstates) - c.A, c.B) + c.D)[0, 0]
        out.append(P * C / zk)
    return np.array(out)


def _siso_plant(model):
    from flexure.core import state_space

    return state_space(model)["x", "F"]


@pytest.mark.parametrize("name", ["stage", "stage3"])
def test_design_meets_the_crossover_with_margins(name, request):
    model = request.getfixturevalue(name)
    d = design_feedback(model, crossover=300.0, fs=4000.0)
    L = _loop_response(d, model, np.array([300.0]))
    assert abs(L[0]) == pytest.approx(1.0, rel=1e-9)
    # phase margin from the independent evaluation at the cross-over
    assert 180 + np.degrees(np.angle(L[0])) == pytest.approx(d.phase_margin_deg, abs=0.05)
    # modulus margin: min |1 + L| on a fine grid up to Nyquist
    omega = np.geomspace(1.0, np.pi * 4000 * 0.9999, 20000)
    assert np.min(np.abs(1 + _loop_response(d, model, omega))) == pytest.approx(
        d.modulus_margin, rel=2e-3)
    assert d.phase_margin_deg > 30 and d.gain_margin > 3 and d.modulus_margin > 0.5
    assert d.spectral_radius < 1


def test_design_refuses_an_unstable_loop(stage):
    with pytest.raises(ControlDesignError, match="unstable"):
        design_feedback(stage, crossover=300.0, fs=600.0)
    with pytest.raises(ControlDesignError, match="Nyquist"):
        design_feedback(stage, crossover=5000.0, fs=1000.0)
    with pytest.raises(ControlDesignError, match="sample rate"):
        design_feedback(stage, fs=0.0)


def test_discrete_controller_steps_like_python_control(stage):
    d = design_feedback(stage)
    c = DiscreteController(d.controller)
    e = np.sin(np.arange(200) / 7.0) * 1e-6
    u = np.array([c.step([ek])[0] for ek in e])
    reference = control.forced_response(d.controller, np.arange(200) / 4000.0, e).outputs
    assert u == pytest.approx(reference, rel=1e-9, abs=1e-15)
    again = DiscreteController.from_dict(c.to_dict())
    assert np.array_equal(again.A, c.A) and np.array_equal(again.D, c.D)


# -- feedforward ----------------------------------------------------------------------------


def test_low_frequency_model_of_one_dof_is_its_linear_model(stage):
    lin = linearize(stage)
    lf = low_frequency_model(stage, linear_model=lin)
    assert lf.mass[0, 0] == pytest.approx(lin.M0[0, 0], rel=1e-12)
    assert lf.damping[0, 0] == pytest.approx(lin.C0[0, 0], rel=1e-12)
    assert lf.stiffness[0, 0] == pytest.approx(lin.K[0, 0], rel=1e-12)


def test_low_frequency_model_of_three_dofs_is_its_first_mode(stage3):
    lf = low_frequency_model(stage3)
    modes = natural_frequencies(stage3)
    phi_x = modes.coordinate_shapes[stage3.coordinate_index("3.x"), 0]
    assert lf.mass[0, 0] == pytest.approx(1 / phi_x**2, rel=1e-12)
    w = 2 * np.pi * modes.frequencies_hz[0]
    assert np.sqrt(lf.stiffness[0, 0] / lf.mass[0, 0]) == pytest.approx(w, rel=1e-12)
    # the first mode is the x motion of the stage: close to the 1-DOF model
    assert lf.mass[0, 0] == pytest.approx(0.21125, rel=1e-3)
    assert lf.stiffness[0, 0] == pytest.approx(945.0, rel=1e-3)


def test_held_feedforward_has_no_half_sample_lag(stage):
    """Open loop on the exact ZOH model: interval means track far better than point values."""
    lf = low_frequency_model(stage)
    fs = 1000.0
    p = ThirdOrderProfile(1e-3, 0.2)
    k = np.arange(301)
    t = k / fs
    P = control.c2d(_siso_plant(stage), 1 / fs, method="zoh")
    means = forces(lf, p, t, t + 1 / fs)[:, 0]
    points = lf.force(*(x[:, None] for x in (p.evaluate(t)[0], p.evaluate(t)[1],
                                              p.evaluate(t)[2])))[:, 0]
    err_means = np.max(np.abs(control.forced_response(P, t, means).outputs - p.position(t)))
    err_points = np.max(np.abs(control.forced_response(P, t, points).outputs - p.position(t)))
    assert err_means < 1e-4 * 1e-3
    assert err_points > 20 * err_means


@pytest.mark.parametrize("zeros, tolerance", [
    ("none", 1e-4),  # ZOH sampling zero near -1: mirrored (a small gain error)
    ("nmp", 1e-5),  # a non-minimum-phase zero at 50 rad/s: exact backwards inversion
    ("light", 0.1),  # lightly damped zeros at 100 rad/s: ZPETC, approximate
])
def test_stable_inverse_tracks_with_bounded_input(zeros, tolerance):
    s = control.tf("s")
    base = 1 / (0.2 * s**2 + 0.04 * s + 945)
    numerator = {"none": 1, "nmp": 1 - s / 50, "light": s**2 / 1e4 + 2e-6 * s + 1}[zeros]
    Ts = 1e-3
    P = control.c2d(numerator * base, Ts, method="zoh")
    p = ThirdOrderProfile(1e-3, 0.2, start=0.2)
    t = np.arange(700) * Ts
    r = p.position(t)
    inverse = StableInverse(P)
    u = inverse.apply(r)
    y = control.forced_response(P, t, u).outputs
    assert np.max(np.abs(y - r)) < tolerance * 1e-3
    assert np.all(np.isfinite(u)) and np.max(np.abs(u)) < 2.0  # N; 945 N/m x 1 mm ~ 1 N
    if zeros == "nmp":
        assert inverse.zeros_anticausal.size == 1
    if zeros == "light":
        assert inverse.zeros_mirrored.size == 2


def test_feedforward_holds_a_loaded_scene_where_it_starts():
    """stage_spatial_19dof carries a constant 1 N on 3.x: the feedforward at rest cancels it."""
    model = load_scene("stage_spatial_19dof")
    lf = low_frequency_model(model)
    assert lf.equilibrium[0] == pytest.approx(1.0 / lf.stiffness[0, 0], rel=2e-3)
    p = ThirdOrderProfile(1e-3, 1.0)
    u = forces(lf, p, np.array([0.0]), np.array([1e-3]), offsets=np.array([0.0]))
    assert u[0, 0] == pytest.approx(-1.0, rel=2e-3)
    again = type(lf).from_dict(lf.to_dict())
    assert np.array_equal(again.equilibrium, lf.equilibrium)


def test_a_second_loop_on_the_stiff_vertical_axis_is_refused():
    """Two loops (3.x and 3.y): the 300 rad/s PID on the 3.8e7 N/m vertical spring, whose
    2129 Hz mode folds back below the 2 kHz Nyquist frequency, would be unstable."""
    import tomllib

    from flexure.core import build_model, scene_path

    data = tomllib.loads(scene_path("stage_planar_3dof").read_text())
    data["inputs"]["Fy"] = {"node": "3", "coordinate": "y"}
    model = build_model(data, source="two-input stage")
    with pytest.raises(ControlDesignError, match="unstable: pole z"):
        design_feedback(model, crossover=300.0, fs=4000.0)


def test_an_input_without_a_colocated_output_is_refused():
    import tomllib

    from flexure.core import build_model, scene_path

    data = tomllib.loads(scene_path("stage_planar_1dof").read_text())
    del data["outputs"]["x"]
    model = build_model(data, source="no-x stage")
    with pytest.raises(ControlDesignError, match="no position output"):
        design_feedback(model)
