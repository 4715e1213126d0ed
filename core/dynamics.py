"""The reduced nonlinear equations of motion on the DOFs, and their tangent.

For DOFs q and velocities qdot the constraints are solved away at every evaluation
(x = F(q) by Newton's method, warm-started from a first-order prediction of the previous
solution; never integrated), and the DOF accelerations follow from

    M_bar(q) qddot = DF^T (f - M (D2F qdot) qdot - g_conv(x, xdot)) - (De_s DF)^T sigma_s

with M_bar = DF^T M DF (kg), f = loads + gravity + B u the nodal forces (N, N m) with the
inputs u on their coordinates, g_conv the velocity-dependent inertia force of the element
masses and sigma_s = S e_s + D edot_s the stress resultants of the stressed deformations.

The tangent used for the integrators' Newton iterations is the model's own linearisation in
the current state: mass M_bar, damping C0 = (De_s DF)^T D (De_s DF) and stiffness K0 + G0,
where G0 is evaluated with the stress resultants of the full dynamic balance (multipliers of
r - M xddot), so that it is exact at rest and a good approximation in motion. For the
first-order state y = [q, qdot]:

    dydot/dy = [[0, I], [-M_bar^-1 (K0 + G0), -M_bar^-1 C0]]
"""

import time
from dataclasses import dataclass

import numpy as np
from scipy.linalg import lapack

from . import assembly
from .assembly import _point_gravity
from .errors import ConvergenceError, SimulationError
from .kinematics import Configuration
from .mechanics import Mechanics


@dataclass
class Evaluation:
    """One evaluation of the equations of motion; arrays in SI units."""

    q: np.ndarray  # (NDOF,)
    qdot: np.ndarray  # (NDOF,)
    qddot: np.ndarray  # (NDOF,)
    x: np.ndarray  # (NX,) coordinates
    xdot: np.ndarray  # (NX,) coordinate velocities
    config: object  # kinematics Configuration
    mass: np.ndarray  # M_bar (NDOF, NDOF)
    coordinate_mass: np.ndarray  # M (NX, NX)
    force_balance: np.ndarray  # r (NX,) without the term M DF qddot
    sigma_c: np.ndarray  # (NE,) constitutive stress resultants
    hessians: list | None  # per group (group, D2e) or None when not needed


class Dynamics:
    """The equations of motion of one model; keeps the kinematic warm start between calls.

    Parameters
    ----------
    model : Model
        The model (its inputs are forces on their coordinates).
    mechanics : Mechanics, optional
        A prebuilt Mechanics of the model.
    """

    def __init__(self, model, *, mechanics=None):
        self.model = model
        self.mech = mechanics or Mechanics(model)
        self.kin = self.mech.kinematics
        self.inertia = self.mech.inertia
        self.ndof = model.declared_dof_count
        self.input_matrix = np.zeros((model.nx, len(model.inputs)))
        for j, port in enumerate(model.inputs):
            self.input_matrix[port.coordinate, j] = 1.0
        self.has_gravity = bool(np.any(model.gravity))
        self.constant_mass = None if self.inertia.groups else np.diag(model.lumped_mass)
        self.constant_force = model.loads.astype(float).copy()
        if self.has_gravity and not self.inertia.groups:
            self.constant_force += self.inertia.gravity_force(model.initial_coordinates)
        self.stressed = self.mech.stressed
        # flat positions of each group's (deformation, coordinate) entries in De (NE, NX)
        nx = model.nx
        self._De_index = [(group, (group.deformation_index[:, :, None] * nx
                                   + group.coordinate_index[:, None, :]).ravel())
                          for group in model.groups]
        self._lumped = np.diag(model.lumped_mass).astype(float)
        self._mass_groups = [(group, Mp, assembly.pair_index(group, nx))
                             for group, Mp in self.inertia.groups]
        # the constraint Jacobian J (free x free) as `Kinematics.constraint_jacobian` builds
        # it, from precomputed flat indices: the unit rows of the DOF coordinates are fixed
        kin = self.kin
        n_def = kin.constraint_rows.size
        self._J_template = kin.constraint_jacobian(np.zeros((len(model.deformation_names),
                                                             model.nx)))
        self._J_take = (kin.constraint_rows[:, None] * model.nx + kin.free[None, :]).ravel()
        self._J_rows = n_def
        self.chord_iterations = 6
        # constraint tolerance relative to the length scale: near round-off, so that the
        # kinematic error stays below the tightest integrator tolerance (rtol 1e-12 on 0.1 m)
        self.tolerance = 1e-14
        # smallest ratio of the LU pivots of the constraint Jacobian before a configuration
        # counts as singular (a well-posed stage: 1e-2 .. 1)
        self.singular_ratio = 1e-6
        self.reset_warm_start()

    # -- kinematics -------------------------------------------------------------------------
    def reset_warm_start(self, x=None):
        """Start the next kinematic solution from x (NX,) (default: the scene's coordinates)."""
        x = self.model.initial_coordinates if x is None else x
        self._x = np.array(x, dtype=float)
        self._q = self.kin.dofs_of(self._x)
        self._DF = None
        self._lu = None
        self._hessians = None

    def solve(self, q):
        """The kinematic Configuration for DOFs q, and the deformation Hessians there.

        Start from the first-order prediction x_prev + DF_prev (q - q_prev); when the
        constraints are then violated by more than the kinematic tolerance, correct with the
        previous constraint Jacobian (chord Newton, converging at a rate of order |dq| / L);
        fall back to full Newton (`Kinematics.solve`) when that does not converge. Typically
        one evaluation of the deformations (at the prediction) and one with their derivatives
        (at the corrected x, whose deformations serve both the convergence test and the
        stored kinematics).
        """
        kin, model = self.kin, self.model
        q = np.array(q, dtype=float)
        if self._DF is None:
            config = kin.solve(q, self._x)
            return self._store(q, config.x)
        x = self._x + self._DF @ (q - self._q)
        tolerance = self.tolerance * kin.length_scale
        free, lu = kin.free, self._lu
        g = kin.residual(x, assembly.deformations(model, x), q)
        if np.abs(g).max() <= tolerance:
            return self._store(q, x)
        for _ in range(self.chord_iterations):
            dx = _lu_solve(lu, g)
            if not np.isfinite(dx).all():
                return self._store(q, x)
            x[free] -= dx
            derivatives = self._deformations_order2(x)
            g = kin.residual(x, derivatives[0], q)
            if np.abs(g).max() <= tolerance or np.abs(dx).max() <= tolerance:
                return self._store(q, x, derivatives)
        return self._store(q, kin.solve(q, x).x)

    def positions(self, q):
        """Coordinates x (NX,) for DOFs q by chord iterations from the stored solution only
        (no derivatives of the deformations); falls back to `solve` when they slow down."""
        if self._DF is None:
            return self.solve(q).x
        kin = self.kin
        q = np.array(q, dtype=float)
        x = self._x + self._DF @ (q - self._q)
        tolerance = self.tolerance * kin.length_scale
        converged = False
        for _ in range(2):
            g = kin.residual(x, assembly.deformations(self.model, x), q)
            if np.max(np.abs(g)) <= tolerance:
                converged = True
                break
            dx = _lu_solve(self._lu, g)
            x[kin.free] -= dx
            if np.max(np.abs(dx)) <= tolerance:
                converged = True
                break
        if not converged or not np.all(np.isfinite(x)):  # slow: refresh DF and the LU
            return self.configuration(q).x
        self._x, self._q = x, q
        return x

    def _store(self, q, x, derivatives=None):
        """First- and second-order kinematics at a solved x; keeps them as the next start.

        derivatives: (e, De, hessians) already evaluated at x, if any."""
        kin, model = self.kin, self.model
        e, De, hessians = derivatives or self._deformations_order2(x)
        J = self._J_template.copy()
        J[: self._J_rows] = De.take(self._J_take).reshape(self._J_rows, J.shape[1])
        lu = _lu_factor(J)
        pivots = np.abs(lu[0].diagonal())
        if not pivots.min() > self.singular_ratio * pivots.max():
            raise ConvergenceError(
                f"kinematics of {model.name!r}: a singular configuration at "
                f"q = {np.array2string(q, precision=6)} (constraint Jacobian pivot ratio "
                f"{pivots.min() / pivots.max():.1e} < {self.singular_ratio:g}): the DOFs "
                "cannot describe the motion through it")
        DF = np.zeros((model.nx, kin.selector.shape[1]))
        DF[kin.free] = _lu_solve(lu, kin.selector)
        config = Configuration(q=q, x=x, e=e, De=De, lu=lu, DF=DF)
        self._x, self._q, self._DF, self._lu = x, q, DF, lu
        self._hessians = hessians
        return config

    def configuration(self, q):
        """Like `solve`, but a failure becomes a SimulationError naming the cause."""
        try:
            return self.solve(q)
        except ConvergenceError as error:
            raise SimulationError(f"constraints cannot be solved: {error}") from None

    # -- equations of motion ------------------------------------------------------------------
    def evaluate(self, q, qdot, u, *, hessians=False):
        """Solve the equations of motion at (q, qdot) with inputs u; an `Evaluation`.

        The deformation Hessians come with every kinematic solution, so the evaluation always
        carries them (`hessians` is accepted for callers that need them)."""
        mech, inertia = self.mech, self.inertia
        config = self.configuration(q)
        x, DF, De = config.x, config.DF, config.De
        xdot = DF @ qdot
        moving = bool(qdot.any())
        hess = self._hessians
        edot = De @ xdot if mech.has_damping else None
        sigma_c = mech.constitutive_stress(config, edot)
        f = self.constant_force.copy()
        if self.has_gravity and inertia.groups:
            f += inertia.gravity_force(x)
        if u is not None and u.size:
            f += self.input_matrix @ u
        M, inertia_force = self._inertia(x, xdot, moving)
        r = f - De.T @ sigma_c
        if moving:
            r -= M @ self._convective_acceleration(config, xdot, hess) + inertia_force
        mass = DF.T @ M @ DF
        _, _, qddot, info = lapack.dgesv(mass, DF.T @ r)
        if info > 0:
            raise SimulationError(
                "the reduced mass matrix M_bar is singular (a DOF without mass)")
        return Evaluation(q=q, qdot=qdot, qddot=qddot, x=x, xdot=xdot, config=config, mass=mass,
                          coordinate_mass=M, force_balance=r, sigma_c=sigma_c, hessians=hess)

    def _convective_acceleration(self, config, xdot, hessians):
        """(D2F qdot) qdot (NX,) for xdot = DF qdot: `Kinematics.convective_acceleration`
        with LAPACK's getrs called directly (scipy's lu_solve costs 9 times more on these
        small systems)."""
        kin = self.kin
        quad = assembly.hessian_quadratic_forms(self.model, hessians, xdot)
        rhs = np.zeros(kin.free.size)
        rhs[: kin.constraint_rows.size] = quad[kin.constraint_rows]
        result = np.zeros(self.model.nx)
        result[kin.free] = -_lu_solve(config.lu, rhs)
        return result

    def _inertia(self, x, xdot, moving):
        """M(x) (NX, NX) and the convective inertia force (NX,) in one pass per group.

        Per element: Dp^T Mp Dp and Dp^T Mp (D2p xdot) xdot as batched matrix products (the
        element arrays are a few entries each: the number of numpy calls sets the time)."""
        if self.constant_mass is not None:
            return self.constant_mass, 0.0
        nx = self.model.nx
        M = self._lumped.copy()
        force = np.zeros(nx)
        for group, Mp, pairs in self._mass_groups:
            points = group.kind.inertia_points(group.local(x), group.reference,
                                               order=2 if moving else 1)
            Dp = points[1]
            DpT_Mp = np.swapaxes(Dp, 1, 2) @ Mp  # (n, m, P)
            M += np.bincount(pairs, weights=(DpT_Mp @ Dp).ravel(),
                             minlength=nx * nx).reshape(nx, nx)
            if moving:
                D2p = points[2]
                n, P, m = Dp.shape
                v = xdot[group.coordinate_index]
                vv = (v[:, :, None] * v[:, None, :]).reshape(n, m * m, 1)
                accel = D2p.reshape(n, P, m * m) @ vv  # (D2p v) v, (n, P, 1)
                force += np.bincount(group.coordinate_index.ravel(),
                                     weights=(DpT_Mp @ accel).ravel(), minlength=nx)
        return M, force

    def _deformations_order2(self, x):
        """e (NE,), De (NE, NX) and per group (group, D2e) in one pass over the elements."""
        model = self.model
        e = np.zeros(len(model.deformation_names))
        De = np.zeros(e.size * model.nx)
        hessians = []
        for group, flat in self._De_index:
            local_e, local_De, D2e = group.kind.deformations(group.local(x), group.reference,
                                                             order=2)
            e[group.deformation_index] = local_e
            # every (deformation, coordinate) pair belongs to one element: plain assignment
            De[flat] = local_De.ravel()
            hessians.append((group, D2e))
        return e, De.reshape(e.size, model.nx), hessians

    def accelerations(self, q, qdot, u):
        """qddot (NDOF,) at (q, qdot) with inputs u (n_inputs,) in N."""
        return self.evaluate(q, qdot, u).qddot

    def tangent(self, q, qdot, u, *, qddot=None):
        """(M_bar, C, K): tangent mass, damping and stiffness (NDOF, NDOF) in the state.

        qddot: the accelerations used in the dynamic balance (default: those of the state);
        IDA passes its own iterate.
        """
        ev = self.evaluate(q, qdot, u, hessians=True)
        return self.tangent_of(ev, qddot)

    def tangent_of(self, ev, qddot=None):
        """The tangent (M_bar, C, K) of an evaluation made with hessians=True."""
        mech, config = self.mech, ev.config
        acc = ev.qddot if qddot is None else qddot
        r_full = ev.force_balance - ev.coordinate_mass @ (config.DF @ acc)
        sigma = mech.stress_resultants(config, r_full, ev.sigma_c)
        K = mech.structural_stiffness(config) + mech.geometric_stiffness(
            config, sigma, 1.0, hessians=ev.hessians)
        C = mech.damping_matrix(config)
        return ev.mass, C, K

    def mechanical_energy(self, q, qdot, u=None):
        """Kinetic plus potential energy (J): 1/2 qdot^T M_bar qdot + 1/2 e_s^T S e_s minus
        the work potential of the constant loads, the inputs u and gravity."""
        config = self.configuration(q)
        x = config.x
        M, _ = self._inertia(x, config.DF @ qdot, False)
        mass = config.DF.T @ M @ config.DF
        e_s = config.e[self.stressed]
        energy = 0.5 * qdot @ mass @ qdot + 0.5 * e_s @ self.mech.S @ e_s
        f = self.model.loads + (self.input_matrix @ u if u is not None and u.size else 0.0)
        energy -= f @ x
        if self.has_gravity:
            energy -= self.model.lumped_mass * self.inertia._translation_gravity(
                self.model.gravity) @ x
            for group, Mp in self.inertia.groups:
                (p,) = group.kind.inertia_points(group.local(x), group.reference, order=0)
                weights = Mp @ _point_gravity(group, self.model.gravity)
                energy -= np.einsum("np,np->", weights, p)
        return float(energy)

    def outputs(self, ev, ports=None):
        """The declared outputs (n_outputs,) of an evaluation: positions m, velocities m/s."""
        ports = self.model.outputs if ports is None else ports
        return np.array([ev.xdot[p.coordinate] if p.quantity == "velocity" else ev.x[p.coordinate]
                         for p in ports])


class FirstOrderSystem:
    """ydot = f(t, y), y = [q - q_ref, qdot], and its Jacobian, for the integrators.

    q_ref (NDOF,) is the reference configuration the state is taken from (the Simulator
    sets it; zeros by default, then y = [q, qdot]). The derivative and the Jacobian do not
    depend on it: d(q - q_ref)/dt = qdot.

    The inputs come from `input_function(t)` (n_inputs,) N. Each evaluation checks that the
    state and the accelerations are finite and raises SimulationError naming the time.
    """

    def __init__(self, dynamics, input_function):
        self.dynamics = dynamics
        self.n = dynamics.ndof
        self.input_function = input_function
        self.q_ref = np.zeros(self.n)
        self.rhs_count = 0
        self.jacobian_count = 0
        self.deadline = None  # time.perf_counter() value past which an evaluation fails

    def _inputs(self, t):
        return self.input_function(t)

    def _evaluate(self, t, y, *, hessians=False):
        n = self.n
        if self.deadline is not None and time.perf_counter() > self.deadline:
            raise SimulationError(f"t = {t:.9g} s: the time limit of the run is over")
        if not np.isfinite(y).all():
            raise SimulationError(f"t = {t:.9g} s: the state became non-finite "
                                  f"({_first_bad(y, self.dynamics.model, n)})")
        try:
            ev = self.dynamics.evaluate(self.q_ref + y[:n], y[n:], self._inputs(t),
                                        hessians=hessians)
        except SimulationError as error:
            raise SimulationError(f"t = {t:.9g} s: {error}") from None
        if not np.isfinite(ev.qddot).all():
            raise SimulationError(f"t = {t:.9g} s: non-finite accelerations (a singular "
                                  "configuration or a non-finite force)")
        return ev

    def rhs(self, t, y, yp):
        """CVODE right-hand side: fills yp = [qdot, qddot]."""
        self.rhs_count += 1
        n = self.n
        ev = self._evaluate(t, y)
        yp[:n] = y[n:]
        yp[n:] = ev.qddot

    def derivative(self, t, y):
        """ydot (2 NDOF,) as a new array."""
        yp = np.empty_like(y)
        self.rhs(t, y, yp)
        return yp

    def jacobian(self, t, y, yp, JJ):
        """CVODE Jacobian: fills every entry of JJ = d ydot / d y from the tangent."""
        self.jacobian_count += 1
        n = self.n
        ev = self._evaluate(t, y, hessians=True)
        mass, C, K = self.dynamics.tangent_of(ev)
        JJ[:, :] = 0.0
        JJ[:n, n:] = np.eye(n)
        # M_bar is regular here: `evaluate` has solved with it (dgesv) or raised
        lu = _lu_factor(mass)
        JJ[n:, :n] = -_lu_solve(lu, K)
        JJ[n:, n:] = -_lu_solve(lu, C)

    def jacobian_matrix(self, t, y):
        """d ydot / d y (2 NDOF, 2 NDOF) as a new array."""
        JJ = np.empty((2 * self.n, 2 * self.n))
        self.jacobian(t, y, None, JJ)
        return JJ

    # -- implicit form for IDA: res = [qp - v, M_bar vp - M_bar qddot(q, v)] -----------------
    def residual(self, t, y, yp, res):
        """IDA residual of the implicit form (fills res)."""
        self.rhs_count += 1
        n = self.n
        ev = self._evaluate(t, y)
        res[:n] = yp[:n] - y[n:]
        res[n:] = ev.mass @ (yp[n:] - ev.qddot)

    def residual_jacobian(self, t, y, yp, res, cj, JJ):
        """IDA Jacobian d res / d y + cj d res / d yp (fills every entry of JJ)."""
        self.jacobian_count += 1
        n = self.n
        ev = self._evaluate(t, y, hessians=True)
        mass, C, K = self.dynamics.tangent_of(ev, yp[n:])
        JJ[:n, :n] = cj * np.eye(n)
        JJ[:n, n:] = -np.eye(n)
        JJ[n:, :n] = K
        JJ[n:, n:] = C + cj * mass


def _lu_factor(matrix):
    """LU factors (lu, piv) as `scipy.linalg.lu_factor` returns them, without its checks
    (a singular matrix is caught by the caller's pivot test)."""
    lu, piv, _ = lapack.dgetrf(matrix)
    return lu, piv


def _lu_solve(lu, b):
    """`scipy.linalg.lu_solve(lu, b)` by LAPACK getrs directly: the same numbers, a ninth of
    the call overhead on these small systems."""
    return lapack.dgetrs(lu[0], lu[1], b)[0]


def _first_bad(y, model, n):
    names = model.dof_names
    i = int(np.flatnonzero(~np.isfinite(y))[0])
    return f"{names[i % n]}{'' if i < n else ' velocity'} = {y[i]}"
