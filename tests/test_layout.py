"""The engine's layout table against its index constants, its packing and its roles.

The slots' index constants (`slots.X`) and the records' field constants (`data.NDOF`) are
generated from `layout`; the packing (`packing`) fills slots by name and `packing_check.check` holds
it against the table. These tests check the three ways that can go wrong: two slots sharing
an index, a slot packed under another's name (or by another concern, or of another size), a
slot declared and never packed; and that what the table calls configuration is left alone
by evaluations.
"""

import numpy as np
import pytest

from flexure.core import Simulator, load_scene
from flexure.core.engine import access, engine, layout, packing, packing_check, slots
from flexure.core.engine import data as ed
from flexure.core.engine.data import EngineData

# a planar stage, a spatial one, rigid clusters with sparse factors, voice-coil actuators
SCENES = ("stage_planar_3dof", "stage_spatial_19dof", "manipulator_control",
          "manipulator_control_vcm")


def test_the_tables_give_every_slot_and_field_its_own_name_and_index():
    assert layout.table_problems() == []
    for dtype, names in ((layout.INT, layout.INT_SLOTS), (layout.FLOAT, layout.FLOAT_SLOTS)):
        indices = [getattr(slots, layout.BY_NAME[name].constant) for name in names]
        assert indices == list(range(len(names))), dtype
        assert all(type(i) is int for i in indices)  # numba freezes plain ints as literals
    for record, fields in layout.RECORDS.items():
        assert [getattr(ed, f.constant) for f in fields] == list(range(len(fields))), record


def test_a_duplicate_in_the_table_is_found(monkeypatch):
    x = layout.BY_NAME["x"]
    monkeypatch.setattr(layout, "SLOTS", layout.SLOTS + (x,))
    assert "slot name 'x' used twice" in layout.table_problems()
    assert "slot constant 'X' used twice" in layout.table_problems()


def test_every_packing_function_is_in_the_table_and_every_slot_has_one():
    assert set(layout.PACKERS) == set(packing.PACKERS)


@pytest.fixture(scope="module", params=SCENES)
def packed(request):
    """(context, {packing function: {slot: array}}) of a scene."""
    context = packing.Context(load_scene(request.param), tolerance=1e-15, singular_ratio=1e-6,
                              augmented=None, sparse=None, rigid=True)
    return context, packing.pack(context)


def _moved(packed, moves):
    """A copy of the packing with slots moved: {(packer, name): (packer, new name)}."""
    out = {packer: dict(arrays) for packer, arrays in packed.items()}
    for (packer, name), (new_packer, new_name) in moves.items():
        out[new_packer][new_name] = packed[packer][name]
        if (packer, name) not in moves.values():
            del out[packer][name]
    return out


def test_the_packing_matches_the_table(packed):
    context, arrays = packed
    assert packing_check.check(arrays, context.counts) == []


def test_a_slot_packed_under_another_slots_name_is_refused(packed):
    context, arrays = packed
    swapped = _moved(arrays, {("kinematics", "x"): ("kinematics", "e"),
                              ("kinematics", "e"): ("kinematics", "x")})
    problems = packing_check.check(swapped, context.counts)
    assert any(p.startswith("slot 'x': expected nx") for p in problems), problems
    assert any(p.startswith("slot 'e': expected ne") for p in problems), problems
    by_another = _moved(arrays, {("motion", "qddot"): ("kinematics", "qddot")})
    assert "slot 'qddot': expected from motion, packed by kinematics" in packing_check.check(
        by_another, context.counts)
    as_int = {**arrays, "kinematics": {**arrays["kinematics"],
                                       "x": arrays["kinematics"]["x"].astype(np.int64)}}
    assert any("slot 'x': expected a flat float64 array" in p
               for p in packing_check.check(as_int, context.counts))


def test_a_slot_never_packed_or_unknown_is_refused(packed):
    context, arrays = packed
    missing = {**arrays, "motion": {k: v for k, v in arrays["motion"].items() if k != "mass"}}
    assert packing_check.check(missing, context.counts) == [
        "slot 'mass' declared (packed by motion) and never packed"]
    unknown = {**arrays, "motion": {**arrays["motion"], "masses": arrays["motion"]["mass"]}}
    assert packing_check.check(unknown, context.counts) == [
        "motion packed 'masses', which is no slot of the layout"]


def test_engine_data_refuses_a_packing_that_does_not_match(monkeypatch):
    def motion_without_mass(context):
        return {k: v for k, v in packing.motion(context).items() if k != "mass"}

    monkeypatch.setitem(packing.PACKERS, "motion", motion_without_mass)
    with pytest.raises(layout.LayoutError, match="'mass' declared"):
        EngineData(load_scene("stage_planar_1dof"))


def test_python_and_compiled_code_find_a_slot_by_name_and_by_constant():
    data = EngineData(load_scene("stage_planar_1dof"))
    for slot in layout.SLOTS:
        by_name = (data.int_array if slot.dtype == layout.INT else data.float_array)(slot.name)
        tuple_ = data.ints if slot.dtype == layout.INT else data.floats
        assert by_name is tuple_[getattr(slots, slot.constant)], slot.name
    x = access.coordinates(data.address)  # a compiled accessor, from the table
    assert x.ctypes.data == data.float_array("x").ctypes.data and x.size == data.model.nx
    with pytest.raises(ValueError, match="expected the name of a float64 slot"):
        data.float_array("dims")
    assert set(data.slots(layout.CONFIG)) == set(layout.names(layout.CONFIG))


@pytest.mark.parametrize("scene", ["stage_spatial_19dof", "manipulator_control_vcm"])
def test_evaluations_leave_the_configuration_alone(scene):
    """A simulation (RHS, Jacobians, kinematics, mass, tangent) writes no slot, and no dims
    field, that the table calls configuration."""
    sim = Simulator(load_scene(scene), method="esdirk", rtol=1e-6)
    config = {name: array.copy() for name, array in sim.data.slots(layout.CONFIG).items()}
    dims = sim.data.int_array("dims")
    fixed = [i for i, f in enumerate(layout.DIMS_FIELDS) if f.role == layout.CONFIG]
    dims_before = dims[fixed].copy()
    sim.set_inputs([0.5] * len(sim.model.inputs))
    sim.advance_to(2e-3)
    y = np.ascontiguousarray(sim.state, dtype=float)
    jacobian = np.zeros(y.size * y.size)
    assert engine.call(sim.data, engine.OP_JACOBIAN, y, jacobian) == ed.OK
    for name, before in config.items():
        assert np.array_equal(before, sim.data.slots()[name]), name
    assert np.array_equal(dims_before, dims[fixed])


def test_an_evaluation_mode_is_undone_after_its_block_even_after_a_failure():
    """`EngineData.evaluating` sets dims.has_damping, dims.static and dims.conv_wanted for its
    block, leaves a switch not given alone, and puts back what was there, also when the
    block raises; `restart_kinematics` starts the next
    solution from the given coordinates (x_start, warm = 0), and the solution it gives is the
    one a fresh packing gives from there."""
    data = EngineData(load_scene("stage_planar_1dof"))
    dims = data.int_array("dims")
    dims[ed.HAS_DAMPING], dims[ed.STATIC] = 0, 1
    with data.evaluating(damping=True, static=False):
        assert (dims[ed.HAS_DAMPING], dims[ed.STATIC]) == (1, 0)
    assert (dims[ed.HAS_DAMPING], dims[ed.STATIC]) == (0, 1)
    with pytest.raises(RuntimeError, match="inside"), data.evaluating(damping=True):
        assert (dims[ed.HAS_DAMPING], dims[ed.STATIC]) == (1, 1)
        raise RuntimeError("inside")
    assert (dims[ed.HAS_DAMPING], dims[ed.STATIC]) == (0, 1)
    with data.evaluating(convective=True):
        assert (dims[ed.HAS_DAMPING], dims[ed.STATIC], dims[ed.CONV_WANTED]) == (0, 1, 1)
    assert (dims[ed.HAS_DAMPING], dims[ed.STATIC], dims[ed.CONV_WANTED]) == (0, 1, 0)

    x0 = data.model.initial_coordinates
    q = np.array([1e-3])
    assert engine.call(data, engine.OP_KINEMATICS, q) == ed.OK
    assert dims[ed.WARM] == 1  # the next solve would start from this solution
    data.restart_kinematics(x0)
    assert dims[ed.WARM] == 0 and np.array_equal(data.float_array("x_start"), x0)
    assert engine.call(data, engine.OP_KINEMATICS, q) == ed.OK
    fresh = EngineData(load_scene("stage_planar_1dof"))
    assert engine.call(fresh, engine.OP_KINEMATICS, q) == ed.OK
    np.testing.assert_allclose(data.float_array("x"), fresh.float_array("x"), rtol=0,
                               atol=1e-15)
