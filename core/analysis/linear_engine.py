"""The linearisation through the compiled engine: M0, C0 and K0 + G0 at a static equilibrium.

At a static equilibrium (q, qdot = 0, qddot = 0) the engine's own operations give the
matrices of `linearization` (its docstring has the equations):

- OP_ACCELERATIONS at (q, qdot = 0), in the reduced form, solves the kinematics and forms r =
  f - De^T sigma_c (no damping force: edot = 0, and no convective term at rest);
- OP_TANGENT at qddot = 0 forms K0 + G0 (slot stiffness) with the stress resultants sigma_c
  plus the multipliers of the dynamic balance J^-T (r - M DF qddot) = J^-T r, which at
  qddot = 0 are those of the static balance; C0 = DeF_s^T D DeF_s (slot damping); and,
  through OP_MASS, M0 = DF^T M DF (slot mass) and DF (slot DF).

K0 alone, which `LinearModel` keeps apart from G0 (`reduction` asks whether G0 vanishes), is
DeF_s^T S DeF_s with DeF = De DF from the solution's De (the numpy kinematics' at the same
coordinates) and the engine's DF, and the packed S (sparse products, NDOF^2 per stressed
deformation's entries), and G0 = (K0 + G0) - K0 (round-off of |K| in G0, 1e-16 of it).

The load. A StaticSolution does not say which loads hold it (`static_equilibrium`'s `loads`
may differ from the model's), but its stress resultants do: at an equilibrium the generalised
force on the free coordinates is De^T sigma (sigma with the multipliers of the constraint
rows; the DOF rows' multipliers are Q, zero there). The engine is given those free
coordinates' nodal loads, De^T sigma minus the gravity and the held inputs' forces it adds
itself at x (`Mechanics.external_force` of no loads), so its r is De_c^T lambda_c and its
multipliers J^-T r are the solution's own, the same stress resultants that the numpy
reference (`Mechanics.geometric_stiffness`) weighs the Hessians with. Under the model's
own loads the two agree, as J^-T r of the static balance is the solution's multipliers
(tests/test_linear_engine.py checks K against the statics' balance, `EngineBalance`, under the
loads themselves).

The packed model is the statics' (`static_engine.engine_balance`: one per live model, in
the reduced form, inputs as plain force inputs, which is what the linearisation wants: an
actuator's force at rest is its port value; the coil enters `LinearModel.state_matrices`
from the model). Its damping is switched off for the statics (at rest D edot = 0); it is
switched on for the tangent here and off again, and so is M_bar, which the statics' own
evaluation leaves out (`dims.static`, `static_engine`), so that the statics' later calls see
their packed model as they left it; the load is the statics' to set anew (`set_load`) at
its next solve.

The input and output columns of the state space come from the same evaluation
(`engine_port_rows`, OP_PORT_ROWS: `engine.port_entries`): per input b_j^T DF on the DOFs, an
actuator's too (its force column and its coil's back-EMF row), and per output d y / d q, at
the tangent's x and DF.

A model whose statics step sparse (from 240 DOFs, `static_engine.sparse_step`) has no reduced
form packed; it is not packed for the linearisation, which reads the sparse step's packing
instead (`linear_sparse`: the sparse Newton matrix's M, C_x and K_x reduced by DF).

Where the engine does not take a model: what `static_engine.supports` refuses; those take
the numpy path. Gravity on element masses that hang on rotations (a BEAM's consistent mass,
whose tangent points couple to its position points) is in the engine's tangent
(`engine.gravity_stiffness`: its load stiffness, which the numpy reference has as
`Inertia.gravity_stiffness`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import linear_sparse, static_engine

if TYPE_CHECKING:  # names for the annotations only
    from ..mechanics.mechanics import Mechanics
    from ..model import Model
    from .statics import StaticSolution


def supports(model: Model, mechanics: Mechanics) -> bool:
    """Whether the engine linearises `model`: its statics' engine takes it
    (`static_engine.supports`). `mechanics` is `preferred`'s, which the callers pass to
    both; the engine's answer does not depend on it."""
    return static_engine.supports(model)


def preferred(model: Model, mechanics: Mechanics) -> bool:
    """Whether the engine is the default path of the linearisation of `model`: where the
    statics prefer it (`static_engine.preferred`) and have packed it (`packed`: a loaded
    equilibrium, which they solved through the engine). The linearisation then costs two
    operations on that packed model (0.006 s against the numpy path's 0.029 s on
    manipulator_control), or, where the statics step sparse (from 240 DOFs), the sparse
    Newton matrix's M, C_x and K_x reduced by T (`linear_sparse`: 0.19 of numpy's CPU on
    the 816-DOF manipulator, 0.43 on manipulator_reduced, 0.67 and 0.77 on the cantilevers of
    288 and 384 DOFs; docs/benchmarks.md, session 37). Packing the engine for one
    linearisation costs more than it saves on every model of the statics' window: the
    engine with its packing (the engine imported) took 1.9 to 2.0 times numpy's CPU on the
    three 75-DOF manipulators (42 against 21 ms) and 2.7 times on the spatial BEAM
    cantilevers of 258 and 300 DOFs (docs/benchmarks.md, 2026-12-01), so an unloaded model,
    whose statics took the numpy path, is linearised there too."""
    return static_engine.preferred(model) and packed(model) and supports(model, mechanics)


def packed(model: Model) -> bool:
    """Whether the statics' packed engine model of `model` is live and the linearisation
    reads it: the reduced form (`static_engine.live_balance`), or the sparse step's
    augmented one (`static_engine.live_step`)."""
    return (static_engine.live_balance(model) is not None
            or static_engine.live_step(model) is not None)


def _sparse_route(balance) -> bool:
    """Whether the linearisation reads `balance`'s sparse step packing (`linear_sparse`):
    it steps sparse and its reduced form is not packed (which is then not packed for it)."""
    return balance.sparse and not balance.packed_dense


def engine_matrices(model: Model, solution: StaticSolution, mechanics: Mechanics,
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """M0, C0, K0 and G0 (NDOF, NDOF) of `model` at `solution`, through the engine (module
    docstring); with kinematic inputs on every DOF (the caller drops the prescribed ones).

    Parameters
    ----------
    model : Model
        A model the engine takes (`supports`).
    solution : StaticSolution
        The configuration and its stress resultants (N), at a load factor of 1.
    mechanics : Mechanics
        The model's mechanics (its gravity and input forces at x).

    Returns
    -------
    (M0, C0, K0, G0)
        kg, N s/m, N/m, N/m in the DOF units (m, rad).

    Raises
    ------
    ConvergenceError
        The engine could not solve the kinematics at the solution's DOFs.
    """

    balance = static_engine.engine_balance(model)
    config, values = solution.config, solution.port_values
    # the free coordinates' nodal loads that hold the solution (module docstring)
    held = np.asarray(config.De.T @ solution.stress_resultants).ravel()
    held -= mechanics.external_force(config.x, 1.0, np.zeros(model.nx), values)
    loads = np.zeros(model.nx)
    free = model.free_coordinates
    loads[free] = held[free]
    if _sparse_route(balance):
        return linear_sparse.matrices(model, solution, balance, loads)
    data = balance.data
    balance.set_load(1.0, loads, values)
    # the evaluation forms M_bar, which M0 is, and C0 where the model has damping
    with data.evaluating(damping=np.any(data.float_array("D")), static=False):
        _, K = balance.residual_and_tangent(config)
        n = model.ndof
        M0 = data.float_array("mass").reshape(n, n).copy()
        C0 = data.float_array("damping").reshape(n, n).copy()
        DF = data.float_array("DF").reshape(-1, n).copy()
    K0 = linear_sparse.structural(data, config.De, DF)
    return M0, C0, K0, K - K0


def engine_port_rows(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """The inputs' rows b_j^T DF (n_inputs, NDOF; N per unit input on each DOF, the port's
    velocity per DOF velocity) and the outputs' rows d y / d q (n_outputs, NDOF; m/m, rad/rad
    and so on, a rate output's per rate of q) of `model` at the last evaluation of its
    statics' packed model, through OP_PORT_ROWS (module docstring): call it right after
    `engine_matrices`, whose tangent is that evaluation. With kinematic inputs on every DOF
    (the caller drops the prescribed ones)."""
    from ..engine.port_entries import port_rows
    from ..mechanics.output_quantities import output_order

    balance = static_engine.engine_balance(model)
    if _sparse_route(balance):
        return linear_sparse.port_rows(model, balance)
    data = balance.data
    return port_rows(data, model.outputs, [output_order(port) for port in model.outputs])
