"""`flexure analyze --state-space` on a scene with kinematic inputs: the state space whose
inputs are their positions (`flexure.core.analysis.motion_statespace`), as JSON and as text."""

import numpy as np


def motion_space_result(model, solution):
    """The `--json` entry "state_space_from_positions": A, B, C, D, D1, D2 and the names
    (inputs in m or rad; outputs in their units; efforts in N or N m)."""
    from ..analysis.motion_statespace import motion_state_space

    space = motion_state_space(model, solution=solution)
    return {"A": space.A, "B": space.B, "C": space.C, "D": space.D, "D1": space.D1,
            "D2": space.D2, "inputs": space.inputs, "outputs": space.outputs,
            "states": space.states}


def render_motion_space(space):
    """The text of a "state_space_from_positions" entry: its matrices and names."""
    parts = ["\nstate space from the kinematic inputs' positions: z' = A z + B u, outputs "
             "C z + D u + D1 u' + D2 u''"]
    with np.printoptions(precision=6, linewidth=100):
        for key in ("A", "B", "C", "D", "D1", "D2"):
            parts.append(f"\n{key} =\n{np.array(space[key])}")
    parts.append(f"\ninputs: {', '.join(space['inputs'])}   outputs: "
                 f"{', '.join(space['outputs'])}   states: {', '.join(space['states']) or 'none'}")
    return "\n".join(parts)
