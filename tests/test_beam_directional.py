"""The BEAM's directional second derivative h_b = v^T D2e_b v (`beam_directional`) against
the contraction of the full Hessians: of the numpy reference `beam.deformations` (order 2)
and of the compiled twin `beam_kernels.deformations_kernel` (the reference's D2e is held
against differences of its De in tests/test_beam.py). The tolerance: 1e-12 of the
products' magnitude sum |v_a| |D2e_ab| |v_b| of each row (the jet and the contraction sum
the same terms in another order).

Called as plain Python (`py_func`): the kernel's helpers compile as small functions of their
own, in about a second; the compiled entry is checked through the engine
(tests/test_directional_engine.py).
"""

import numpy as np
import pytest

from flexure.core.elements import beam, beam_directional, beam_kernels, entries

COUNT = 12


def python(kernel):
    """The kernel as plain Python."""
    return getattr(kernel, "py_func", kernel)


@pytest.fixture(scope="module", params=["default_axis", "given_axis"])
def beams(request):
    rng = np.random.default_rng(20261130)
    x0, x = beam.random_coordinates(rng, COUNT)
    y_axis = None if request.param == "default_axis" else rng.normal(size=(COUNT, 3))
    ref = beam.reference(x0, y_axis, properties={"Ip_A": rng.uniform(0.01, 0.1, COUNT)})
    # velocities of three scales: the translations' and the Euler parameters' apart
    v = rng.normal(size=x.shape) * rng.choice([1e-3, 1.0, 1e3], size=x.shape)
    return x, v, ref, beam.pack_reference(ref)


def directional(x, v, packed):
    h = np.full((x.shape[0], 6), np.nan)
    for i in range(x.shape[0]):
        python(beam_directional.directional_kernel)(x[i], v[i], packed[i], h[i])
    return h


def contracted(D2e, v):
    """v^T D2e_b v and its magnitude sum |v_a| |D2e_ab| |v_b| per element and row."""
    return (np.einsum("nbac,na,nc->nb", D2e, v, v),
            np.einsum("nbac,na,nc->nb", np.abs(D2e), np.abs(v), np.abs(v)))


def test_directional_equals_the_reference_hessians_contracted(beams):
    x, v, ref, packed = beams
    _, _, D2e = beam.deformations(x, ref, order=2)
    expected, magnitude = contracted(D2e, v)
    h = directional(x, v, packed)
    assert np.all(np.isfinite(h))
    assert np.all(np.abs(h - expected) <= 1e-12 * magnitude)


@pytest.mark.slow  # the BEAM's kernel compiled for Python (5 s cold); the reference's is above
def test_directional_equals_the_kernels_hessians_contracted(beams):
    x, v, ref, packed = beams
    n = x.shape[0]
    D2e = np.empty((n, 6, 14, 14))
    e, De = np.empty((n, 6)), np.empty((n, 6, 14))
    for i in range(n):
        python(beam_kernels.deformations_kernel)(x[i], packed[i], 2, e[i], De[i], D2e[i])
    expected, magnitude = contracted(D2e, v)
    assert np.all(np.abs(directional(x, v, packed) - expected) <= 1e-12 * magnitude)


def test_beam_entry_carries_the_directional_kernel():
    """The element registry reads the entry with the directional kernel; the other elements'
    keep the plain one (`entries.ORDER_ASK` answers which)."""
    assert beam.deformations_entry is beam_directional.deformations_entry
    assert "directional_kernel" in beam.deformations_entry.__name__
    assert entries.ORDER_DIRECTIONAL < 0 and entries.ORDER_ASK < 0
