"""Where the measurement of a state's outputs starts its kinematics.

The outputs that are not DOFs (an encoder on a rigid body, an end effector's position) need
x = F(q) at the measured state's DOFs q. The measuring runs on a second packed model (the
simulator's `_output_data`, the compiled loop's output table), so that it never disturbs the
integrator's own, and it stops as soon as the constraint residual is within the tolerance
(`engine.OP_POSITIONS`). It starts from the plant's last kinematic solution x_e at DOFs q_e,
moved to q to first order with the factors of J that solution left:

    x_start = x_e + J_e^-1 [0; q - q_e]   on the free coordinates

(`engine.kinematics.predicted_coordinates`, the kinematics' own warm start, here from another
packed model's solution; the slaves of rigid clusters follow their masters at the first
evaluation). At the end of
an integrator step q - q_e is the step's last Newton correction, within the Newton's
tolerance (about 1e-9 m at the loop's rtol 1e-5), so the start's residual, of the order of
|q - q_e|^2 over the flexures' lengths, passes at the first evaluation: one solve with J's
factors and one evaluation of e instead of a Newton step's factorisation. When it does not
pass, the Newton goes on from there as before.
"""

from ..engine.kinematics import start_from_plant  # the engine's: it reads the plant's slots

__all__ = ["start_from_plant"]
