"""The loop for any mechanism: one's own controller (a python-control system or
callables) and one's own reference (samples or r(t)) in place of the designed PID-like
feedback and the third-order profile.

Runs are short (0.1 s moves on stage_planar_1dof, tens of milliseconds each)."""

import control
import numpy as np
import pytest

from flexure.controllers import LoopError, build_loop, design_feedback, run_loop
from flexure.controllers.profiles import ThirdOrderProfile
from flexure.controllers.user_controller import discrete_system
from flexure.controllers.user_reference import interval_means

FS = 4000.0
SHORT = {"stroke": 1e-3, "duration": 0.1, "settle": 0.02}


@pytest.fixture(scope="module")
def designed(stage):
    """The built-in loop's run and its design."""
    _, design = build_loop(stage, **SHORT)
    return run_loop(stage, **SHORT), design


def as_system(design):
    """The designed discrete controller as a python-control StateSpace of one's own."""
    c = design.controller
    return control.ss(c.A, c.B, c.C, c.D, 1.0 / FS)


class StateSpaceCallable:
    """The designed controller written as a Python callable f(k, e) -> u, with a reset."""

    def __init__(self, system):
        self.A, self.B, self.C, self.D = (np.asarray(m, float) for m in
                                          (system.A, system.B, system.C, system.D))
        self.resets = 0
        self.reset()

    def reset(self):
        self.x = np.zeros(self.A.shape[0])
        self.resets += 1

    def __call__(self, k, e):
        u = float((self.C @ self.x)[0] + self.D[0, 0] * e)
        self.x = self.A @ self.x + self.B[:, 0] * e
        return u


@pytest.mark.parametrize("form", ["state space", "transfer function", "list of SISO"])
def test_the_designed_controller_given_as_a_system_reproduces_the_built_in_loop(
        stage, designed, form):
    """Given back as one's own system, the designed controller gives the designed loop's
    samples bit for bit (state space; compiled alike), its margins and a measured cross-over
    of 300 rad/s; as a transfer function another realisation of the same C(z) (round-off)."""
    reference, design = designed
    system = as_system(design)
    given = {"state space": system, "transfer function": control.tf(system),
             "list of SISO": [system]}[form]
    result = run_loop(stage, controller=given, **SHORT)
    s = result.summary()
    assert s["controller_kind"] == "state space" and s["robustness_checked"]
    assert s["crossover_rad_s"] == pytest.approx(300.0, rel=1e-4)
    for key in ("phase_margin_deg", "gain_margin", "modulus_margin"):
        assert s[key] == pytest.approx(reference.summary()[key], rel=1e-6)
    if form == "transfer function":
        assert np.max(np.abs(result.position - reference.position)) < 1e-9 * SHORT["stroke"]
    else:
        assert np.array_equal(result.position, reference.position)
        assert np.array_equal(result.force, reference.force)


def test_a_controller_of_ones_own_reports_its_own_crossover_and_margins(stage):
    """The design for 150 rad/s given as one's own system: the loop reports 150 rad/s and
    that design's margins (38.5 degrees; docs/closed-loop.md), not the 300 rad/s hint."""
    slow = design_feedback(stage, crossover=150.0, fs=FS)
    result = run_loop(stage, controller=as_system(slow), **SHORT)
    s = result.summary()
    assert s["crossover_rad_s"] == pytest.approx(150.0, rel=1e-3)
    assert s["phase_margin_deg"] == pytest.approx(slow.phase_margin_deg, abs=0.01)
    assert s["phase_margin_deg"] == pytest.approx(38.5, abs=0.05)
    assert s["passed"]


@pytest.mark.parametrize("plant", ["inprocess", "fmu"])
def test_a_callable_controller_tracks_as_the_designed_one(stage, designed, plant, tmp_path):
    """The designed controller written as a callable (a Python loop per sample) gives the
    compiled loop's positions to round-off; its reset is called before the run; it has no
    margins, and the summary says its robustness was not checked."""
    reference, design = designed
    function = StateSpaceCallable(as_system(design))
    result = run_loop(stage, controller=[function], plant=plant, workdir=tmp_path, **SHORT)
    assert function.resets == 2  # at construction and before the run
    assert np.max(np.abs(result.position - reference.position)) < 1e-12 * SHORT["stroke"]
    assert np.max(np.abs(result.force - reference.force)) < 1e-9 * np.max(
        np.abs(reference.force))
    s = result.summary()
    assert s["controller_kind"] == "callable" and s["robustness_checked"] is False
    assert np.isnan(s["phase_margin_deg"]) and np.isnan(s["crossover_rad_s"])
    from flexure.controllers.cli import render

    assert "robustness" in render(s) and "not checked" in render(s)


class DiscretePD:
    """u = k_p e + k_d (e_k - e_k-1) fs: a callable keeping its last error, reset per run."""

    def __init__(self, kp, kd):
        self.kp, self.kd, self.last = kp, kd, 0.0

    def reset(self):
        self.last = 0.0

    def __call__(self, k, e):
        u = self.kp * e + self.kd * (e - self.last) * FS
        self.last = e
        return u


def test_a_pd_callable_alone_leaves_the_static_error_of_two_springs(stage):
    """A PD of one's own and no feedforward: at rest the stage settles where k_p e = k x,
    a final error of stroke k / (k + k_p): with the 945 N/m spring and k_p = 9450 N/m,
    1/11 of the stroke (damping ratio 0.7 at 222 rad/s, settled after 0.3 s)."""
    kp, stiffness = 9450.0, 945.0  # N/m; the stage's spring (docs/closed-loop.md)
    kd = 2 * 0.7 * 0.2112 * np.sqrt((stiffness + kp) / 0.2112)  # N s/m
    pd = DiscretePD(kp, kd)
    pd.last = 1.0  # a stale state: the run resets it
    result = run_loop(stage, controller=pd, feedforward=False, stroke=1e-3, duration=0.05,
                      settle=0.3)
    assert result.error[-1, 0] == pytest.approx(1e-3 * stiffness / (stiffness + kp), rel=1e-3)
    assert not result.summary()["passed"]


def test_a_mimo_transfer_function_is_realised_entry_by_entry():
    """python-control converts a MIMO transfer function only with slycot: ours, entry by
    entry, has the same frequency response (to 1e-12)."""
    dt = 1.0 / FS
    G = control.tf([[[1.0, 0.5], [0.1]], [[0.2], [1.0, 0.3]]],
                   [[[1.0, -0.9], [1.0, -0.5]], [[1.0, -0.4], [1.0, -0.8]]], dt)
    system = discrete_system(G, fs=FS, names=["F1", "F2"])
    assert isinstance(system, control.StateSpace) and system.dt == dt
    for w in (1.0, 300.0, 5000.0):
        z = np.exp(1j * w * dt)
        np.testing.assert_allclose(system(z), G(z), rtol=1e-12)


def test_a_controller_of_ones_own_that_destabilises_the_loop_is_refused(stage, designed):
    """Ten times the designed gain (gain margin 4.17): refused, naming the pole."""
    with pytest.raises(LoopError, match=r"unstable: pole z = .*\|z\| = 1\.\d+"):
        run_loop(stage, controller=10.0 * as_system(designed[1]), **SHORT)


@pytest.mark.parametrize("make, message", [
    (lambda c: control.tf([1.0], [1.0, 1.0]), r"continuous \(dt = 0\); expected a discrete "
                                              r"one with dt = 1/fs = 0\.00025 s"),
    (lambda c: control.ss(c.A, c.B, c.C, c.D, 1e-3), r"expected dt = 1/fs = 0\.00025 s, got "
                                                     r"dt = 0\.001 s"),
    (lambda c: control.ss(c.A, c.B, c.C, c.D, True), r"unspecified sample time"),
    (lambda c: control.append(c, c), r"expected a 1 x 1 system .* got 2 x 2"),
    (lambda c: [c, c], r"one per loop \(F\): expected 1, got 2"),
    (lambda c: [c, lambda k, e: 0.0], "not a mix"),
    (lambda c: "PID", "must be a discrete python-control system .* got str"),
    (lambda c: control.tf([1.0, 2.0, 3.0], [1.0, -0.5], 1 / FS), "non-proper"),
])
def test_a_wrong_system_gets_a_clear_loop_error(stage, designed, make, message):
    system = as_system(designed[1])
    with pytest.raises(LoopError, match=message):
        run_loop(stage, controller=make(system), **SHORT)


def test_other_misuses_of_a_controller_of_ones_own(stage, designed, tmp_path):
    function = StateSpaceCallable(as_system(designed[1]))
    with pytest.raises(LoopError, match=r"returned nan at sample 0; expected a finite number"):
        run_loop(stage, controller=lambda k, e: float("nan"), **SHORT)
    with pytest.raises(LoopError, match="cannot be serialised into the controller FMU"):
        run_loop(stage, controller=function, plant="libcosim", workdir=tmp_path, **SHORT)
    assert not list(tmp_path.iterdir())  # refused before any FMU was built
    with pytest.raises(LoopError, match="not both"):
        build_loop(stage, controller=function, design=designed[1], **SHORT)
    with pytest.raises(LoopError, match="lead_ratio: design options of the built-in"):
        build_loop(stage, controller=function, lead_ratio=4.0, **SHORT)
    with pytest.raises(LoopError, match="crossover, where the margins' frequency grid"):
        build_loop(stage, controller=function, crossover=-1.0, **SHORT)


# -- references of one's own ------------------------------------------------------------------

def profile_samples(offset=0.0):
    """The 0.1 s, 1 mm profile and 0.02 s of rest at 4 kHz, point by point (481 samples)."""
    profile = ThirdOrderProfile(1e-3, 0.1)
    return np.array([offset + float(profile.position(k / FS)) for k in range(481)]), profile


def test_the_profile_given_as_samples_or_as_r_of_t_tracks_as_the_built_in_one(stage, designed):
    """The built-in profile given as samples: the same reference, the spline's feedforward
    within 3e-12 of the exact interval means (measured 2.5e-12), the same positions to
    1e-15 of the stroke; given as r(t), the very same run as the samples."""
    reference, _ = designed
    samples, profile = profile_samples()
    given = run_loop(stage, reference=samples)
    assert given.summary()["reference_kind"] == "samples"
    assert given.t.size == 481 and given.summary()["duration"] == pytest.approx(0.12)
    np.testing.assert_allclose(given.reference, reference.reference, rtol=0, atol=1e-18)
    assert np.max(np.abs(given.feedforward - reference.feedforward)) < 3e-12 * np.max(
        np.abs(reference.feedforward))
    assert np.max(np.abs(given.position - reference.position)) < 1e-15
    assert given.stroke == pytest.approx(1e-3) and given.summary()["passed"]
    function = run_loop(stage, reference=lambda t: float(profile.position(t)), **SHORT)
    assert function.summary()["reference_kind"] == "callable"
    assert np.array_equal(function.position, given.position)
    assert np.array_equal(function.force, given.force)


def test_feedforward_of_a_sampled_reference_converges_at_the_stated_orders():
    """The spline's interval means of a 20 Hz sine against the exact ones: the mean
    acceleration's error falls as h^4 inside and h^3 over the first samples (measured
    ratios 16.0 and 8.0 per halving of h from 1 to 4 kHz; 5e-9 and 7e-6 of the peak at
    4 kHz); the mean position errs by less than 1e-6 of the amplitude."""
    w = 2 * np.pi * 20.0
    inner, start = [], []
    for fs in (1000.0, 2000.0, 4000.0):
        h = 1.0 / fs
        t = np.arange(int(fs) + 2) * h
        p, v, a = interval_means(np.sin(w * t)[:, None], fs)
        t0, t1 = t, t + h
        exact_a = w * (np.cos(w * t1) - np.cos(w * t0)) / h
        exact_p = (np.cos(w * t0) - np.cos(w * t1)) / (w * h)
        body = slice(20, t.size - 60)  # the last samples hold: a kink the spline smooths
        inner.append(np.max(np.abs(a[body, 0] - exact_a[body])) / w**2)
        start.append(np.max(np.abs(a[:5, 0] - exact_a[:5])) / w**2)
        assert np.max(np.abs(p[body, 0] - exact_p[body])) < 1e-6  # of the amplitude
    assert inner[0] / inner[1] == pytest.approx(16.0, rel=0.05)
    assert inner[1] / inner[2] == pytest.approx(16.0, rel=0.05)
    assert start[0] / start[1] == pytest.approx(8.0, rel=0.05)
    assert start[1] / start[2] == pytest.approx(8.0, rel=0.05)
    assert inner[-1] < 1e-8 and start[-1] < 1e-5


def test_a_sine_reference_is_tracked_with_its_feedforward(stage):
    """0.2 mm at 5 Hz, started at rest (1 - cos): the spline's feedforward cuts the error of
    feedback alone by more than 1000 and tracks within 0.1 %."""
    def r(t):
        return 1e-4 * (1.0 - np.cos(2 * np.pi * 5.0 * t))

    with_ff = run_loop(stage, reference=r, duration=0.2, settle=0.0)
    alone = run_loop(stage, reference=r, duration=0.2, settle=0.0, feedforward=False)
    assert with_ff.stroke == pytest.approx(2e-4, rel=1e-6)
    assert with_ff.summary()["passed"]
    assert alone.max_abs_error > 1000 * with_ff.max_abs_error


@pytest.mark.parametrize("reference, message", [
    (np.zeros((10, 2)), r"expected shape \(N\+1,\) or \(N\+1, 1\) .* got \(10, 2\)"),
    (np.array([0.0]), r"got \(1, 1\)"),
    (np.array([0.0, np.nan, 1e-3]), "sample 1 is not finite"),
    (lambda t: [t, t], r"returned \[0\.0, 0\.0\] at t = 0 s; expected 1 finite position"),
    (lambda t: "up", "returned 'up'"),
    (np.zeros(20), "does not move"),
    ({"x": 1}, "must be an array of positions or a callable"),
])
def test_a_wrong_reference_gets_a_clear_loop_error(stage, reference, message):
    with pytest.raises(LoopError, match=message):
        run_loop(stage, reference=reference, **SHORT)


def test_a_reference_and_a_move_path_are_refused_together(stage):
    from flexure.controllers.move_path import MovePath

    path = MovePath(np.array([0.0, 0.5, 1.0]), np.array([[0.0], [5e-4], [1e-3]]), None,
                    "linear", {"2.x": 1e-3})
    with pytest.raises(LoopError, match="two references"):
        build_loop(stage, reference=profile_samples()[0], path=path)


def test_the_inverse_feedforward_takes_a_sampled_reference(stage):
    samples, _ = profile_samples()
    result = run_loop(stage, reference=samples, feedforward="inverse")
    assert result.summary()["feedforward_kind"] == "inverse"
    assert result.summary()["error_ratio"] < 1e-5


@pytest.mark.slow  # 2.9 s; the same controllers on the in-process plant stay in the default tier
def test_ones_own_controllers_and_a_given_design_run_on_the_linear_plant(stage, designed):
    """On plant "linear" the designed loop, the same design given back, the controller as a
    system and as a callable compute the same samples (to round-off), and their positions are
    the nonlinear loop's to 1e-5 of the stroke (measured 2.4e-6: the nonlinear plant's
    integrator at the loop's rtol 1e-5 on a 0.1 s move; the stage is nearly linear)."""
    reference, design = designed
    linear = run_loop(stage, plant="linear", **SHORT)
    runs = [run_loop(stage, plant="linear", design=design, **SHORT),
            run_loop(stage, plant="linear", controller=as_system(design), **SHORT),
            run_loop(stage, plant="linear",
                     controller=[StateSpaceCallable(as_system(design))], **SHORT)]
    for result in runs:
        assert np.max(np.abs(result.position - linear.position)) < 1e-12 * SHORT["stroke"]
    assert np.max(np.abs(linear.position - reference.position)) < 1e-5 * SHORT["stroke"]
