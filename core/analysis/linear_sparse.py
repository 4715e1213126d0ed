"""The linearisation through the engine's sparse Newton matrix, for models whose statics step
sparse (`static_engine.sparse_step`: from 240 DOFs), without packing the reduced form.

A balance that steps on the sparse saddle-point system has its model packed in the augmented
form, with the ESDIRK's sparse Newton matrix (`engine.newton`). OP_NEWTON_JACOBIAN at the
state y = [q; 0] (the equilibrium's DOFs, at rest) evaluates the model there and assembles, by
the Newton matrix's own element kernels, on the pattern of H over the free coordinates (with
rigid clusters the reduced ones z, the slaves' mass and curvature folded into their masters):

    M      the mass (kg, kg m^2 on rotation parameters)
    C_x    = De_s^T D De_s, the damping (N s/m)
    K_x    = De_s^T S De_s + sum_i sigma_i D2e_i - df/dx, the tangent at rest (N/m)

with sigma the stress resultants of the dynamic balance at rest, sigma_c plus J^-T (r - M
xddot), which at the equilibrium (xddot = 0 to the statics' residual) are the static ones, as
`linear_engine`'s OP_TANGENT at qddot = 0 has them (the load that `linear_engine` writes makes
r the solution's own De_c^T lambda_c). On the DOFs, with T = DF on the same coordinates
(x_free = T q to first order; the solution's DF, rows `free`):

    M0 = T^T M T,   C0 = T^T C_x T,   K0 + G0 = T^T K_x T,

the reduced matrices of `linear_engine` (M0 = DF^T M DF: T_rigid^T M T_rigid is M_z). K0 alone
is DeF_s^T S DeF_s with DeF = De DF from the solution's De and DF and the packed S
(`structural`), G0 = (K0 + G0) - K0. T is sparse on a model whose DOFs move few coordinates
each (the 816-DOF manipulator's DF is 0.9 % full, manipulator_reduced's 43 %): below
SPARSE_T_BELOW of its entries non-zero the products are sparse ones, else dense.

The input and output rows (`port_rows`): the solution's DF is written into the packing's slot
DF, which its augmented evaluations do not read, and OP_PORT_ROWS runs at the Newton
matrix's evaluation there.

Agreement with the numpy reference (tests/test_linear_sparse.py): M0, C0, K0 and K within
1e-10 of each one's largest entry (measured 2e-16 to 4e-15 on manipulator_reduced and the
816-DOF manipulator under 1 N on every input).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model
    from .static_engine import EngineBalance
    from .statics import StaticSolution

# below this share of non-zero entries in T (the DOFs' columns of DF on H's coordinates) the
# reductions T^T (.) T are sparse products (measured: 0.03 s against 0.6 s dense on the
# 816-DOF manipulator, T 0.9 % full; manipulator_reduced's T, 43 % full, is faster dense)
SPARSE_T_BELOW = 0.1


def matrices(model: Model, solution: StaticSolution, balance: EngineBalance,
             loads: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """M0, C0, K0 and G0 (NDOF, NDOF; kg, N s/m, N/m, N/m in the DOF units) of `model` at
    `solution` from `balance`'s sparse packing (module docstring), under the nodal `loads`
    (NX,; N, N m) that hold the solution with its inputs' port values.

    Raises
    ------
    ConvergenceError
        The engine could not evaluate the model at the solution's DOFs.
    """
    from scipy.sparse import csc_matrix, csr_matrix

    from ..engine import data as ed
    from ..engine import engine
    from ..engine.operations import OP_NEWTON_JACOBIAN
    from ..errors import ConvergenceError
    from ..numerics.sparse_lu_pattern import pattern

    data = balance.step_data
    config = solution.config
    balance.set_load(1.0, loads, solution.port_values)
    y = np.concatenate([np.asarray(config.q, float), np.zeros(model.ndof)])
    with data.evaluating(damping=np.any(data.float_array("D"))):
        status = engine.call(data, OP_NEWTON_JACOBIAN, y)
    if status != ed.OK:
        from ..engine.status import status_message

        raise ConvergenceError(f"linearisation of {model.name!r}: "
                               f"{status_message(status)}")
    parts = data.float_array("newton_parts")
    nnz = parts.size // 3
    _, rows, columns = pattern(data.int_array("newton_h"))
    nf = int(data.int_array("dims")[ed.NFREE])
    block = (rows < nf) & (columns < nf)  # M, C_x, K_x; the rest is J_o beside and below
    rows, columns = rows[block], columns[block]
    DF = config.DF
    data.float_array("DF")[:] = DF.ravel()  # for OP_PORT_ROWS (module docstring)
    T = DF[data.int_array("free")]
    sparse = np.count_nonzero(T) < SPARSE_T_BELOW * T.size
    if sparse:
        T, DF = csr_matrix(T), csr_matrix(DF)

    def reduced(values):
        A = csc_matrix((values[block], (rows, columns)), shape=(nf, nf))
        return (T.T @ (A @ T)).toarray() if sparse else T.T @ np.asarray(A @ T)

    M0, C0, K = (reduced(parts[k * nnz: (k + 1) * nnz]) for k in range(3))
    K0 = structural(data, config.De, DF)
    return M0, C0, K0, K - K0


def structural(data, De, DF) -> np.ndarray:
    """K0 = DeF_s^T S DeF_s (NDOF, NDOF; N/m in the DOF units), DeF = De DF, from a solution's
    De (sparse, (NE, NX)) and DF (NX, NDOF; dense or scipy sparse) and the packed S of `data`
    (compressed rows on the stressed deformations)."""
    from scipy.sparse import csr_matrix, issparse

    stressed = data.int_array("stressed")
    S = csr_matrix((data.float_array("S"), data.int_array("stress_columns"),
                    data.int_array("stress_pointers")), shape=(stressed.size, stressed.size))
    DeF = De[stressed] @ DF
    if issparse(DeF):
        return (DeF.T @ (S @ DeF)).toarray()
    DeF = np.asarray(DeF)
    return DeF.T @ np.asarray(S @ DeF)


def port_rows(model: Model, balance: EngineBalance) -> tuple[np.ndarray, np.ndarray]:
    """The inputs' rows b_j^T DF and the outputs' rows d y / d q (`linear_engine.
    engine_port_rows`' units) at the evaluation of the last `matrices` of `balance`."""
    from ..engine.port_entries import port_rows as rows_of
    from ..mechanics.output_quantities import output_order

    return rows_of(balance.step_data, model.outputs,
                   [output_order(port) for port in model.outputs])
