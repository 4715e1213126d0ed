"""The statics' Newton step from the sparse augmented system on the coordinates.

The reduced Newton step of `statics` solves K dq = Q on the DOFs, with

    Q = DF^T r_x,    K = DF^T K_x DF,    K_x = De_s^T S De_s + sum_i sigma_i d2e_i/dx2 - df/dx

(`Mechanics.tangent_stiffness`; r_x the coordinate-space force balance, sigma every
deformation's stress resultant, the reactions J^-T r_x included). On a large model, forming
it is most of an iteration: DF, the solve of J for NDOF right-hand sides, and the dense
product DF^T (K_x DF), 20 and 20 ms of about 90 on the 507-DOF manipulator_reduced. The same
step solves, on the free coordinates, the sparse saddle-point system

    [ K_x     -J_c^T ] [ dx ]   [ r_x     ]
    [ J_c       0    ] [ mu ] = [ 0; dq_p ]

with J_c the rows of the constraint Jacobian J that dx must keep (the rigid deformations,
zero; the prescribed DOFs, their given move dq_p); the free DOFs' step is then dq = J_q dx,
J's rows of those DOFs. Why it is the same: the first row block says K_x dx - r_x lies in
the span of J_c^T, which DF's free columns annihilate (J DF = [0; I], so J_c DF has no
entry in a free DOF's column); the second says dx = DF dq for some dq. So DF^T (K_x DF dq -
r_x) = 0 on the free DOFs: the reduced step, without DF (`Kinematics.configuration` with
first_order=False) and with one sparse LU of NX + NC unknowns (5 ms on the 507-DOF
manipulator, 2657 unknowns). The two steps agree to round-off (tests/test_static_augmented.py:
within 1e-8 of the step's largest entry, measured 5e-11); the equilibria, converged to the
same tolerance on dq, within 1e-10 of each DOF's unit.

The constraint rows are scaled by K_x's largest entry, so that the LU's pivots compare
numbers of one size (N/m against unitless Jacobian entries otherwise); the scaling changes
mu only, which is not used.

Unprojected iterates (Newton on the coordinates and multipliers, sequential quadratic
programming). The step above is Newton's on the whole system r_x - J_c^T mu = 0, g_c(x) = 0
when its second block's right-hand side is -g_c(x), the rigid deformations' residual (zero
at a solved configuration, so the same step there): sigma = sigma_c + J^-T r_x holds the
multipliers, and K_x carries their curvature (sum_i sigma_i d2e_i/dx2 over the rigid
deformations too). So the iterate need not be projected onto the constraints (the
kinematics solved for q from x + dx, three to four sparse LUs of J each, about 10 of 27 ms
of an iteration on manipulator_reduced): `moved` takes x + dx itself, its q read off x (the
DOF coordinates and deformations there), and `solved` projects the converged iterate once
(a correction of the order of the last dx squared). Both iterations converge
quadratically to the same equilibrium (tests/test_static_augmented.py); on the manipulator
report's 21 workspace poses the unprojected one took 207 instead of 260 iterations (two
failed load steps, each then halved, instead of five) at about 21 instead of 27 ms each.
A step made elsewhere (the curvature predictor's, which changes dq after the step) or of
round-off size is projected as before.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError
from ..mechanics.scales import within

if TYPE_CHECKING:  # names for the annotations only
    from ..mechanics.kinematics import Configuration
    from ..mechanics.mechanics import Mechanics


class AugmentedBalance:
    """The statics' Newton step through the sparse augmented system (module docstring), for
    a model on the numpy `Mechanics`' sparse path (`Mechanics.sparse`: by default from
    `kinematics.SPARSE_FROM` free coordinates; a smaller model's when forced, as the tests
    do).

    Parameters
    ----------
    mech : Mechanics
        The model's mechanics, sparse.
    """

    def __init__(self, mech: Mechanics):
        if not mech.sparse:
            raise ValueError(f"the augmented statics need the sparse mechanics; "
                             f"{mech.model.name!r} has {mech.kinematics.free.size} free "
                             "coordinates")
        self.mech, self.model = mech, mech.model
        kin = mech.kinematics
        # J's row of each DOF: the column of the kinematics' right-hand side [0; I]
        dof_rows = np.argmax(kin.selector, axis=0)
        self._free_rows = dof_rows[self.model.free_dofs]
        self._held_rows = np.concatenate([np.arange(kin.n_rigid),
                                          dof_rows[self.model.prescribed_dofs]])
        self._rigid = self.model.rigid_deformations
        self._load = (1.0, None, None)
        # (the configuration of the last step, its dx)
        self._step = (None, None)
        self._unprojected = None  # the last iterate `moved` did not project

    def set_load(self, load_factor: float, loads: np.ndarray | None = None,
                 values: np.ndarray | None = None) -> None:
        """The load factor (unitless), nodal loads (NX,) N and port values (n_inputs,) N,
        N m of the next steps."""
        self._load = (load_factor, loads, values)

    def free_step(self, config: Configuration, dq: np.ndarray) -> np.ndarray:
        """Newton's step on the free DOFs at config.

        Parameters
        ----------
        config : Configuration
            A solved configuration (its DF is not read).
        dq : ndarray (NDOF,)
            The step, read on the prescribed DOFs only (their given move, m or rad).

        Returns
        -------
        ndarray (n_free_dofs,)
            The free DOFs' step, m or rad.

        Raises
        ------
        ConvergenceError
            The augmented system, and so the tangent stiffness, is singular.
        """
        from scipy.sparse import bmat, csr_matrix
        from scipy.sparse.linalg import splu

        mech, kin = self.mech, self.mech.kinematics
        free = kin.free
        load_factor, loads, values = self._load
        sigma_c = mech.constitutive_stress(config)
        r_x = mech.external_force(config.x, load_factor, loads, values) - config.De.T @ sigma_c
        sigma = mech.stress_resultants(config, r_x, sigma_c)
        stiffness = mech.coordinate_stiffness(config, sigma)
        load = mech.load_stiffness(config.x, load_factor, values)
        if load is not None:
            stiffness = stiffness - csr_matrix(load)
        stiffness = stiffness.tocsr()[free][:, free]
        scale = np.max(np.abs(stiffness.data), initial=0.0) or 1.0
        J = config.lu.matrix  # dense below the kinematics' SPARSE_FROM (a forced sparse
        J = csr_matrix(J) if isinstance(J, np.ndarray) else J.tocsr()  # Mechanics)
        held = scale * J[self._held_rows]
        system = bmat([[stiffness, -held.T], [held, None]], format="csc")
        # -g_c: the rigid deformations' residual at an unprojected iterate; at a projected
        # configuration it is the kinematics' round-off, and zero is the step it aims at
        residual = (-scale * config.e[self._rigid] if self.is_unprojected(config)
                    else np.zeros(kin.n_rigid))
        rhs = np.concatenate([r_x[free], residual, scale * dq[self.model.prescribed_dofs]])
        try:
            dx = splu(system).solve(rhs)[: free.size]
        except RuntimeError:  # "Factor is exactly singular"
            raise ConvergenceError("the tangent stiffness is singular") from None
        step = J[self._free_rows] @ dx
        self._step = (config, dx)
        return step

    def moved(self, config: Configuration, q: np.ndarray, *,
              as_stepped: bool = False) -> Configuration:
        """The next iterate at DOFs q (m, rad), without DF.

        Where the last step was made at config and the caller says q is config's DOFs plus
        that step unchanged (as_stepped): unprojected (module docstring), x + dx with the
        deformations and J there, its q the DOF coordinates and deformations at x + dx.
        Otherwise (the curvature predictor's step, a step of round-off size): projected,
        the kinematics solved for q from config's coordinates moved by dx (if the step was
        made at config), as `project` does. The caller says so rather than this method
        comparing q with config.q + step: dx is the step's coordinates only when the two
        are the same step, which a float comparison would decide only through how the
        caller happened to round its sum.

        Raises
        ------
        ConvergenceError
            x + dx lies where the deformations are not finite (a step far beyond the
            model's reach), or the kinematics of a projected iterate fail.
        """
        kin, model = self.mech.kinematics, self.model
        made_at, dx = self._step
        free = model.free_dofs
        if (not as_stepped or made_at is not config or not np.all(np.isfinite(dx))
                or within(dx, kin.step_tolerance, magnitudes=config.x[kin.free])):
            return self.project(config, q)
        x = config.x.copy()
        x[kin.free] += dx
        with np.errstate(over="ignore", invalid="ignore"):
            moved = kin.configuration(q, x, first_order=False)
        if not np.all(np.isfinite(moved.e)):
            raise ConvergenceError("a Newton step left the model's reach (deformations not "
                                   "finite)")
        # the free DOFs read off x + dx; the prescribed ones keep their given values (x + dx
        # has them to round-off: the step's constraint rows are linear in them)
        moved.q = np.array(q, dtype=float)
        moved.q[free] = np.concatenate([x[model.dof_coordinates],
                                        moved.e[model.dof_deformations]])[free]
        self._unprojected = moved
        return moved

    def project(self, config: Configuration, q: np.ndarray) -> Configuration:
        """The configuration at DOFs q (m, rad), without DF, its kinematics solved from
        config's coordinates moved by the last step's dx, where that step was made at
        config and moves some coordinate by more than the kinematics' step tolerance.

        dx = DF dq to first order, so the kinematics' Newton starts a first-order step
        closer to its solution: 118 instead of 158 of its iterations in a two-step solve of
        manipulator_reduced (30 Newton iterations of the statics). A smaller dx (the one
        step of an unloaded model, round-off) is no move worth making: the kinematics start
        at config's coordinates, as they would without it."""
        kin = self.mech.kinematics
        start = config.x.copy()
        made_at, dx = self._step
        if (made_at is config and np.all(np.isfinite(dx))
                and not within(dx, kin.step_tolerance, magnitudes=start[kin.free])):
            start[kin.free] += dx
        return kin.solve(q, start, first_order=False)

    def is_unprojected(self, config: Configuration) -> bool:
        """Whether config is the last iterate `moved` left unprojected."""
        return config is self._unprojected

    def solved(self, config: Configuration) -> Configuration:
        """config, as the statics report it: an unprojected iterate projected (the
        kinematics solved for its q from its coordinates: the constraints' residual is of
        the order of the last step squared); its DF formed by `static_equilibrium` at the
        end."""
        if self.is_unprojected(config):
            return self.mech.kinematics.solve(config.q, config.x, first_order=False)
        return config
