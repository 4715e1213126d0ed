"""Scene FMU states under fmpy: get, set and serialize replay bit for bit, inputs held across
steps and restores, reset, several instances and scenes in one process."""

import numpy as np
from fmpy_slave import Slave, grid_and_inputs

from flexure.core import Simulator, load_scene


def test_state_get_set_and_serialize_replay_bit_for_bit(scene_fmus):
    path = scene_fmus("stage_planar_3dof")
    a = Slave(path, "a")
    times, forces = grid_and_inputs()
    half = len(forces) // 2
    for t, h, f in zip(times[:half], np.diff(times)[:half], forces[:half], strict=True):
        a.set(f)
        a.step(t, h)
    state = a.fmu.getFMUstate()
    data = a.fmu.serializeFMUstate(state)

    def rest(slave):
        ys = []
        for t, h, f in zip(times[half:-1], np.diff(times)[half:], forces[half:], strict=True):
            slave.set(f)
            ys.append(slave.step(t, h))
        return np.array(ys)

    original = rest(a)
    for _ in range(2):  # restoring twice: the saved state is not changed by stepping on
        a.fmu.setFMUstate(state)
        assert np.array_equal(rest(a), original)
    b = Slave(path, "b")  # another instance, from the serialized bytes
    restored = b.fmu.deSerializeFMUstate(data)
    b.fmu.setFMUstate(restored)
    assert np.array_equal(rest(b), original)
    a.fmu.freeFMUstate(state)
    b.fmu.freeFMUstate(restored)
    a.close()
    b.close()


def test_an_input_set_once_holds_and_a_restored_state_holds_its_own_inputs(scene_fmus):
    """Setting an input once or before every doStep gives the same numbers (the slave tells
    its simulator only of a change). An FMU state holds every settable variable: after
    fmi2SetFMUstate the inputs are the saved ones again, held by the next doStep without a
    set, although the host had set others since."""
    path = scene_fmus("stage_planar_3dof")
    once, every = Slave(path, "once"), Slave(path, "every")
    once.set(0.7)
    held_once, set_every = [], []
    for k in range(6):
        held_once.append(once.step(k * 1e-3, 1e-3))
        every.set(0.7)
        set_every.append(every.step(k * 1e-3, 1e-3))
    assert np.array_equal(np.array(held_once), np.array(set_every))
    state = once.fmu.getFMUstate()
    every.fmu.freeFMUstate(every.fmu.getFMUstate())  # taking a state restarts the kinematics
    once.set(0.2)
    changed = [once.step(k * 1e-3, 1e-3) for k in range(6, 9)]
    once.fmu.setFMUstate(state)
    assert once.fmu.getReal([once.vr[once.inputs[0]]]) == [0.7]
    restored = [once.step(k * 1e-3, 1e-3) for k in range(6, 9)]  # no set: 0.7 N held
    continued = [every.step(k * 1e-3, 1e-3) for k in range(6, 9)]
    assert np.array_equal(np.array(restored), np.array(continued))
    assert not np.array_equal(np.array(restored), np.array(changed))
    once.fmu.freeFMUstate(state)
    once.close()
    every.close()


def test_reset_starts_over(scene_fmus):
    scene = "stage_planar_1dof"
    slave = Slave(scene_fmus(scene))
    slave.set(1.0)
    first = [slave.step(k * 1e-3, 1e-3) for k in range(5)]
    slave.fmu.reset()
    slave.initialize()
    sim = Simulator(load_scene(scene))
    sim.reset()
    assert np.array_equal(slave.y(), sim.outputs())
    slave.set(1.0)
    again = [slave.step(k * 1e-3, 1e-3) for k in range(5)]
    slave.close()
    assert np.array_equal(np.array(first), np.array(again))


def test_two_instances_and_two_scenes_in_one_process(scene_fmus):
    planar = scene_fmus("stage_planar_3dof")
    truss = scene_fmus("truss_1dof_x")
    alone = {}
    for name, path, force in (("p", planar, 1.0), ("t", truss, 2.0)):
        s = Slave(path, name)
        s.set(force)
        alone[name] = [s.step(k * 1e-3, 1e-3) for k in range(8)]
        s.close()
    a, b, c = Slave(planar, "a"), Slave(planar, "b"), Slave(truss, "c")
    a.set(1.0)
    b.set(-1.0)
    c.set(2.0)
    ya, yb, yc = [], [], []
    for k in range(8):  # interleaved
        ya.append(a.step(k * 1e-3, 1e-3))
        yc.append(c.step(k * 1e-3, 1e-3))
        yb.append(b.step(k * 1e-3, 1e-3))
    for s in (a, b, c):
        s.close()
    assert np.array_equal(ya, alone["p"])
    assert np.array_equal(yc, alone["t"])
    assert not np.allclose(ya, yb)
