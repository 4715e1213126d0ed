"""A variable-step BDF2 integrator, compiled, on the engine, for sampled loops.

Why next to TR-BDF2 ("esdirk2", the loop's default): in a loop at a fixed sample rate a step
cannot span a sample (the held force changes there), so a method's cost there is its
evaluations per step. TR-BDF2's two implicit stages take two evaluations of f a step at best;
BDF2 has one implicit equation a step and takes one, since it carries the last step's start
across a held input's change, moved by the engine's input response (`bdf2_kernels`). On the
manipulator's 6 mm loop (75 DOFs, 4 kHz) it takes one evaluation a sample where TR-BDF2 takes
2.16, with positions as close to a tight run's (docs/benchmarks.md); its velocities are less
close. CVODE's BDF, by contrast, restarts at order 1 at every changed force.

The method (the formulas, the error estimate, the input change: `bdf2_kernels`): variable-step
BDF2 with its local error estimated against the quadratic through the last two states,
filtered by the Newton matrix; backward Euler for the first step after a restart. The Newton
iteration, the Jacobian's renewal, the Newton matrix's factors and the step landing on t_stop
are the ESDIRK's (`esdirk`), whose arrays, restart and C entry layout it shares: `Bdf2` is an
`Esdirk` with another advance.
"""

import numpy as np

from .esdirk import Esdirk

# BDF2 reads no tableau; the entry's layout (esdirk_entry.arguments) still takes one
_NO_TABLEAU = (np.zeros((1, 1)), np.zeros(1), np.zeros((1, 1)))


class Bdf2(Esdirk):
    """The variable-step BDF2 on ydot = f(y), y = [q - q_ref, qdot(, coil currents)], with
    the engine: a `Stepper` (reset, advance, statistics, restart memory: the ESDIRK's).

    Parameters
    ----------
    data, rtol, atol, max_step
        As in `sundials.Cvode`.
    method : str
        The registry's name of it, "bdf2".
    """

    def __init__(self, data, *, rtol, atol, max_step=None, method="bdf2"):
        from .bdf2_kernels import advance_entry

        self._registered(method)
        self._allocate(data, rtol=rtol, atol=atol, max_step=max_step, label="BDF2",
                       exponent=1.0 / 3.0, tables=_NO_TABLEAU, entry=advance_entry)


__all__ = ["Bdf2"]
