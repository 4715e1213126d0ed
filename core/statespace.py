"""State-space models of the declared inputs and outputs, as python-control objects.

With the state [dq, dq'] (deviations from the configuration of the linear model):

    A = [[0, I], [-M0^-1 K, -M0^-1 C0]]     B = [[0], [M0^-1 DF^T b]]
    C = [[DF_y, 0]] for positions, [[0, DF_y]] for velocities,  D = 0

where b holds a unit force on the coordinate of each input (SPACAR's INPUTF) and DF_y the rows
of DF of each output coordinate (OUTX). Units: inputs N (N m), outputs m, m/s (rad, rad/s).
"""

import numpy as np

from .blas import blas_threads
from .errors import SceneError
from .linearization import linearize


@blas_threads()
def state_space(model, *, linear_model=None):
    """The linearised model as a control.StateSpace with named inputs, outputs and states."""
    import control  # 0.5 s to import (scipy.signal, matplotlib): only where it is used

    if not model.inputs or not model.outputs:
        raise SceneError(
            f"{model.source}: a state-space model needs [inputs] and [outputs]; "
            f"{model.name!r} declares {len(model.inputs)} input(s), {len(model.outputs)} output(s)"
        )
    lin = linear_model or linearize(model)
    n = lin.M0.shape[0]
    DF = lin.DF
    b = np.zeros((model.nx, len(model.inputs)))
    for column, port in enumerate(model.inputs):
        b[port.coordinate, column] = 1.0
    M_inv_K = np.linalg.solve(lin.M0, lin.K)
    M_inv_C = np.linalg.solve(lin.M0, lin.C0)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-M_inv_K, -M_inv_C]])
    B = np.vstack([np.zeros((n, b.shape[1])), np.linalg.solve(lin.M0, DF.T @ b)])
    C = np.zeros((len(model.outputs), 2 * n))
    for row, port in enumerate(model.outputs):
        offset = 0 if port.quantity == "position" else n
        C[row, offset:offset + n] = DF[port.coordinate]
    D = np.zeros((len(model.outputs), len(model.inputs)))
    dofs = model.dof_names
    return control.ss(
        A, B, C, D,
        inputs=[p.name for p in model.inputs],
        outputs=[p.name for p in model.outputs],
        states=[f"{d}" for d in dofs] + [f"{d}_dot" for d in dofs],
        name=model.name,
    )
