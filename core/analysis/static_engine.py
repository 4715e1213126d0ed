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
largest entry), but for one term the engine's tangent leaves out: the load stiffness of
gravity on element masses that hang on rotations (a BEAM's consistent mass couples its
position points, where gravity acts, to its tangent points), 5e-9 of K's largest entry on a
spatial cantilever under gravity. Q is exact, so the equilibrium is the same; only Newton's
convergence there is short of quadratic by that much. On every built-in scene the
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


# Where the engine is the statics' default: a window of model sizes, from measurements of
# one static solve's CPU, engine over numpy (examples/benchmarks/statics.py, 2026-11-29).
# - Above ENGINE_MAX_DOFS DOFs the engine may cost more: each iteration forms DF (NDOF
#   solves of J) and the dense tangent DF^T (K_x DF) (`engine.tangent`), about (DF's
#   entries) NDOF products, where the numpy path's step on a model from 300 free
#   coordinates is the sparse augmented system's (`static_augmented`), in proportion to
#   the elements. BEAM cantilevers: 0.37 at 192 and 240 DOFs, 0.86 at 288, 1.05 at 336,
#   1.3 to 1.4 at 384; manipulator_reduced (507 DOFs) 1.1; the 816-DOF manipulator (its DF
#   is 1 % full) 0.89 to 1.0, left to numpy by this rule.
# - Below SPARSE_FROM free coordinates (where the numpy kinematics go sparse) a numpy solve
#   takes milliseconds (20 ms on stage_spatial_19dof), less than what touching the compiled
#   engine costs a process (0.08 s of CPU: numba, llvmlite, the cached entries; warm
#   `flexure analyze truss_1dof_x` 0.38 -> 0.46 s).
ENGINE_MAX_DOFS = 300
ENGINE_MIN_FREE = SPARSE_FROM


def supports(model: Model) -> bool:
    """Whether the engine takes the statics of `model`: not with kinematic inputs and
    actuators together, which its packing refuses (its prescribed form has no coils)."""
    return not (model.kinematic_inputs and model.actuators)


def preferred(model: Model) -> bool:
    """Whether the engine is the default path of the statics of `model`: it takes the model,
    which has at least ENGINE_MIN_FREE free coordinates and at most ENGINE_MAX_DOFS DOFs
    (where the engine is the faster, its start-up included)."""
    return (supports(model) and model.ndof <= ENGINE_MAX_DOFS
            and model.free_coordinates.size >= ENGINE_MIN_FREE)


def live_balance(model: Model) -> EngineBalance | None:
    """The `EngineBalance` of `model` if the statics have packed it already, else None
    (nothing is packed: what the linearisation asks before it takes the engine)."""
    return _BALANCES.get(model)


def engine_balance(model: Model) -> EngineBalance:
    """The `EngineBalance` of `model`, packed once per live model and reused (its packing
    takes 0.3 to 1 s on the 507-DOF manipulator; a model is not changed once built: a
    parameter study builds a model per parameter set)."""
    return _BALANCES.get(model) or _BALANCES.put(model, EngineBalance(model))


class EngineBalance:
    """The static balance of one model through the compiled engine (module docstring).

    Parameters
    ----------
    model : Model
        A model the engine takes (`supports`).
    """

    def __init__(self, model: Model):
        # the engine (and numba) imported on first use: a command that never solves a loaded
        # model through it does not pay for that import
        from ..engine import data as ed
        from ..engine.data import EngineData

        self.model = model
        self._ed = ed
        data = EngineData(model, augmented=False, singular_ratio=0.0)
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
        self._current: EnginePoint | None = None  # whose kinematics the engine holds
        n = model.ndof
        self._rest = np.zeros(n)  # qdot = 0 and qddot = 0

    def set_load(self, load_factor: float, loads: np.ndarray | None = None,
                 values: np.ndarray | None = None) -> None:
        """Put s times the load into the packed model.

        Parameters
        ----------
        load_factor : float
            s (unitless).
        loads : ndarray (NX,), optional
            Nodal forces, N (N m on rotations); default the model's loads.
        values : ndarray (n_inputs,), optional
            The inputs' port values, N or N m; default none.
        """
        loads = self.model.loads if loads is None else loads
        self._constant[:] = load_factor * (loads + self._lumped_gravity)
        for packed, full in self._gravity:
            packed[:] = load_factor * full
        self._inputs[:] = 0.0 if values is None else load_factor * np.asarray(values, float)

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
        self._start(point)
        q = np.ascontiguousarray(point.q, dtype=float)
        status = engine.call(data, engine.OP_ACCELERATIONS, q, self._rest)
        if status not in (ed.OK, ed.SINGULAR_MASS):  # see the module docstring on massless
            self._fail(status, q)
        self._current = point
        Q = data.float_array("reduced_force").copy()
        status = engine.call(data, engine.OP_TANGENT, self._rest)
        if status != ed.OK:
            self._fail(status, q)
        n = q.size
        return Q, data.float_array("stiffness").reshape(n, n).copy()

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
        self._start(point)
        q = np.ascontiguousarray(point.q, dtype=float)
        status = engine.call(self.data, engine.OP_CONFIGURATION, q)
        if status != self._ed.OK:
            self._fail(status, q)
        solved = EnginePoint(q, self.data.float_array("x").copy())
        self._current = solved
        return solved

    def _start(self, point):
        """Where the engine's kinematics start for `point`: its own x, unless the engine
        holds it or it is an unsolved iterate (whose start is the engine's last solution)."""
        x = getattr(point, "x", None)
        if x is None or point is self._current:
            return
        self.data.float_array("x_start")[:] = x
        self.data.int_array("dims")[self._ed.WARM] = 0

    def _fail(self, status, q):
        from ..simulation.status import STATUS_MESSAGES

        self._current = None
        reason = STATUS_MESSAGES.get(int(status), f"engine status {int(status)}")
        raise ConvergenceError(f"static balance of {self.model.name!r} at q = "
                               f"{np.array2string(q, precision=6)}: {reason}")
