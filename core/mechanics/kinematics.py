"""Kinematics: the dependent coordinates for given DOFs, and the transfer functions DF, D2F.

For DOF values q the coordinates x = F(q) solve, on the free (non-fixed) coordinates,

    e_o(x) = 0          every deformation prescribed zero
    e_m(x) = q_e        every DOF deformation
    x_m    = q_x        every DOF coordinate

a square system whose Jacobian J is regular exactly when the model is exactly constrained.
Newton's method, warm-started from the previous solution, converges quadratically; it stops
when every unknown's correction is within `tolerance` of its own unit (lengths of the
model's length scale, rotations and Euler parameters of 1), with a floor 8 eps of its
magnitude (`scales`).

First order: DF = dx/dq solves J DF = [0; I].  Second order: with the constraint Hessians
H_i = d2 g_i / dx2, (D2F qdot) qdot = -J^-1 [ (DF qdot)^T H_i (DF qdot) ]_i.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError
from . import assembly
from .scales import kinematic_tolerances, length_scale, within

if TYPE_CHECKING:  # names for the annotations only
    from ..model import ElementGroup, Model

    # the constraint Hessians of `assembly.deformation_hessians`: (group, D2e (n, k, m, m))
    Hessians = list[tuple[ElementGroup, np.ndarray]]

# From this many free coordinates on, J is factored as a sparse matrix (SuperLU): a deformation
# depends on at most 14 coordinates, so a large J is almost empty and its dense LU (O(n^3))
# dominates a static solve. Below it, the dense LU is faster than the sparse bookkeeping.
SPARSE_FROM = 300


class JacobianFactor:
    """The constraint Jacobian J for solves, dense or sparse by its size (sparse: its LU
    factors, kept); `solve` solves J z = b (or J^T z = b) for one or more right-hand sides.
    Singular: solve gives non-finite values, as LAPACK's dense LU does."""

    def __init__(self, J):
        self.size = J.shape[0]
        self.sparse = not isinstance(J, np.ndarray)  # scipy.sparse's, imported by who made it
        self.matrix = J  # J itself (CSC where sparse): the augmented statics build on it
        if self.sparse:
            from scipy.sparse.linalg import splu

            J = J.tocsc()
            try:
                # SuperLU would factor non-finite entries into garbage (and BLAS complaints)
                self.lu = splu(J) if np.all(np.isfinite(J.data)) else None
            except RuntimeError:  # "Factor is exactly singular"
                self.lu = None
        # below SPARSE_FROM no factors are kept: numpy's solve (LAPACK's LU with partial
        # pivoting, gesv) factors `matrix` at each solve (see `solve`)

    def solve(self, b, *, transposed=False):
        """J^-1 b (or J^-T b); b (n,) or (n, k)."""
        if self.sparse:
            if self.lu is None:
                return np.full(np.shape(b), np.nan)
            return self.lu.solve(np.asarray(b, dtype=float), trans="T" if transposed else "N")
        # numpy factors J again at each solve (a few per configuration, O(n^3) at n < 300),
        # where scipy.linalg's kept factors would cost a short command its import (0.12 to
        # 0.15 s of CPU, a quarter of `flexure analyze` on a small scene)
        with np.errstate(all="ignore"):
            try:
                return np.linalg.solve(self.matrix.T if transposed else self.matrix, b)
            except np.linalg.LinAlgError:  # exactly singular: as LAPACK's LU, no finite answer
                return np.full(np.shape(b), np.nan)


@dataclass
class Configuration:
    """A solved configuration: coordinates, deformations and first-order kinematics."""

    q: np.ndarray  # (NDOF,) DOF values
    x: np.ndarray  # (NX,) coordinates
    e: np.ndarray  # (NE,) deformations
    De: np.ndarray  # (NE, NX) deformation Jacobian (CSR where DF is None on the sparse path)
    lu: JacobianFactor  # LU factors of the constraint Jacobian J (free x free)
    DF: np.ndarray | None  # (NX, NDOF) first-order transfer function; None: not formed


class Kinematics:
    """Solves a model's constraints; one instance per model, reused across evaluations.

    The methods share their arguments' meanings and units: q (NDOF,) the DOF values, the DOF
    coordinates first, then the DOF deformations (m or rad); x (NX,) the coordinates (m and
    rad, Euler parameters unitless); e (NE,) their deformations (m); De (NE, NX) the
    deformation Jacobian de/dx (m/m, m/rad); config a solved `Configuration`; hessians, where
    a method takes them, the deformation Hessians at config.x
    (`assembly.deformation_hessians`), passed when the caller has them already and computed
    otherwise.

    Parameters
    ----------
    model : Model
    tolerance : float
        Newton stops when every correction is within `tolerance` of its own unit
        (relative: m through the length scale, Euler parameters and rad through 1;
        `scales.kinematic_tolerances`).
    max_iterations : int
        Newton iterations before ConvergenceError.
    """

    def __init__(self, model: Model, *, tolerance: float = 1e-12,
                 max_iterations: int = 30) -> None:
        self.model = model
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.free = model.free_coordinates
        self.constraint_rows = np.concatenate([model.rigid_deformations, model.dof_deformations])
        self.n_rigid = model.rigid_deformations.size
        self.dof_positions = np.searchsorted(self.free, model.dof_coordinates)
        self.length_scale = length_scale(model)
        # per residual row and per unknown, in their own units (m, rad, unitless)
        self.row_tolerance, self.step_tolerance = kinematic_tolerances(
            model, tolerance, rows=self.constraint_rows, free=self.free)
        self._pattern = None  # the sparse J's entries, found on first use (`factor`)
        n_free, ndof = self.free.size, model.declared_dof_count
        # Right-hand side [0; I] of J DF = [0; I]: the rows of J are (rigid deformations, DOF
        # deformations, DOF coordinates) while q lists the DOF coordinates first.
        n_xdof, n_edof = model.dof_coordinates.size, model.dof_deformations.size
        self.selector = np.zeros((max(n_free, self.n_rigid + ndof), ndof))
        self.selector[self.n_rigid + np.arange(n_edof), n_xdof + np.arange(n_edof)] = 1.0
        self.selector[self.n_rigid + n_edof + np.arange(n_xdof), np.arange(n_xdof)] = 1.0
        self.selector = self.selector[:n_free]  # J is square only in an exactly counted model

    def dofs_of(self, x: np.ndarray) -> np.ndarray:
        """The DOF values of coordinates x: the DOF coordinates, then the DOF deformations.

        Parameters
        ----------
        x : ndarray (NX,)

        Returns
        -------
        ndarray (NDOF,)
            q, m or rad.
        """
        e = assembly.deformations(self.model, x)
        return np.concatenate([x[self.model.dof_coordinates], e[self.model.dof_deformations]])

    def constraint_jacobian(self, De: np.ndarray) -> np.ndarray:
        """The dense constraint Jacobian J on the free coordinates: the rows of the rigid and
        DOF deformations, then unit rows of the DOF coordinates.

        Parameters
        ----------
        De : ndarray (NE, NX)

        Returns
        -------
        ndarray (n_free, n_free)
            J, in the units of De.
        """
        J = np.zeros((self.free.size, self.free.size))
        n_def = self.constraint_rows.size
        J[:n_def] = De[np.ix_(self.constraint_rows, self.free)]
        J[n_def + np.arange(self.dof_positions.size), self.dof_positions] = 1.0
        return J

    def factor(self, De: np.ndarray) -> JacobianFactor:
        """The LU factors of J at the deformation Jacobian De: sparse from SPARSE_FROM free
        coordinates on (its pattern, the elements' coordinates, is the same at every x).

        Parameters
        ----------
        De : ndarray (NE, NX)

        Returns
        -------
        JacobianFactor
            Whose `solve` gives non-finite values where J is singular.
        """
        if self.free.size < SPARSE_FROM:
            return JacobianFactor(self.constraint_jacobian(De))
        source_rows, source_columns = self._sparse_entries()[:2]
        return self._sparse_factor(De[source_rows, source_columns])

    def _sparse_entries(self):
        """`_sparse_pattern`, found once."""
        if self._pattern is None:
            self._pattern = self._sparse_pattern()
        return self._pattern

    def _sparse_factor(self, values):
        """The sparse J's factors from its entries taken from De, `_sparse_entries`' order."""
        rows, columns = self._pattern[2:4]
        n_def = self.constraint_rows.size
        data = np.concatenate([values, np.ones(self.dof_positions.size)])
        rows = np.concatenate([rows, n_def + np.arange(self.dof_positions.size)])
        columns = np.concatenate([columns, self.dof_positions])
        from scipy.sparse import csc_matrix  # only for large models: 0.05 s to import

        return JacobianFactor(csc_matrix((data, (rows, columns)),
                                         shape=(self.free.size, self.free.size)))

    def _element_jacobian(self, x, *, sparse_De=False):
        """(e (NE,), the factors of J, De as a CSR matrix or None) at x, without the dense
        De: J's entries taken from the elements' own blocks (the same numbers as from De, in
        the same places). The Newton iterations of a large model's kinematics need no more,
        and forming and filling the (NE, NX) De took 4 of its 6.5 ms on the 507-DOF
        manipulator."""
        e = np.zeros(len(self.model.deformation_names))
        blocks = []
        for group in self.model.groups:
            local_e, local_De = group.kind.deformations(group.local(x), group.reference,
                                                        order=1)
            e[group.deformation_index] = local_e
            blocks.append(np.ravel(local_De))
        _, _, _, _, keep, all_rows, all_columns = self._sparse_entries()
        values = np.concatenate(blocks) if blocks else np.zeros(0)
        De = None
        if sparse_De:
            from scipy.sparse import csr_matrix

            De = csr_matrix((values, (all_rows, all_columns)), shape=(e.size, self.model.nx))
        return e, self._sparse_factor(values[keep]), De

    def _sparse_pattern(self):
        """(De rows, De columns, J rows, J columns) of every entry J takes from De; then
        which of the elements' (deformation, coordinate) pairs, in the order of their
        blocks (`_element_jacobian`), these are (a mask), and those pairs' rows and
        columns of De."""
        row_of = np.full(len(self.model.deformation_names), -1)
        row_of[self.constraint_rows] = np.arange(self.constraint_rows.size)
        column_of = np.full(self.model.nx, -1)
        column_of[self.free] = np.arange(self.free.size)
        pairs = [np.broadcast_arrays(group.deformation_index[:, :, None],
                                     group.coordinate_index[:, None, :])
                 for group in self.model.groups]
        source_rows = np.concatenate([d.ravel() for d, _ in pairs])
        source_columns = np.concatenate([c.ravel() for _, c in pairs])
        keep = (row_of[source_rows] >= 0) & (column_of[source_columns] >= 0)
        all_rows, all_columns = source_rows, source_columns
        source_rows, source_columns = source_rows[keep], source_columns[keep]
        return (source_rows, source_columns, row_of[source_rows], column_of[source_columns],
                keep, all_rows, all_columns)

    def residual(self, x: np.ndarray, e: np.ndarray, q: np.ndarray) -> np.ndarray:
        """The constraint residual g: the rigid deformations, the DOF deformations minus
        their DOF values, the DOF coordinates minus theirs.

        Parameters
        ----------
        x : ndarray (NX,)
        e : ndarray (NE,)
        q : ndarray (NDOF,)

        Returns
        -------
        ndarray (n_free,)
            g, m (rad on a DOF angle).
        """
        model = self.model
        n_xdof = model.dof_coordinates.size
        return np.concatenate([
            e[model.rigid_deformations],
            e[model.dof_deformations] - q[n_xdof:],
            x[model.dof_coordinates] - q[:n_xdof],
        ])

    def solve(self, q: np.ndarray, x_start: np.ndarray, *,
              first_order: bool = True) -> Configuration:
        """The configuration for DOFs q, by Newton's method on the constraints.

        Parameters
        ----------
        q : ndarray (NDOF,)
        x_start : ndarray (NX,)
            The coordinates to start from (m, rad), e.g. the previous solution.
        first_order : bool
            Form DF (False: its DF is None; `configuration`).

        Returns
        -------
        Configuration
            x, e, De, the factors of J and DF at q.

        Raises
        ------
        ConvergenceError
            The constraints cannot be solved (J singular, or Newton does not converge:
            beyond the mechanism's reach or at a singular configuration).
        """
        x = np.array(x_start, dtype=float)
        for _ in range(self.max_iterations):
            # A singular J, or Newton running away from a configuration it cannot reach (x
            # overflowing on the way), is answered below with a ConvergenceError of our own.
            with np.errstate(over="ignore", invalid="ignore"):
                if self.free.size < SPARSE_FROM:
                    e, De = assembly.deformation_jacobian(self.model, x)
                    lu = self.factor(De)
                else:
                    e, lu, _ = self._element_jacobian(x)
                g = self.residual(x, e, q)
                dx = lu.solve(g)
            if not np.all(np.isfinite(dx)):
                raise ConvergenceError(
                    f"kinematics of {self.model.name!r}: the constraint Jacobian is singular "
                    f"at q = {np.array2string(q, precision=6)} (a singular configuration)"
                )
            x[self.free] -= dx
            # on the step alone, always one step past a small residual: the reference for
            # the engine, which stops on either, is as accurate as Newton gets
            if within(dx, self.step_tolerance, magnitudes=x[self.free]):
                break
        else:
            worst = np.max(np.abs(dx) / self.step_tolerance)
            raise ConvergenceError(
                f"kinematics of {self.model.name!r}: Newton did not converge in "
                f"{self.max_iterations} iterations at q = {np.array2string(q, precision=6)} "
                f"(last correction {worst:.3e} times its tolerance): these DOF values lie "
                "beyond the reach of the mechanism or at a singular configuration"
            )
        return self.configuration(q, x, first_order=first_order)

    def configuration(self, q: np.ndarray, x: np.ndarray, *,
                      first_order: bool = True) -> Configuration:
        """First-order kinematics at coordinates x that satisfy the constraints for q.

        Parameters
        ----------
        q : ndarray (NDOF,)
        x : ndarray (NX,)
            Coordinates that satisfy the constraints for q (m, rad); not checked.
        first_order : bool
            Form DF (False: DF is None; its solve for NDOF right-hand sides is most of a
            large model's configuration, 20 of 30 ms on the 507-DOF manipulator; and on the
            sparse path (SPARSE_FROM free coordinates) De is a scipy.sparse CSR matrix,
            with the elements' entries, explicit zeros kept).

        Returns
        -------
        Configuration
            With e, De, the factors of J and DF = dx/dq (NX, NDOF).
        """
        if not first_order and self.free.size >= SPARSE_FROM:
            e, lu, De = self._element_jacobian(x, sparse_De=True)
            return Configuration(q=np.asarray(q, float), x=x, e=e, De=De, lu=lu, DF=None)
        e, De = assembly.deformation_jacobian(self.model, x)
        lu = self.factor(De)
        DF = None
        if first_order:
            DF = np.zeros((self.model.nx, self.selector.shape[1]))
            DF[self.free] = lu.solve(self.selector)
        return Configuration(q=np.asarray(q, float), x=x, e=e, De=De, lu=lu, DF=DF)

    def convective_acceleration(self, config: Configuration, qdot: np.ndarray,
                                hessians: Hessians | None = None) -> np.ndarray:
        """(D2F qdot) qdot: the coordinate acceleration at zero DOF acceleration.

        Parameters
        ----------
        config : Configuration
        qdot : ndarray (NDOF,)
            The DOF velocities, m/s or rad/s.
        hessians : list of (ElementGroup, ndarray), optional

        Returns
        -------
        ndarray (NX,)
            m/s^2 or rad/s^2 (1/s^2 on Euler parameters).
        """
        if hessians is None:
            hessians = assembly.deformation_hessians(self.model, config.x)
        xdot = config.DF @ qdot
        quad = assembly.hessian_quadratic_forms(self.model, hessians, xdot)
        rhs = np.zeros(self.free.size)
        rhs[: self.constraint_rows.size] = quad[self.constraint_rows]
        result = np.zeros(self.model.nx)
        result[self.free] = -config.lu.solve(rhs)
        return result

    def second_order(self, config: Configuration,
                     hessians: Hessians | None = None) -> np.ndarray:
        """The second-order transfer function D2F = d2x / dq_j dq_k.

        Parameters
        ----------
        config : Configuration
        hessians : list of (ElementGroup, ndarray), optional

        Returns
        -------
        ndarray (NX, NDOF, NDOF)
            In coordinate units per DOF unit squared (1/m, m/rad^2, ...).
        """
        if hessians is None:
            hessians = assembly.deformation_hessians(self.model, config.x)
        ndof = config.DF.shape[1]
        rhs = np.zeros((self.free.size, ndof, ndof))
        for group, D2e in hessians:
            local = config.DF[group.coordinate_index]  # (n, m, ndof)
            forms = np.einsum("nkij,nir,njs->nkrs", D2e, local, local)
            rows = _positions(self.constraint_rows, group.deformation_index)
            mask = rows >= 0
            rhs[rows[mask]] = forms[mask]
        D2F = np.zeros((self.model.nx, ndof, ndof))
        solved = config.lu.solve(rhs.reshape(self.free.size, -1))
        D2F[self.free] = -solved.reshape(self.free.size, ndof, ndof)
        return D2F

    def multipliers(self, config: Configuration, generalized_force: np.ndarray) -> np.ndarray:
        """lambda = J^-T r on the free coordinates, for a coordinate-space force r.

        The entries of rigid deformations are their stress resultants (reaction forces);
        those of the DOFs are the unbalanced generalised forces DF^T r.

        Parameters
        ----------
        config : Configuration
        generalized_force : ndarray (NX,)
            r, N (N m on rotations).

        Returns
        -------
        ndarray (n_free,)
            N for the deformation rows (every deformation is a length); N or N m for the
            DOF coordinates.
        """
        return config.lu.solve(generalized_force[self.free], transposed=True)


def _positions(order, values):
    """Position of each value in `order`, or -1 where absent."""
    lookup = np.full(max(order.max(initial=-1), values.max(initial=-1)) + 1, -1)
    lookup[order] = np.arange(order.size)
    return lookup[values]
