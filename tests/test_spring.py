"""PLSPRING and SPRING, the linear spring and damper between two (possibly coincident) nodes,
against analytic solutions: a mass on the spring (m = 2 kg, k = 800 / 1800 N/m, c = 4 / 6 N s/m
along x / y, so w = 20 / 30 rad/s and zeta = c / (2 sqrt(k m)) = 0.05 / 0.05), its static
deflection F / k and m g / k, its natural frequencies sqrt(k / m), the damping ratio from the
state space and a free decay simulated by the compiled engine; and the numpy functions and the
compiled kernel against the plain formulas of the module docstring. The derivatives against
finite differences: tests/test_elements.py (parametrised over the registry).
"""

import numpy as np
import pytest

from flexure.core import (
    SceneError,
    build_model,
    natural_frequencies,
    simulate,
    state_space,
    static_equilibrium,
)
from flexure.core.elements import plspring, spring

MASS = 2.0  # kg
K = {"x": 800.0, "y": 1800.0, "z": 3200.0}  # N/m
C = {"x": 4.0, "y": 6.0, "z": 8.0}  # N s/m
OMEGA = {a: np.sqrt(K[a] / MASS) for a in K}  # 20, 30, 40 rad/s
ZETA = {a: C[a] / (2.0 * np.sqrt(K[a] * MASS)) for a in K}  # 0.05 each


def scene(dimension=2, *, offset=0.0, force=None, gravity=None, released=None):
    """A fixed node "g" and a node "m" of MASS kg on a spring from g to m, the two nodes
    coincident (offset 0) or `offset` m apart along x; an input F and an output x on m.x."""
    axes = "xyz"[:dimension]
    kind = "PLSPRING" if dimension == 2 else "SPRING"
    node = {"position": [offset] + [0.0] * (dimension - 1), "mass": MASS}
    if force is not None:
        node["force"] = list(force)
    data = {
        "scene": {"name": "spring", "dimension": dimension},
        "sections": {"soft": {**{f"k{a}": K[a] for a in axes}, **{f"c{a}": C[a] for a in axes}}},
        "nodes": {"g": {"position": [0.0] * dimension, "fixed": list(axes)}, "m": node},
        "elements": {"s": {"type": kind, "nodes": ["g", "m"], "section": "soft",
                           "released": released or [f"e{i + 1}" for i in range(dimension)]}},
        "inputs": {"F": {"node": "m", "coordinate": "x"}},
        "outputs": {"x": {"node": "m", "coordinate": "x"}},
    }
    if gravity is not None:
        data["scene"]["gravity"] = list(gravity)
    return data


@pytest.mark.parametrize("offset", [0.0, 0.1], ids=["coincident", "apart"])
def test_static_deflection_is_force_over_stiffness(offset):
    """F = [3, -5] N and gravity -9.81 m/s^2 along y: x = 3 / kx, y = -(5 + m g) / ky (m); the
    spring is linear, so Newton lands on it to round-off."""
    model = build_model(scene(offset=offset, force=[3.0, -5.0], gravity=[0.0, -9.81]))
    solution = static_equilibrium(model).coordinates()
    assert solution["m.x"] == pytest.approx(offset + 3.0 / K["x"], rel=1e-12, abs=1e-15)
    assert solution["m.y"] == pytest.approx(-(5.0 + MASS * 9.81) / K["y"], rel=1e-12)


def test_spatial_static_deflection_along_each_axis():
    model = build_model(scene(3, force=[3.0, -5.0, 7.0]))
    solution = static_equilibrium(model).coordinates()
    for axis, force in zip("xyz", (3.0, -5.0, 7.0), strict=True):
        assert solution[f"m.{axis}"] == pytest.approx(force / K[axis], rel=1e-12)


@pytest.mark.parametrize("dimension", [2, 3])
def test_natural_frequencies_are_sqrt_k_over_m(dimension):
    expected = sorted(OMEGA[a] / (2.0 * np.pi) for a in "xyz"[:dimension])
    modes = natural_frequencies(build_model(scene(dimension)))
    np.testing.assert_allclose(modes.frequencies_hz, expected, rtol=1e-12)


def test_damping_ratio_from_the_state_space():
    """The poles -zeta w +- i w sqrt(1 - zeta^2) of both axes."""
    poles = np.linalg.eigvals(state_space(build_model(scene())).A)
    upper = sorted(poles[poles.imag > 0], key=lambda p: p.imag)
    for pole, axis in zip(upper, "xy", strict=True):
        assert abs(pole) == pytest.approx(OMEGA[axis], rel=1e-12)
        assert -pole.real / abs(pole) == pytest.approx(ZETA[axis], rel=1e-12)


def test_free_decay_simulated_matches_the_damped_oscillator():
    """From rest at x = 0 with xdot = 0.1 m/s: x(t) = v0 / wd exp(-zeta w t) sin(wd t), on the
    compiled engine (CVODE at rtol 1e-10); to 1e-7 of the amplitude v0 / w = 5 mm over one
    second (eight periods, decayed to 1/e^1)."""
    model = build_model(scene())
    assert [model.coordinate_names[i] for i in model.dof_coordinates] == ["m.x", "m.y"]
    times = np.linspace(0.0, 1.0, 201)
    v0 = 0.1
    result = simulate(model, 1.0, qdot0=[v0, 0.0], rtol=1e-10, output_times=times)
    w, zeta = OMEGA["x"], ZETA["x"]
    wd = w * np.sqrt(1.0 - zeta**2)
    exact = v0 / wd * np.exp(-zeta * w * times) * np.sin(wd * times)
    np.testing.assert_allclose(result.outputs["x"], exact, rtol=0, atol=1e-7 * v0 / w)
    np.testing.assert_allclose(result.q[:, 1], 0.0, atol=1e-15)


def test_a_rigid_deformation_joins_the_nodes_along_its_axis():
    """e1 zero (rigid) and e2 released: the node cannot move along x under a 3 N push; the
    constraint carries it (the stress resultant of e1 is the reaction, 3 N)."""
    model = build_model(scene(force=[3.0, -5.0], released=["e2"]))
    assert model.dof_count()["ndof"] == 1
    solution = static_equilibrium(model)
    assert solution.coordinates()["m.x"] == pytest.approx(0.0, abs=1e-15)
    assert solution.coordinates()["m.y"] == pytest.approx(-5.0 / K["y"], rel=1e-12)


def test_a_released_deformation_needs_its_stiffness():
    data = scene()
    del data["sections"]["soft"]["ky"]
    with pytest.raises(SceneError) as error:
        build_model(data, source="s.toml")
    assert str(error.value) == ("s.toml: elements.s.released: released deformation 'e2' needs a "
                                "stiffness: section 'soft' has no ky > 0")


def plain_deformations(x, x0):
    """The module docstring's formulas, element by element: e = (r^q - r^p) - (r^q_0 - r^p_0),
    De = [-I, I], D2e = 0."""
    n, m = x.shape
    d = m // 2
    e, De = np.empty((n, d)), np.empty((n, d, m))
    for i in range(n):
        for a in range(d):
            e[i, a] = (x[i, d + a] - x[i, a]) - (x0[i, d + a] - x0[i, a])
            De[i, a] = [(-1.0 if j == a else 1.0 if j == d + a else 0.0) for j in range(m)]
    return e, De, np.zeros((n, d, m, m))


@pytest.mark.parametrize("kind", [plspring, spring], ids=["PLSPRING", "SPRING"])
@pytest.mark.parametrize("order", [0, 1, 2])
def test_numpy_functions_and_compiled_kernel_match_the_plain_formulas(kind, order):
    """Coincident and distinct nodes; the kernel fills every entry up to its order (NaN
    beyond it stays), equal to the plain formulas to round-off (1e-15 m on 0.1 m)."""
    rng = np.random.default_rng(11)
    count, d = 6, kind.dimension
    x0 = rng.uniform(-0.1, 0.1, (count, 2 * d))
    x0[:3, d:] = x0[:3, :d]  # three springs between coincident nodes
    x = x0 + rng.normal(scale=0.02, size=x0.shape)
    ref = kind.reference(x0)
    expected = plain_deformations(x, x0)
    computed = kind.deformations(x, ref, order)
    packed = kind.pack_reference(ref)
    assert packed.shape == (count, kind.REFERENCE_WIDTH)
    for got, want in zip(computed, expected, strict=False):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    for i in range(count):
        arrays = [np.full(shape, np.nan) for shape in ((d,), (d, 2 * d), (d, 2 * d, 2 * d))]
        kind.deformations_kernel(x[i], packed[i], order, *arrays)
        for k, (got, want) in enumerate(zip(arrays, expected, strict=True)):
            if k <= order:
                np.testing.assert_allclose(got, want[i], rtol=0, atol=1e-15)
            else:
                assert np.all(np.isnan(got))


def test_stiffness_damping_and_mass_of_the_section():
    ref = spring.reference(np.zeros((2, 6)))
    props = {name: np.array([1.0, 2.0]) * (i + 1) for i, name in enumerate(spring.properties)}
    np.testing.assert_array_equal(spring.stiffness(ref, props)[1], np.diag([2.0, 4.0, 6.0]))
    np.testing.assert_array_equal(spring.damping(ref, props)[1], np.diag([8.0, 10.0, 12.0]))
    np.testing.assert_array_equal(spring.inertia_matrix(ref, props), np.zeros((2, 6, 6)))
