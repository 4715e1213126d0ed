"""J's sparse values with rigid clusters (`sparse_factors.constraint_values`) against the
full walk over slot rigid_de.

`constraint_values` adds the touching elements' De_z (slot rigid_de) on J's rows alone (slot
touching_rows), the only rows `rigid_kernels.rigid_de` forms. The reference is the walk over
every entry of rigid_de that a J map places, in numpy: at a moving state of
manipulator_control (sparse J), with rigid_de's other entries set to NaN (as if never formed),
J's values must be finite, and J's values less those with rigid_de zeroed must be rigid_de
placed by the map, entry by entry, to round-off (1e-15 of the largest value: each value is
(De or 1) + De_z + T's weight, summed in that order on both sides).
"""

import numpy as np

from flexure.core import Mechanics, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine import rigid as packed_rigid
from flexure.core.engine.data import EngineData
from flexure.core.engine.sparse_factors import constraint_values
from flexure.core.numerics import sparse_lu


def test_js_values_read_rigid_de_on_js_rows_as_the_full_walk_places_it():
    model = load_scene("manipulator_control")
    data = EngineData(model, augmented=True)
    dims = data.int_array("dims")
    assert dims[ed.J_SPARSE] == 1 and dims[ed.NSLAVES] > 0
    mechanics = Mechanics(model)
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    rng = np.random.default_rng(7)
    q = q0 + 1e-4 * rng.standard_normal(q0.size)
    assert engine.call(data, engine.OP_ACCELERATIONS, q, rng.standard_normal(q0.size)) == ed.OK

    rigid_de = data.float_array("rigid_de")
    elements = data.int_array("rigid_elements").reshape(-1, packed_rigid.ELEMENT_WIDTH)
    on_rows = np.zeros(rigid_de.size, dtype=bool)
    for _, t, b in data.int_array("touching_rows").reshape(-1, 3):
        mz = elements[t, packed_rigid.E_MZ]
        at = elements[t, packed_rigid.E_DE_OFFSET] + b * mz
        on_rows[at: at + mz] = True
    formed = rigid_de.copy()
    assert np.all(np.isfinite(formed[on_rows])) and not on_rows.all()

    jmap = data.int_array("j_map")
    start = data.float_array("De").size + int(dims[ed.NXDOF])  # rigid_de's part of the map
    places = jmap[start: start + rigid_de.size]
    n_values = sparse_lu.matrix_values(data.int_array("j_sparse"),
                                       data.float_array("j_sparse_values")).size
    values, without = np.full(n_values, np.nan), np.full(n_values, np.nan)
    rigid_de[~on_rows] = np.nan
    constraint_values(data.address, jmap, values)
    rigid_de[:] = 0.0
    constraint_values(data.address, jmap, without)
    rigid_de[:] = formed

    assert np.all(np.isfinite(values))  # the unformed entries are not read
    placed = np.zeros(n_values)
    read = places >= 0
    np.add.at(placed, places[read], formed[read])  # the full walk's rigid_de part
    assert np.count_nonzero(placed) > 100
    scale = np.max(np.abs(values))
    assert np.max(np.abs((values - without) - placed)) <= 1e-15 * scale
