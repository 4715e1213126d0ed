"""`freezing.freezable` (the complement of the taken rows' span, shrunk by Householder
reflections) against the plain incremental test it replaces: an orthonormal basis of the
span, grown by each group's rows after two Gram-Schmidt passes against it, the same
thresholds. The same groups are taken on the elongation-frozen manipulator's reduction
candidates, on a guidance with every released deformation alone and in pairs, and on the
planar stage; the complement stays orthonormal and orthogonal to every taken row."""

import copy

import numpy as np
import pytest

from examples import manipulator
from flexure.core import load_scene
from flexure.core.mechanics import freezing
from flexure.core.mechanics.constraints import RANK_TOLERANCE, scaled_jacobian
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
    top = np.abs(scaled_De[:, columns]).max()
    complement = freezing._initial_complement(prescribed, RANK_TOLERANCE * top)
    rows = scaled_De[np.ix_(group, columns)]
    reflectors, tau = np.linalg.qr(complement.T @ rows.T, mode="raw")
    shrunk = freezing._without_leading(complement, reflectors, tau)
    assert shrunk.shape == (columns.size, complement.shape[1] - 2)
    assert np.abs(shrunk.T @ shrunk - np.eye(shrunk.shape[1])).max() < 1e-13
    scale = np.abs(np.vstack([prescribed, rows])).max()
    assert np.abs(prescribed @ shrunk).max() < 1e-13 * scale
    assert np.abs(rows @ shrunk).max() < 1e-13 * scale
