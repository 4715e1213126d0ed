"""A touching BEAM's mass on its z-coordinates from the BEAM's closed form
(core/engine/touching_beam_mass.py, through OP_BEAM_MASSES: core/engine/beam_mass_entry.py),
against the dense products of plain numpy and the generic kernel
(`rigid_kernels.touching_mass`).

Me_z = T_e^T Dp^T Mp Dp T_e and f_c = T_e^T Dp^T Mp Dp c_e, for the manipulator's touching
BEAMs' T_e at moved masters (`RigidPacking.element_transform`, the plain twin of the
kernels' sums) and random BEAMs' Dp and Mp (`tests/test_beam_mass.beam_elements`); which
models run it; the manipulator's evaluation taking it for every touching BEAM, and its
accelerations against the engine without clusters.
"""

import numpy as np
import pytest
from test_rigid import engine_results, moved_masters

from flexure.core import Mechanics, load_scene
from flexure.core.engine import beam_mass_entry, engine, operations, rigid_kernels
from flexure.core.engine import data as ed
from flexure.core.engine import rigid as rg
from flexure.core.engine import slots as slot
from flexure.core.engine.data import EngineData
from flexure.core.engine.point_masses import element_points, point_columns
from flexure.core.engine.slots import group_inertia, inertia_scratch
from flexure.core.engine.touching_beam_mass import SCRATCH, touching_beam_mass
from flexure.core.mechanics.rigid_bodies import RigidLayout, find_clusters
from flexure.core.numerics.jit import kernel
from tests.test_beam_mass import beam_elements


@pytest.fixture(scope="module")
def manipulator():
    """(model, EngineData, RigidLayout, x at moved masters with its slaves filled and T's
    weights in the packed model) of manipulator_control."""
    model = load_scene("manipulator_control")
    data = EngineData(model)
    layout = RigidLayout(model, find_clusters(model))
    x = moved_masters(model, layout, seed=3)
    rigid_kernels.fill_slaves(data.address, x.copy())
    return model, data, layout, x


def touching_beams(data):
    """The touching elements (t, group, index) of BEAM groups that have a mass of their own."""
    elements = data.int_array("rigid_elements").reshape(-1, rg.ELEMENT_WIDTH)
    beams = [(t, row[rg.E_GROUP], row[rg.E_ELEMENT]) for t, row in enumerate(elements)
             if row[rg.E_MASS_OFFSET] >= 0 and row[rg.E_FOLDED] == 0]
    return [(t, g, i) for t, g, i in beams
            if data.rigid.groups_m[g] == 14 and data.rigid.touching[t][2].size <= 14]


def test_against_the_dense_products(manipulator):
    """Me_z and f_c of each of the manipulator's touching BEAMs (random Dp, Mp and slaves'
    c) to 1e-13 of their largest entries, against plain numpy and the generic kernel."""
    model, data, layout, x = manipulator
    table, packing = data.address, data.rigid
    beams = touching_beams(data)
    assert len(beams) == 57
    _, Dps, Mps = beam_elements(len(beams), seed=11)
    rng = np.random.default_rng(12)
    c = data.float_array("rigid_c")
    terms, W = data.int_array("rigid_terms"), data.float_array("rigid_weights")
    local = np.full(SCRATCH, np.nan)
    pattern = np.flatnonzero(Mps[0].ravel()).astype(np.int64)
    for (t, g, i), Dp, Mp in zip(beams, Dps, Mps, strict=True):
        coords = model.groups[g].coordinate_index[i]
        z = packing.touching[t][2]
        Te = packing.element_transform(g, i, coords, x)
        c_e = rng.standard_normal(14)
        Me_z, f_c = np.full(z.size ** 2, np.nan), np.full(z.size, np.nan)
        start = data.int_array("rigid_elements")[t * rg.ELEMENT_WIDTH + rg.E_TERM_OFFSET]
        touching_beam_mass(terms, start, W, z.size, Mp.ravel(), Dp, c_e, Me_z, f_c, local)
        Me = Dp.T @ Mp @ Dp
        expected, expected_f = Te.T @ Me @ Te, Te.T @ Me @ c_e
        scale, scale_f = np.max(np.abs(expected)), np.max(np.abs(expected_f))
        assert np.max(np.abs(Me_z - expected.ravel())) <= 1e-13 * scale
        assert np.max(np.abs(f_c - expected_f)) <= 1e-13 * scale_f
        # the generic kernel, with the same c on the element's coordinates
        c[:] = 0.0
        c[coords] = c_e
        columns = np.zeros(24 * 15 + 14, dtype=np.int64)
        point_columns(24, 14, Dp, columns)
        generic, force = rigid_kernels.touching_mass(table, t, Mp.ravel(), pattern, 24, 14,
                                                     Dp, columns, coords, True)
        assert np.max(np.abs(Me_z - generic)) <= 1e-13 * scale
        assert np.max(np.abs(f_c - force)) <= 1e-13 * scale_f
    c[:] = 0.0


def test_which_models_run_it():
    """The manipulator (touching BEAMs with their own mass) runs OP_BEAM_MASSES; a planar
    stage with a rigid cluster (PLBEAMs) does not."""
    assert beam_mass_entry.uses(EngineData(load_scene("manipulator_control")))
    assert not beam_mass_entry.uses(EngineData(load_scene("stage_planar_3dof")))


@kernel
def _closed_form_status(table, t, g, i):
    """touching_masses' status for touching element t (element i of group g) after its
    inertia points and their non-zero columns are where `inertia_forces` leaves them."""
    inertia = group_inertia(table, g)
    _, m, P, _, _, _, _, _, _, _ = inertia
    scratch = inertia_scratch(table, 0, P, m)
    element_points(inertia, scratch, i, slot.float_array(table, slot.X),
                   slot.float_array(table, slot.XDOT), 2)
    point_columns(P, m, scratch[5], slot.int_array(table, slot.POINT_COLUMNS))
    return beam_mass_entry.touching_masses(table, t, True)


def test_the_manipulator_takes_it(manipulator):
    """After an evaluation (which connects OP_BEAM_MASSES), every touching BEAM of the
    manipulator passes the closed form's checks (status OK); a planar stage's touching
    PLBEAM does not (NOT_AVAILABLE: the generic path)."""
    model, data, _, _ = manipulator
    q = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    assert engine.call(data, engine.OP_EVALUATE, q, 0.1 * np.ones(q.size)) == ed.OK
    op = operations.OP_BEAM_MASSES
    assert engine._TABLE[op] == engine.ENTRIES[op].address
    table = data.address
    for t, g, i in touching_beams(data):
        assert _closed_form_status(table, t, g, i) == ed.OK
    stage = load_scene("stage_planar_3dof")
    planar = EngineData(stage)
    q = Mechanics(stage).kinematics.dofs_of(stage.initial_coordinates)
    assert engine.call(planar, engine.OP_EVALUATE, q, 0.1 * np.ones(q.size)) == ed.OK
    assert planar.rigid.touching
    for t, (g, i, _) in enumerate(planar.rigid.touching):
        assert _closed_form_status(planar.address, t, g, i) == ed.NOT_AVAILABLE


@pytest.mark.slow
def test_the_manipulator_against_the_full_system():
    """qddot, the tangent's K and the first-order Jacobian of the manipulator with its
    clusters (its touching BEAMs' masses in the closed form) against the engine without
    clusters at two random moving states, to 1e-12 of each quantity's largest entry (as
    tests/test_rigid.py's elimination)."""
    model = load_scene("manipulator_control")
    full, _ = engine_results(model, False, "augmented", seed=8)
    reduced, data = engine_results(model, True, "augmented", seed=8)
    assert beam_mass_entry.uses(data)
    for a, b in zip(full, reduced, strict=True):
        for quantity in ("qddot", "stiffness", "jacobian"):
            scale = np.max(np.abs(a[quantity]))
            assert np.max(np.abs(a[quantity] - b[quantity])) <= 1e-12 * scale, quantity
