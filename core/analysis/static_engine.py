"""The static balance and its tangent through the compiled engine, for `statics`' Newton.

At DOFs q (m, rad) and a load factor s, `EngineBalance.residual_and_tangent` returns

    Q(q) = DF^T r,  r = s f(x) - De^T sigma_c          (NDOF,)        N or N m
    K(q) = -dQ/dq = K0 + G0                            (NDOF, NDOF)   N/m, N m/rad (mixed)

with f the loads (nodal forces, gravity on the lumped and the element masses, the held
inputs' port values), from the engine's existing operations at rest: OP_ACCELERATIONS at
(q, qdot = 0), in the reduced form, solves the kinematics and forms DF, r and DF^T r (slot
reduced_force); OP_TANGENT at qddot = 0 forms K0 + G0 with the multipliers of the static
balance J^-T r. These are `Mechanics.static_balance` and `Mechanics.tangent_stiffness` of
the numpy reference to round-off (tests/test_static_engine.py: K within 1e-10 of its
largest entry), the load stiffness of gravity on element masses that hang on rotations
included (a BEAM's consistent mass couples its position points, where gravity acts, to its
tangent points; `engine.gravity_stiffness`: 5e-9 of K's largest entry on a spatial
cantilever under gravity). On every built-in scene the
equilibria of the two paths agree within 1e-10 of each DOF's unit (m through the model's
length scale, rad through 1; measured 5e-15 and below).

The balance owns its packed model (one per live model, kept between calls), packed in the
reduced form, and writes into it what the statics holds fixed: the load per load factor
(slot constant_force: the nodal loads and gravity on the lumped masses; the element groups'
gravity on their inertia points in slot group_data; the inputs' port values in slot inputs,
each s times its full value), every input a plain force input (an actuator's force at rest
is given: `mechanics.actuators.steady_port_values`; no coil), no damping (at rest
D edot = 0, and C0 is not wanted) and dims.static: its evaluation forms DF^T r and neither
M_bar, its LU nor qddot, which the statics does not use (they were a third to nine tenths
of an evaluation, 0.8 of 1.4 ms on manipulator_control, 68 of 91 ms on
manipulator_reduced), and marks M_bar current, so that the tangent, which reads neither,
does not form it. No integrator shares this packed model, so no simulation sees these
writes. Models without mass work alike (no M_bar is factored; SINGULAR_MASS, which the
engine's other forms return for them, is no failure here either).

The kinematics are solved to the engine's tolerance (1e-15 of each row's unit); a
configuration counts as singular only at a zero pivot of J, as in the numpy kinematics
(`singular_ratio=0`), so both paths reach the same configurations.

On a large model (`sparse_step`: from SPARSE_STEP_FROM DOFs) Newton's step dq = K^-1 Q
comes instead from the sparse saddle-point system [K_x s J_o^T; s J_o 0] on the free
coordinates (OP_STATIC_STEP, `engine.static_step`: the ESDIRK's sparse Newton matrix with
the inertia and damping terms absent), without DF and the dense K, in proportion to the
elements: `EngineBalance.free_step`, on a packing of its own in the augmented form (the
one the sparse Newton matrix is packed for), with the same conventions (load per load
factor, no damping, actuators as force inputs, dims.static). It is the dense step to
round-off (tests/test_static_step.py: within 1e-9 of the step's largest entry, measured
2e-13 on manipulator_control to 1.3e-10 on a 384-DOF BEAM cantilever, where numpy's
augmented step differs from the dense one by 5.6e-10). The reduced form, which the dense
tangent and the linearisation read, is then packed only when asked for
(`EngineBalance.data`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError
from ..live_models import PerLiveModel
from ..mechanics.kinematics import SPARSE_FROM

if TYPE_CHECKING:  # names for the annotations only
    from ..mechanics.kinematics import Configuration
    from ..model import Model

_BALANCES = PerLiveModel()  # model -> EngineBalance


@dataclass
class EnginePoint:
    """A Newton iterate of the engine path: DOFs q (NDOF,) m or rad, and its coordinates x
    (NX,) m or rad once solved (None: not yet; its kinematics start from the engine's last
    solution)."""

    q: np.ndarray
    x: np.ndarray | None = None


# Where the engine is the statics' default: every model from ENGINE_MIN_FREE free
# coordinates up (measured: one static solve's CPU, engine over numpy, in one process, the
# balance packed, alternating, medians; examples/benchmarks/statics.py, docs/benchmarks.md,
# session 36).
# - From SPARSE_STEP_FROM DOFs the engine steps on the sparse saddle-point system
#   (`engine.static_step`, `sparse_step`), in proportion to the elements: 0.27 to 0.31 of
#   numpy's CPU on BEAM cantilevers of 288 to 384 DOFs, 0.35 on manipulator_reduced (507
#   DOFs), 0.35 to 0.38 on the 816-DOF manipulator, where the dense step (each iteration
#   forms DF, NDOF solves of J, and the dense tangent DF^T (K_x DF)) cost 0.54 to 0.81, 1.4
#   to 1.6 and 0.98 to 0.99 (two runs, 5 and 7 rounds).
# - Below it the dense step: the sparse one is the faster there too (0.57 to 0.82 of the
#   dense step's CPU, 75 to 240 DOFs), but the engine's linearisation reads the reduced
#   form that the dense step packs (`linear_engine`: one packing per live model), and a
#   static solve and a linearisation together cost less through it up to about 200 DOFs
#   (manipulator_control 28 against 43 ms, cantilevers of 144 and 192 DOFs 0.92 and 0.97
#   of the sparse path's; 1.03 at 240 DOFs, 1.23 at 288). SPARSE_STEP_FROM = 240 takes the
#   sparse step from the first size measured where the pair costs no more through it.
# - Below ENGINE_MIN_FREE free coordinates (where the numpy kinematics go sparse) a numpy
#   solve takes milliseconds (20 ms on stage_spatial_19dof), less than what touching the
#   compiled engine costs a process (0.08 s of CPU: numba, llvmlite, the cached entries;
#   warm `flexure analyze truss_1dof_x` 0.38 -> 0.46 s).
# Packing is not in these figures: a balance is packed once per live model (0.2 s of CPU on
# manipulator_control, 0.75 s on manipulator_reduced), so a process that solves one
# equilibrium of a new model pays more than the numpy path, as it did in the old window
# (a new model and one solve, in a process with the engine started: manipulator_control
# 1.8 times numpy's CPU, the 288-DOF cantilever 1.2, manipulator_reduced 2.0).
ENGINE_MIN_FREE = SPARSE_FROM
SPARSE_STEP_FROM = 240  # DOFs


def supports(model: Model) -> bool:
    """Whether the engine takes the statics of `model`: not with kinematic inputs and
    actuators together, which its packing refuses (its prescribed form has no coils)."""
    return not (model.kinematic_inputs and model.actuators)


def preferred(model: Model) -> bool:
    """Whether the engine is the default path of the statics of `model`: it takes the model,
    which has at least ENGINE_MIN_FREE free coordinates (where a solve through the engine is
    the faster, with the packing amortised over the solves of a live model: a process that
    solves a new large model once pays more, the comment above ENGINE_MIN_FREE; no upper
    bound)."""
    return supports(model) and model.free_coordinates.size >= ENGINE_MIN_FREE


def sparse_step(model: Model) -> bool:
    """Whether the engine's statics of `model` ask for the sparse saddle-point system's step
    (`engine.static_step`): at least SPARSE_STEP_FROM DOFs (the comment above it), no
    kinematic inputs and no coil currents, which the sparse Newton matrix's packing
    refuses before it looks further. That packing decides the rest (S and D element by
    element, every element with mass, static pivots: `engine.newton_packing`), and a model
    it refuses steps dense (`EngineBalance`). A rule on the model alone, so the path does
    not depend on the CPU; read when a balance is packed, so a test may change
    SPARSE_STEP_FROM before it packs a model."""
    return (model.ndof >= SPARSE_STEP_FROM and not model.kinematic_inputs
            and not model.coil_actuators)


def live_balance(model: Model) -> EngineBalance | None:
    """The `EngineBalance` of `model` if the statics have packed its reduced form already,
    else None (nothing is packed that the linearisation reads: what it asks before it takes
    the engine; a balance that steps sparse packs the reduced form only when asked)."""
    balance = _BALANCES.get(model)
    return balance if balance is not None and balance.packed_dense else None


def live_step(model: Model) -> EngineBalance | None:
    """The `EngineBalance` of `model` if the statics have packed it and it steps on the sparse
    saddle-point system (`EngineBalance.sparse`), else None: the linearisation then reads the
    sparse Newton matrix's packing (`linear_sparse`) rather than packing the reduced form."""
    balance = _BALANCES.get(model)
    return balance if balance is not None and balance.sparse else None


def engine_balance(model: Model, *, sparse: bool | None = None) -> EngineBalance:
    """The `EngineBalance` of `model`, packed once per live model and reused (a packing
    takes about 0.16 s of CPU on the 507-DOF manipulator; a model is not changed once built: a
    parameter study builds a model per parameter set). sparse: the step wanted (default
    `sparse_step`'s rule); a live balance that steps otherwise is packed again."""
    balance = _BALANCES.get(model)
    if balance is None or (sparse is not None and balance.asked != sparse):
        balance = _BALANCES.put(model, EngineBalance(model, sparse=sparse))
    return balance


class EngineBalance:
    """The static balance of one model through the compiled engine (module docstring).

    Parameters
    ----------
    model : Model
        A model the engine takes (`supports`).
    sparse : bool, optional
        Step on the sparse saddle-point system (True, where the sparse Newton matrix's
        packing takes the model; else dense) or on the dense tangent (False); default
        `sparse_step`'s rule.
    """

    def __init__(self, model: Model, *, sparse: bool | None = None):
        # the engine (and numba) imported on first use: a command that never solves a loaded
        # model through it does not pay for that import
        from ..engine import data as ed

        self.model = model
        self._ed = ed
        self._load = (1.0, None, None)
        self._dense: _Packing | None = None
        self._sparse: _Packing | None = None
        self._rest = np.zeros(model.ndof)  # qdot = 0 and qddot = 0
        # the step asked for; a model the sparse Newton matrix refuses steps dense
        self.asked = sparse_step(model) if sparse is None else bool(sparse)
        if self.asked:
            packing = _Packing(model, augmented=True)
            if packing.data.int_array("dims")[ed.NEWTON_SPARSE] == 1:
                self._sparse = packing
                self._out = np.zeros(2 * model.ndof)
        if self._sparse is None:
            self._dense = _Packing(model, augmented=False)

    @property
    def sparse(self) -> bool:
        """Whether Newton's step is the sparse saddle-point system's (`free_step`) rather
        than the dense tangent's (`residual_and_tangent`)."""
        return self._sparse is not None

    @property
    def data(self):
        """The packed model in the reduced form (`EngineData`), which the dense tangent and
        the linearisation read; packed on first use where the statics step sparse."""
        if self._dense is None:
            self._dense = _Packing(self.model, augmented=False)
            self._dense.load(*self._load)
        return self._dense.data

    @property
    def step_data(self):
        """The packed model in the augmented form that the sparse step runs on (`EngineData`,
        with the sparse Newton matrix's slots), or None where the balance steps dense."""
        return None if self._sparse is None else self._sparse.data

    @property
    def packed_dense(self) -> bool:
        """Whether the reduced form's packing exists (the linearisation's rule, `live_balance`)."""
        return self._dense is not None

    def set_load(self, load_factor: float, loads: np.ndarray | None = None,
                 values: np.ndarray | None = None) -> None:
        """Put s times the load into the packed model(s).

        Parameters
        ----------
        load_factor : float
            s (unitless).
        loads : ndarray (NX,), optional
            Nodal forces, N (N m on rotations); default the model's loads.
        values : ndarray (n_inputs,), optional
            The inputs' port values, N or N m; default none.
        """
        self._load = (load_factor, loads, values)
        for packing in (self._dense, self._sparse):
            if packing is not None:
                packing.load(load_factor, loads, values)

    def moved(self, point: EnginePoint | Configuration, q: np.ndarray, *,
              as_stepped: bool = False) -> EnginePoint:
        """The iterate at DOFs q after `point` (its kinematics solved when it is evaluated,
        from the engine's last solution, whatever step made it: as_stepped is not needed
        here)."""
        return EnginePoint(np.asarray(q, float))

    def residual_and_tangent(self, point: EnginePoint | Configuration,
                             ) -> tuple[np.ndarray, np.ndarray]:
        """Q and K at `point` under the load of the last `set_load` (module docstring).

        Parameters
        ----------
        point : EnginePoint or Configuration
            Its q (NDOF,), m or rad, and, when solved, its x (NX,): a point from elsewhere
            (a configuration of the numpy kinematics, an earlier equilibrium) starts the
            kinematics from its x.

        Returns
        -------
        Q : ndarray (NDOF,)
            N or N m.
        K : ndarray (NDOF, NDOF)
            N/m in the DOF units (N m/rad on an angle DOF).

        Raises
        ------
        ConvergenceError
            The engine could not solve the kinematics at q (a singular configuration, or
            beyond the mechanism's reach).
        """
        from ..engine import engine

        ed, data = self._ed, self.data
        packing = self._dense
        self._start(packing, point)
        q = np.ascontiguousarray(point.q, dtype=float)
        status = engine.call(data, engine.OP_ACCELERATIONS, q, self._rest)
        if status not in (ed.OK, ed.SINGULAR_MASS):  # see the module docstring on massless
            self._fail(packing, status, q)
        packing.current = point
        Q = data.float_array("reduced_force").copy()
        status = engine.call(data, engine.OP_TANGENT, self._rest)
        if status != ed.OK:
            self._fail(packing, status, q)
        n = q.size
        return Q, data.float_array("stiffness").reshape(n, n).copy()

    def free_step(self, point: EnginePoint | Configuration, dq: np.ndarray) -> np.ndarray:
        """Newton's step at `point` from the sparse saddle-point system (OP_STATIC_STEP,
        `engine.static_step`): the reduced step K^-1 Q without DF, for a balance that steps
        sparse (`sparse`; its models have no kinematic inputs, so every DOF is free).

        Parameters
        ----------
        point : EnginePoint or Configuration
            As `residual_and_tangent`'s.
        dq : ndarray (NDOF,)
            Not read: the prescribed DOFs' move, which these models do not have.

        Returns
        -------
        ndarray (n_free_dofs,)
            The free DOFs' step (here every DOF's), m or rad.

        Raises
        ------
        ConvergenceError
            The engine could not solve the kinematics at q, or the tangent stiffness is
            singular.
        """
        from ..engine import engine

        packing = self._sparse
        self._start(packing, point)
        q = np.ascontiguousarray(point.q, dtype=float)
        status = engine.call(packing.data, engine.OP_STATIC_STEP, q, self._rest, self._out)
        if status == self._ed.SINGULAR_MASS:  # the saddle-point system's LU (engine.static_step)
            packing.current = None
            raise ConvergenceError("the tangent stiffness is singular")
        if status != self._ed.OK:
            self._fail(packing, status, q)
        packing.current = point
        return self._out[: q.size][self.model.free_dofs]

    def step_balance(self) -> np.ndarray:
        """Q = DF^T r (NDOF,), N or N m, at the point of the last `free_step`."""
        return self._out[self.model.ndof:].copy()

    def solved(self, point: EnginePoint) -> EnginePoint:
        """`point` with its coordinates x solved (OP_CONFIGURATION, from the engine's last
        solution).

        Raises
        ------
        ConvergenceError
            As `residual_and_tangent`.
        """
        from ..engine import engine

        if point.x is not None:
            return point
        packing = self._sparse or self._dense
        self._start(packing, point)
        q = np.ascontiguousarray(point.q, dtype=float)
        status = engine.call(packing.data, engine.OP_CONFIGURATION, q)
        if status != self._ed.OK:
            self._fail(packing, status, q)
        solved = EnginePoint(q, packing.data.float_array("x").copy())
        packing.current = solved
        return solved

    def _start(self, packing, point):
        """Where `packing`'s kinematics start for `point`: its own x, unless the packing
        holds it or it is an unsolved iterate (whose start is the packing's last solution)."""
        x = getattr(point, "x", None)
        if x is None or point is packing.current:
            return
        packing.data.restart_kinematics(x)

    def _fail(self, packing, status, q):
        from ..engine.status import status_message

        packing.current = None
        reason = status_message(status)
        raise ConvergenceError(f"static balance of {self.model.name!r} at q = "
                               f"{np.array2string(q, precision=6)}: {reason}")


class _Packing:
    """One packed model of the statics (`EngineData`, in the reduced or the augmented
    form) with what the statics holds fixed written into it (module docstring), the views
    the load goes into, and the iterate whose kinematics it holds (`current`)."""

    def __init__(self, model, *, augmented):
        from ..engine import data as ed
        from ..engine.data import EngineData

        self.model = model
        data = EngineData(model, augmented=augmented, singular_ratio=0.0)
        self.data = data
        data.int_array("actuators")[0::2] = ed.FORCE_INPUT  # their force at rest is given
        data.int_array("dims")[ed.HAS_DAMPING] = 0
        data.int_array("dims")[ed.STATIC] = 1  # DF^T r without M_bar and its LU
        self._constant = data.float_array("constant_force")
        self._lumped_gravity = self._constant - model.loads  # what packing added to the loads
        group_data = data.float_array("group_data")
        points = [slice(row[ed.G_GRAVITY_OFFSET], row[ed.G_GRAVITY_OFFSET] + row[ed.G_P])
                  for row in data.int_array("groups").reshape(-1, ed.G_WIDTH)
                  if row[ed.G_GRAVITY_OFFSET] >= 0]
        # (the packed gravity on a group's inertia points (a view), its full value)
        self._gravity = [(group_data[p], group_data[p].copy()) for p in points]
        self._inputs = data.float_array("inputs")
        self.current: EnginePoint | None = None

    def load(self, load_factor, loads=None, values=None):
        """s times the load into the packed model (`EngineBalance.set_load`)."""
        loads = self.model.loads if loads is None else loads
        self._constant[:] = load_factor * (loads + self._lumped_gravity)
        for packed, full in self._gravity:
            packed[:] = load_factor * full
        self._inputs[:] = 0.0 if values is None else load_factor * np.asarray(values, float)
