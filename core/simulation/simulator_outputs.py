"""What a Simulator measures: its declared outputs at the current state or along a path of
states, and the range-of-validity warnings (`plausibility`) of its states. The part of
`Simulator` that solves the kinematics on its second packed model (`_output_data`), so that
measuring never disturbs the integrator's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..engine.status import status_message
from ..errors import SimulationError
from ..mechanics.output_quantities import output_order
from ..mechanics.ports import output_value
from .measuring import start_from_plant
from .plausibility import RangeCheck

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model


def measured_orders(model: Model) -> list[int]:
    """The time derivative (0, 1, 2: `output_quantities`) of the coordinates each of the
    model's outputs on nodes reads, as a simulation measures them.

    Parameters
    ----------
    model : Model

    Returns
    -------
    list of int (n_outputs,)

    Raises
    ------
    SimulationError
        An acceleration output of a model with kinematic inputs (not measured: a kinematic
        input's acceleration is its path's at the state's time, which this measurement does
        not take); it names the output.
    """
    orders = [output_order(port) for port in model.outputs]
    for port, order in zip(model.outputs, orders, strict=True):
        if order == 2 and model.kinematic_inputs:
            raise SimulationError(
                f"output {port.name!r} is an acceleration: a simulation of a model with "
                f"kinematic inputs ({', '.join(p.name for p in model.kinematic_inputs)}) does "
                "not measure accelerations (a kinematic input's is its path's at the time, "
                "which the measurement does not take); differentiate a velocity output")
    return orders


class SimulatorOutputs:
    """The measuring methods of `Simulator` (which sets up the attributes they read: the
    model, the state, `_output_data`, `_output_coordinates`, `_about_axis`, `_positions_only`,
    `_orders` (the time derivative each output on a node reads: `measured_orders`),
    `_input_functions` and `_inputs_at` (the inputs at a time),
    `_output_dofs` and `_output_dof_list`, `_elements` (the outputs on elements:
    `element_readings`), `_restart_kinematics` (whether the plant's last
    solution may be of another state), the last evaluation's `_last_x`, `_last_e`, and
    `_range`, `_within` made here on first use)."""

    def outputs(self) -> np.ndarray:
        """The declared outputs at the current state: read from q when every output is a
        coordinate DOF, else solved once per state (`advance`, `reset` and `set_state` start
        a new one).

        Returns
        -------
        ndarray (n_outputs,)
            Positions m, velocities m/s, accelerations m/s2 (angles rad, their rates rad/s,
            rad/s2), then the outputs on elements: deformations m, stress resultants N
            (`element_readings`).

        Raises
        ------
        SimulationError
            The kinematics cannot be solved at the state.
        """
        dofs = self._output_dofs
        if dofs is not None:  # every output a coordinate DOF: q itself, a new array, uncached
            return self._q_ref[dofs] + self._y[dofs]
        if self._outputs_cache is None:
            if self._positions_only:
                self._outputs_cache = self._positions_at(self._q_ref + self._y[: self.ndof])
            else:
                # the inputs at this time: the held ones, or an input function's value
                inputs = self._inputs_at(self._t) if self._input_functions else self._u
                self._outputs_cache = self.outputs_along(self.absolute(self._y)[None],
                                                         start=self._x, times=[self._t],
                                                         inputs=[inputs])[0]
        return self._outputs_cache.copy()

    def output_values(self) -> list[float]:
        """`outputs` as a list of floats, for a host that copies them into its own variables
        after every step (the FMU): read from q without an array when every output is a
        coordinate DOF (a quarter of `outputs().tolist()`'s time).

        Returns
        -------
        list of float (n_outputs,)
            As `outputs`: the coordinate outputs, then the outputs on elements (m, N).

        Raises
        ------
        SimulationError
            The kinematics cannot be solved at the state.
        """
        if self._output_dofs is None:
            return self.outputs().tolist()
        q_ref, y = self._q_ref, self._y
        return [q_ref.item(j) + y.item(j) for j in self._output_dof_list]

    def _positions_at(self, q):
        """The position outputs at DOFs q: Newton from the plant's coordinates moved to q
        (`measuring`), positions only, as the compiled sampled loop measures them."""
        data, q = self._output_data, np.ascontiguousarray(q, dtype=float)
        self._start_kinematics(self._x, data)
        if not self._restart_kinematics:  # the plant's last solution is of this state's step
            start_from_plant(self.data.address, data.address, q)
        status = engine.call(data, engine.OP_POSITIONS, q)
        if status != ed.OK:
            raise SimulationError(f"t = {self._t:.9g} s: outputs: {status_message(status)}")
        x = data.float_array("x")
        if self._about_axis:
            return np.array([output_value(self.model, port, x) for port in self.model.outputs])
        return x[self._output_coordinates]

    def outputs_along(self, states: ArrayLike, *, start: np.ndarray | None = None,
                      times: ArrayLike | None = None,
                      inputs: ArrayLike | None = None) -> np.ndarray:
        """The declared outputs along a path of states, solving the kinematics point by point
        (warm-started from one to the next).

        Parameters
        ----------
        states : array_like (n, 2 NDOF + n_coils)
            Absolute states [q, qdot(, i)]: m, rad; m/s, rad/s; A.
        start : ndarray (NX,), optional
            The coordinates (m, rad) the first kinematic solve starts from (default: the
            scene's initial ones).
        times : array_like (n,), optional
            The time of each state (s), for the error that names the state that failed, and
            the kinematic inputs' path a stress output is evaluated on (needed then).
        inputs : array_like (n, n_inputs), optional
            The inputs held at each state (N, N m, V; default the ones held now): what a
            kinematic input's effort, and so a prescribed deformation's stress, carries.

        Returns
        -------
        ndarray (n, n_outputs)
            Positions m, velocities m/s, accelerations m/s2 (angles rad, their rates rad/s,
            rad/s2), then the
            outputs on elements: deformations m, stress resultants N (`element_readings`).

        Raises
        ------
        SimulationError
            The kinematics or the evaluation of a stress output fails at a state (it names
            the state's time, or its place along the path without `times`), or a stress
            output of a model with kinematic inputs comes without `times`.
        """
        return self._along(states, start, None, times, inputs)

    def outputs_and_warnings(self, states: ArrayLike, *, times: ArrayLike | None = None,
                             inputs: ArrayLike | None = None
                             ) -> tuple[np.ndarray, list[str]]:
        """The declared outputs along a path of states, and the range-of-validity warnings
        of those states (`flexure.core.simulation.plausibility`).

        Parameters
        ----------
        states : array_like (n, 2 NDOF + n_coils)
            Absolute states [q, qdot(, i)]: m, rad; m/s, rad/s; A.
        times : array_like (n,), optional
            The time of each state (s), as `outputs_along` takes them.
        inputs : array_like (n, n_inputs), optional
            The inputs held at each state, as `outputs_along` takes them.

        Returns
        -------
        outputs : ndarray (n, n_outputs)
            As `outputs_along`.
        warnings : list of str
            One message per kind of violation ("strain", "distance"); empty within the
            range.

        Raises
        ------
        SimulationError
            The kinematics cannot be solved at a state.
        """
        n_points = len(states)
        path = (np.zeros((n_points, self.model.nx)),
                np.zeros((n_points, len(self.model.deformation_names))))
        outputs = self._along(states, None, path, times, inputs)
        return outputs, list(self._range_check().warnings(*path).values())

    def range_warnings(self) -> dict[str, str]:
        """The range-of-validity warnings of the current state
        (`flexure.core.simulation.plausibility`). The coordinates and deformations are the
        integrator's last evaluation, at the end of the last step.

        Returns
        -------
        dict of str to str
            {kind ("strain", "distance"): message}, empty within the range.
        """
        if self._within is None:
            self._within = self._range_check().watch(self._last_x, self._last_e)
        if self._within():
            return {}
        return self._range_check().warnings(self._last_x, self._last_e)

    def _range_check(self):
        if self._range is None:
            self._range = RangeCheck(self.model)
        return self._range

    def _along(self, states, start, path, times=None, inputs=None):
        data = self._output_data
        self._start_kinematics(self.model.initial_coordinates if start is None else start,
                               data)
        ports, elements = self.model.outputs, self._elements
        states = np.asarray(states, float)
        result = np.zeros((len(states), len(ports) + len(elements)))
        held = (np.broadcast_to(self._u, (len(states), self._u.size)) if inputs is None
                else np.asarray(inputs, float).reshape(len(states), self._u.size))
        n = self.ndof
        x = data.float_array("x")
        for k, y in enumerate(states):
            where = (f"t = {times[k]:.9g} s" if times is not None else "a state")
            status = engine.call(data, engine.OP_KINEMATICS, np.ascontiguousarray(y[:n]))
            if status != ed.OK:  # name the state that failed, not the simulator's time
                raise SimulationError(f"{where} (state {k + 1} of {len(states)} along the "
                                      f"path): outputs: {status_message(status)}")
            rates = self._rates(data, y, held[k], where)  # x, then xdot, xddot as needed
            for j, p in enumerate(ports):
                result[k, j] = (output_value(self.model, p, *rates) if p.about_axis
                                else rates[self._orders[j]][p.coordinate])
            if path is not None:  # the kinematics left x and e of this point in the data
                path[0][k] = x
                path[1][k] = data.float_array("e")
            if len(elements):  # after the kinematics: e is this state's
                try:
                    result[k, len(ports):] = elements.values(
                        data, y, held[k], None if times is None else float(times[k]))
                except SimulationError as error:
                    raise SimulationError(f"{where} (state {k + 1} of {len(states)} along "
                                          f"the path): {error}") from None
        return result

    def _rates(self, data, state, inputs, where):
        """(x, xdot, xddot) of the coordinates up to the highest order the outputs read
        (`output_quantities`), at a state whose kinematics `data` has just solved: xdot =
        DF qdot; xddot = DF qddot + (D2F qdot) qdot from one evaluation of the equations of
        motion with the held inputs (the engine's qddot and convective term, slot conv)."""
        n, nx = self.ndof, self.model.nx
        top = max(self._orders, default=0)
        x = data.float_array("x")
        rates = [x.copy() if top >= 2 else x]  # the evaluation below solves x once more
        if top >= 1:
            rates.append(data.float_array("DF").reshape(nx, n) @ state[n: 2 * n])
        if top >= 2:
            DF = data.float_array("DF").reshape(nx, n).copy()
            # y = [0, qdot(, i)] on q_ref = q: this state's evaluation, as the integrator's
            data.float_array("q_ref")[:] = state[:n]
            data.float_array("inputs")[:] = inputs
            y = np.zeros(self.nstate)
            y[n: min(state.size, self.nstate)] = state[n: self.nstate]
            with data.evaluating(convective=True):  # slot conv formed, not left pending
                status = engine.call(data, engine.OP_RHS, y)
            if status != ed.OK:
                raise SimulationError(f"{where}: the acceleration outputs: "
                                      f"{status_message(status)}")
            rates.append(DF @ data.float_array("qddot") + data.float_array("conv"))
        return rates
