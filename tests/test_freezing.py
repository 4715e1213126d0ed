"""`freezing.freezable` (the complement of the taken rows' span, shrunk by blocked
Householder reflections) against the plain incremental test it replaces: an orthonormal basis of the
span, grown by each group's rows after two Gram-Schmidt passes against it, the same
thresholds. The same groups are taken on the elongation-frozen manipulator's reduction
candidates, on a guidance with every released deformation alone and in pairs, and on the
planar stage; the complement stays orthonormal and orthogonal to every taken row."""

import copy

import numpy as np
import pytest
import scipy.linalg

from examples import manipulator
from flexure.core import load_scene
from flexure.core.mechanics import freezing
from flexure.core.mechanics.constraints import RANK_TOLERANCE, scaled_jacobian
from flexure.core.mechanics.nullspace import rank_and_null_space
from flexure.core.scene.building import build_model


def _freezable_by_span(model, groups):
    """The plain reference: grow an orthonormal basis of the span of the taken rows."""
    kin, scaled_De = scaled_jacobian(model, None)
    columns = kin.free
    prescribed = scaled_De[np.ix_(model.rigid_deformations, columns)]
    top = max(np.abs(scaled_De[:, columns]).max(initial=0.0), 1e-300)
    q, r = np.linalg.qr(prescribed.T)
    keep = np.abs(np.diag(r)) > RANK_TOLERANCE * top
    basis = np.zeros((columns.size, columns.size))
    count = int(keep.sum())
    basis[:, :count] = q[:, keep]
    taken = []
    for position, group in enumerate(groups):
        rows = scaled_De[np.ix_(np.asarray(group, dtype=np.int64), columns)]
        norms = np.linalg.norm(rows, axis=1)
        if rows.shape[0] == 0 or count + rows.shape[0] > columns.size or not np.all(norms > 0):
            continue
        for _ in range(2):
            rows = rows - (rows @ basis[:, :count]) @ basis[:, :count].T
        q, r = np.linalg.qr(rows.T)
        limit = np.maximum(freezing.GROUP_TOLERANCE * norms, RANK_TOLERANCE * top)
        if np.all(np.abs(np.diag(r)) > limit):
            basis[:, count:count + rows.shape[0]] = q
            count += rows.shape[0]
            taken.append(position)
    return taken


def _guidance():
    data = copy.deepcopy(manipulator.scene_guidance())
    for name in ("g1_leaf2.e4", "g1_leaf4.e4", "g1_pivotT.e4"):
        element, deformation = name.rsplit(".", 1)
        data["elements"][element]["released"].append(deformation)
    return build_model(data)


def _released_alone_and_in_pairs(model):
    released = [int(d) for d in model.released_deformations]
    pairs = [[a, b] for a, b in zip(released[::2], released[1::2], strict=False)]
    return [[d] for d in released] + pairs + [[d] for d in released[::-1]]


@pytest.mark.parametrize("name", ["guidance", "stage_planar_3dof"])
def test_the_same_groups_as_the_span_test(name):
    model = _guidance() if name == "guidance" else load_scene(name)
    groups = _released_alone_and_in_pairs(model)
    taken = freezing.freezable(model, groups)
    assert taken == _freezable_by_span(model, groups)
    assert 0 < len(taken) < len(groups)  # some taken, some refused: the test decides


@pytest.mark.slow
def test_the_same_groups_on_the_manipulators_reduction():
    model = load_scene("manipulator_e1")
    groups = _released_alone_and_in_pairs(model)
    taken = freezing.freezable(model, groups)
    assert taken == _freezable_by_span(model, groups)


def test_the_complement_is_orthonormal_and_orthogonal_to_what_is_taken():
    model = load_scene("stage_planar_3dof")
    released = [[int(d)] for d in model.released_deformations]
    group = [released[k][0] for k in freezing.freezable(model, released)[:2]]
    kin, scaled_De = scaled_jacobian(model, None)
    columns = kin.free
    prescribed = scaled_De[np.ix_(model.rigid_deformations, columns)]
    _, _, basis = rank_and_null_space(prescribed, RANK_TOLERANCE)  # N0
    rows = scaled_De[np.ix_(group, columns)]
    inside = basis.T @ rows.T
    (reflectors, tau), _ = scipy.linalg.qr(inside, mode="raw")
    shrunk = freezing.without_leading(np.eye(basis.shape[1], order="F"), reflectors, tau)
    # W Q without its first two columns: Q formed explicitly from the same factorisation
    q = scipy.linalg.qr(inside, mode="full")[0]
    assert np.abs(shrunk - q[:, 2:]).max() < 1e-14
    complement = basis @ shrunk
    assert complement.shape == (columns.size, basis.shape[1] - 2)
    assert np.abs(complement.T @ complement - np.eye(complement.shape[1])).max() < 1e-13
    scale = np.abs(np.vstack([prescribed, rows])).max()
    assert np.abs(prescribed @ complement).max() < 1e-13 * scale
    assert np.abs(rows @ complement).max() < 1e-13 * scale


def test_the_blocked_reflections_equal_the_explicit_product():
    """`without_leading` (LAPACK's blocked dormqr) against W times Q formed explicitly: a
    random orthonormal W (60, 40) and 30 reflections; the identity (100, 100) and 70 (more
    than dormqr's block of 64)."""
    rng = np.random.default_rng(7)
    w = np.asfortranarray(np.linalg.qr(rng.standard_normal((60, 40)))[0])
    parts = rng.standard_normal((40, 30))
    (reflectors, tau), _ = scipy.linalg.qr(parts, mode="raw")
    expected = w @ scipy.linalg.qr(parts, mode="full")[0][:, 30:]
    assert np.abs(freezing.without_leading(w, reflectors, tau) - expected).max() < 1e-13
    big = rng.standard_normal((100, 70))
    (reflectors, tau), _ = scipy.linalg.qr(big, mode="raw")
    shrunk = freezing.without_leading(np.eye(100, order="F"), reflectors, tau)
    assert shrunk.shape == (100, 30)
    assert np.abs(shrunk - scipy.linalg.qr(big, mode="full")[0][:, 70:]).max() < 1e-13
