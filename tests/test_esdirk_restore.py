"""A Simulator state saved at an awkward point of a sampled run continues bit for bit.

The ESDIRK's flags I_AFTER_INPUT, I_LANDED and I_QUIET (`esdirk_layout`) are not in its
restart memory (`Esdirk.restart_memory`). They need not be: taking a snapshot marks a full
restart of the simulator it is taken from (`SimulatorState.get_state`), and a full restart
(`esdirk_kernels.restart` with inputs_only False) sets all three, so the original and the
restored run start their next step from the same flags. The point tried here: right after
an input change (set, not yet integrated: I_AFTER_INPUT would be 1 at the next step of a
run not saved); tests/test_esdirk_step_control.py has the states saved on landing on a
sample (I_LANDED) and after half a sample with no change (I_QUIET).
"""

import numpy as np

from flexure.core import Simulator, load_scene

SAMPLE = 2.5e-4  # s: a 4 kHz loop


def test_a_state_saved_right_after_an_input_change_continues_bit_for_bit():
    """Four samples of random held forces on stage_spatial_19dof (esdirk2, rtol 1e-6), the
    fifth sample's force set, the state saved, then four more samples on the original and
    on a new simulator restored from it: the same time, q and qdot to the bit."""
    model = load_scene("stage_spatial_19dof")
    forces = np.random.default_rng(3).normal(size=(8, len(model.inputs)))
    sim = Simulator(model, method="esdirk2", rtol=1e-6)
    for k in range(4):
        sim.set_inputs(forces[k])
        sim.advance_to((k + 1) * SAMPLE)
    sim.set_inputs(forces[4])
    state = sim.get_state()
    other = Simulator(model, method="esdirk2", rtol=1e-6)
    other.set_state(state)
    for each in (sim, other):
        for k in range(4, len(forces)):
            if k > 4:
                each.set_inputs(forces[k])
            each.advance_to((k + 1) * SAMPLE)
    assert other.time == sim.time
    assert np.array_equal(other.q, sim.q) and np.array_equal(other.qdot, sim.qdot)
