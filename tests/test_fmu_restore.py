"""FMU states restored in fmpy: the restored time is the one stepped from, a forged state (a
valid checksum over made-up numbers) is refused field by field, and von_mises_max is computed
only when read."""

import gc
import math
import re

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime
from fmpy_slave import Slave, do_step

from flexure.core import Simulator, load_scene, stresses_along
from flexure.fmu import build_scene_fmu, state_format

FMI2_ERROR = 3


def steps_to(slave, t_end, h=1e-3, force=0.5):
    """Step a fresh slave from 0 to t_end at h with `force` held; the outputs after each."""
    slave.set(force)
    return [slave.step(k * h, h) for k in range(round(t_end / h))]


@pytest.mark.parametrize("binary, reported", [("auto", 5e-3), ("stock", 8e-3)])
def test_a_restored_state_steps_from_its_own_time(scene_fmus, binary, reported):
    """Stepped to 8 ms, restored to the state of 5 ms: a doStep from 5 ms is accepted and
    repeats the original sixth step bit for bit, a doStep from 8 ms is discarded naming 5 ms.
    fmi2LastSuccessfulTime is answered by pythonfmu's binary from its own record: flexure's
    corrected build asks the slave after the restore (5 ms); the stock binary, the fallback,
    only writes it in doStep (8 ms until the next doStep; docs/fmu.md's datasheet)."""
    slave = Slave(scene_fmus("stage_planar_3dof", binary))
    first = steps_to(slave, 5e-3)
    state = slave.fmu.getFMUstate()
    original = steps_to_from(slave, 5, 8)
    assert slave.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(8e-3, abs=1e-15)
    slave.fmu.setFMUstate(state)
    np.testing.assert_array_equal(slave.y(), first[-1])  # the outputs of 5 ms again
    assert slave.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(reported,
                                                                             abs=1e-15)
    slave.logs.clear()
    assert steps_to_from(slave, 5, 8) == original  # accepted from 5 ms, the same numbers
    assert slave.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(8e-3, abs=1e-15)
    assert not [m for s, m in slave.logs if s == FMI2_ERROR]
    slave.fmu.setFMUstate(state)
    assert slave.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(reported,
                                                                             abs=1e-15)
    assert do_step(slave, 8e-3) == 2
    assert [m for s, m in slave.logs if "expected the communication point t = 0.005 s, got "
            "0.008 s" in m]
    slave.fmu.freeFMUstate(state)
    slave.close()


def steps_to_from(slave, k0, k1, h=1e-3):
    """The outputs after each doStep from k0 * h to k1 * h, as lists (exact comparison)."""
    outputs = []
    for k in range(k0, k1):
        assert do_step(slave, k * h, h) == 0
        outputs.append(slave.y().tolist())
    return outputs


def forge(data, change):
    """State bytes decoded, changed by `change(value)` and encoded again with a valid
    checksum: what a hostile host can hand over."""
    _, identity = state_format.read_identity(data)
    value = state_format.decode(data, identity)
    change(value)
    return state_format.encode(identity, value)


def simulator(value):
    return value["model"]["simulator"]


def set_array(key, index, number):
    def change(value):
        array = np.array(simulator(value)[key])
        array[index] = number
        simulator(value)[key] = array
    return change


def setting(position, number):
    def change(value):
        settings = list(value["model"]["settings"])
        settings[position] = number
        value["model"]["settings"] = tuple(settings)
    return change


# (what is forged, the change, what the refusal must name)
FORGERIES = [
    ("time far beyond the start", lambda v: v.update(time=1e300),
     r"time = 1e\+300 s: expected a time from start_time = 0.0 s to 1e\+09 s after it"),
    ("time before the start", lambda v: v.update(time=-1.0),
     r"time = -1.0 s: expected a time from start_time"),
    ("time NaN", lambda v: v.update(time=math.nan), r"time = nan s: expected a finite float"),
    ("time and the simulator's time apart", lambda v: v.update(time=0.5),
     r"simulator.t = 0.005 s: expected the state's communication point time = 0.5 s"),
    ("a DOF at 1e300 m", set_array("y", 0, 1e300),
     r"simulator.q: coordinate \S+ = 1e\+300 m is 1e\+300 m from its start; expected at most "
     r"100 times the model's size"),
    ("a coordinate at 1e300 m", set_array("x", 0, 1e300),
     r"simulator.x: coordinate \S+ = 1e\+300 m"),
    ("a velocity NaN", set_array("y", -1, math.nan), r"non-finite numbers"),
    ("an input NaN", lambda v: v["variables"].update(F=math.nan),
     r"variable 'F' = nan: expected a finite number"),
    ("an input infinite", lambda v: v["variables"].update(F=math.inf),
     r"variable 'F' = inf: expected a finite number"),
    ("rtol among the variables", lambda v: v["variables"].update({"integrator.rtol": -1.0}),
     r"variable integrator.rtol = -1.0: expected a finite number in \(0, 1\)"),
    ("max_steps 0", lambda v: v["variables"].update({"integrator.max_steps": 0.0}),
     r"integrator.max_steps = 0: expected an integer from 1 to 1e9"),
    ("a method that does not exist", lambda v: v["variables"].update(
        {"integrator.method": "euler"}), r"integrator.method = 'euler': expected one of"),
    ("rtol in the model's settings", setting(1, 2.0),
     r"integrator.rtol = 2.0: expected a finite number in \(0, 1\)"),
    ("atol in the model's settings", setting(2, -1e-9),
     r"integrator.atol = -1e-09: expected a finite number >= 0"),
    ("a state one number longer", lambda v: simulator(v).update(
        y=np.append(simulator(v)["y"], 0.0)), r"with 7 states; expected .* with 6"),
    ("outputs stored (NaN)", lambda v: v["model"].update(outputs=np.full(4, math.nan)),
     r"the model part is not a scene slave's state"),
    ("an unknown call-sequence state", lambda v: v.update(phase="running"),
     r"unknown call-sequence state 'running'"),
]


@pytest.mark.parametrize("what, change, message", FORGERIES,
                         ids=[f[0].replace(" ", "-") for f in FORGERIES])
def test_a_forged_state_is_refused_naming_the_field(scene_fmus, what, change, message):
    """A state with a valid checksum is still only data: each field is checked as a host's
    value would be, the refusal (fmi2Error from flexure's corrected pythonfmu binary; logged
    at status error) names it, and the instance goes on unchanged."""
    slave, forged, before = forged_state(scene_fmus("stage_planar_3dof"), change)
    with pytest.raises(FMICallException) as raised:
        slave.fmu.setFMUstate(forged)
    assert raised.value.status == FMI2_ERROR
    refusals = [m for s, m in slave.logs if s == FMI2_ERROR]
    assert len(refusals) == 2, slave.logs  # the slave's reason, then the binary's answer
    assert "fmi2SetFMUstate refused" in refusals[0] and "the instance is unchanged" in \
        refusals[0]
    assert re.search(message, refusals[0]), refusals[0]
    assert refusals[1] == "fmi2SetFMUstate: the slave refused the state (its log says why)"
    assert slave.y().tolist() == before
    assert do_step(slave, 5e-3) == 0
    assert np.all(np.isfinite(slave.y()))
    slave.fmu.freeFMUstate(forged)
    slave.close()


def test_a_forged_state_is_refused_with_fmi2ok_by_the_stock_binary(scene_fmus):
    """The fallback: pythonfmu's stock binary ignores the slave's refusal and answers fmi2OK;
    the log names the field and the instance is unchanged all the same."""
    change, message = FORGERIES[0][1:]
    slave, forged, before = forged_state(scene_fmus("stage_planar_3dof", "stock"), change)
    assert slave.fmu.setFMUstate(forged) is None  # fmi2OK (fmpy raises on anything else)
    refusals = [m for s, m in slave.logs if s == FMI2_ERROR]
    assert len(refusals) == 1 and re.search(message, refusals[0]), slave.logs
    assert slave.y().tolist() == before
    assert do_step(slave, 5e-3) == 0
    slave.fmu.freeFMUstate(forged)
    slave.close()


def forged_state(path, change):
    """(slave stepped to 5 ms, a deserialized forged state of it, the outputs before)."""
    slave = Slave(path)
    steps_to(slave, 5e-3)
    state = slave.fmu.getFMUstate()
    data = slave.fmu.serializeFMUstate(state)
    slave.fmu.freeFMUstate(state)
    forged = slave.fmu.deSerializeFMUstate(forge(data, change))
    before = slave.y().tolist()
    slave.logs.clear()
    return slave, forged, before


def test_the_unforged_state_restores(scene_fmus):
    """The same decode and encode with no change restores: the forgeries above are refused
    for their change, not for being re-encoded."""
    slave = Slave(scene_fmus("stage_planar_3dof"))
    steps_to(slave, 5e-3)
    state = slave.fmu.getFMUstate()
    data = slave.fmu.serializeFMUstate(state)
    expected = steps_to_from(slave, 5, 7)
    restored = slave.fmu.deSerializeFMUstate(forge(data, lambda value: None))
    slave.logs.clear()
    slave.fmu.setFMUstate(restored)
    assert not [m for s, m in slave.logs if s == FMI2_ERROR]
    assert steps_to_from(slave, 5, 7) == expected
    slave.fmu.freeFMUstate(state)
    slave.fmu.freeFMUstate(restored)
    slave.close()


def slave_instance(identifier, instance_name):
    """The Python slave object of a running FMU instance (in this process, through fmpy)."""
    found = [o for o in gc.get_objects() if type(o).__name__ == identifier
             and not isinstance(o, type) and getattr(o, "instance_name", None) == instance_name]
    assert len(found) == 1
    return found[0]


def test_von_mises_is_computed_only_when_read(tmp_path):
    """von_mises_max is computed on the first read after a step, once, and equals what the
    eager computation gave (stresses_along at the state, with the held inputs), bit for
    bit; steps with no read compute nothing."""
    scene = "stage_spatial_1dof"
    path = build_scene_fmu(scene, tmp_path / "spatial.fmu", von_mises=True)
    slave = Slave(path, "lazy")
    instance = slave_instance(scene, "lazy")
    vr = slave.vr["von_mises_max"]
    model = load_scene(scene)
    sim = Simulator(model, method="esdirk", rtol=1e-6)
    sim.reset()
    assert instance.stress_evaluations == 0  # instantiated and initialised: not read yet
    for k in range(6):
        force = 0.5 if k < 3 else -0.3
        slave.set(force)
        slave.fmu.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
        sim.set_inputs([force])
        sim.advance_to((k + 1) * 1e-3)
    assert instance.stress_evaluations == 0  # six steps, no read
    slave.set(9.0)  # a new input, not yet held: the stress is of the state's inputs
    read = [slave.fmu.getReal([vr])[0] for _ in range(3)]
    assert instance.stress_evaluations == 1  # three reads of one state: computed once
    _, eager = stresses_along(model, [np.concatenate([sim.q, sim.qdot])], inputs=[[-0.3]])
    assert read == [float(np.nanmax(eager))] * 3
    assert read[0] > 0
    slave.fmu.doStep(currentCommunicationPoint=6e-3, communicationStepSize=1e-3)
    slave.fmu.getReal([vr])
    assert instance.stress_evaluations == 2  # a new state: computed again
    slave.close()


def test_a_freed_state_is_kept_valid_and_released_in_turn(monkeypatch):
    """What fmi2FreeFMUstate's release of the last reference leaves (FMUState's finalizer):
    the object kept, its bytes dropped and marked freed; beyond FREED_KEPT the oldest is
    released, unless it was freed more than once (then it is kept for good: releasing it
    would release more references than it holds)."""
    import collections
    import ctypes
    import sys

    from flexure.fmu import slave_states
    from flexure.fmu.slave_states import FREED, HOLDS, FMUState

    monkeypatch.setattr(slave_states, "FREED_KEPT", 2)
    monkeypatch.setattr(slave_states, "FREED_HOLDS", collections.deque())
    monkeypatch.setattr(slave_states, "OVER_FREED_HOLDS", [])
    handle = FMUState(b"state")
    address = id(handle)
    del handle  # the host's free
    kept = slave_states.FREED_HOLDS[0][0]
    assert id(kept) == address and kept.data is FREED
    assert sys.getrefcount(kept) == HOLDS + 2  # the tuple's, `kept` and the argument
    ctypes.pythonapi.Py_DecRef(ctypes.py_object(kept))  # a second free by the host
    del kept
    for _ in range(2):
        FMUState(b"other")  # freed at once: the first of them evicts the over-freed one
    assert slave_states.freed_states() == (2, 1)
    over = slave_states.OVER_FREED_HOLDS[0][0]
    assert id(over) == address
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(over))  # give back what the test took away
    FMUState(b"third")  # evicts one freed once: released, not kept
    assert slave_states.freed_states() == (2, 1)
