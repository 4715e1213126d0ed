"""The range of validity of a model, checked on its states: warnings, never errors.

flexure's elements are geometrically exact for large motions, but their constitutive law is
linear in small deformations, and a flexure stage that has moved a quarter of its own size
has left the range it was designed and modelled for. A state beyond either limit is still
integrated (the equations stay well defined), but the result is reported with a warning
(`Simulator.range_warnings`, `SimulationResult.warnings`, `flexure simulate`, the FMU's log)
instead of being returned in silence:

- axial strain e1 / l0 of any beam (PLBEAM, BEAM: the leaves, wires and bodies of a flexure):
  |strain| <= STRAIN_LIMIT (1 %: well past the elastic limit of flexure materials, about
  0.5 % for spring steel). Trusses are left out: a scene uses them for springs too, whose
  linear law holds at any elongation;
- translation of any node from the start configuration: <= DISTANCE_LIMIT (0.25) times the
  mechanism's size (`mechanism_size`: the diagonal of the box around its nodes' start
  positions). Its size, not its longest element: a leaf meshed into 16 beams is as long as
  one, and moving a quarter of one segment is not leaving the range.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ..numerics.ties import best_first

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model

STRAIN_LIMIT = 1e-2
DISTANCE_LIMIT = 0.25
BEAMS = ("PLBEAM", "BEAM")


class RangeCheck:
    """The limits above for one model; `warnings(x, e)` of a state (coordinates x (NX,) and
    deformations e (NE,), SI units), or of many at once ((n, NX), (n, NE)).

    Parameters
    ----------
    model : Model
        Its beams' lengths and its translational coordinates' start values set the bounds:
        `strain_bound` (m, per beam), `distance_bound` (m), `scale` (m, `mechanism_size`).
    """

    def __init__(self, model: Model) -> None:
        self.model = model
        lengths, elongations = [], []
        for group in model.groups:
            if group.kind.type_name in BEAMS and group.deformation_index.shape[1] > 0:
                lengths.append(np.asarray(group.reference["l0"], float))
                elongations.append(group.deformation_index[:, 0])  # e1: the elongation (m)
        self.elongation = (np.concatenate(elongations).astype(np.int64) if elongations
                           else np.zeros(0, np.int64))
        self.length = np.concatenate(lengths) if lengths else np.zeros(0)
        self.strain_bound = STRAIN_LIMIT * self.length  # |e1| beyond it: out of range (m)
        self.scale = mechanism_size(model)
        self.translational = np.asarray(model.translations, dtype=np.int64)
        self.start = np.asarray(model.initial_coordinates, float)[self.translational]
        self.distance_bound = DISTANCE_LIMIT * self.scale
        # `within`'s arguments in two arrays: each array argument of a compiled call costs
        # about 0.1 us to check, and an FMU makes this call after every doStep
        self._indices = np.concatenate([self.elongation, self.translational])
        self._bounds = np.concatenate([self.strain_bound, self.start, [self.distance_bound]])

    def within(self, x: np.ndarray, e: np.ndarray) -> bool:
        """Whether one state is within both limits: the cheap test an FMU makes after every
        doStep (a few microseconds); `warnings` says what is not.

        Parameters
        ----------
        x : ndarray (NX,)
            The coordinates, m and rad, float64.
        e : ndarray (NE,)
            The deformations, m and rad, float64.

        Returns
        -------
        bool
            True within both limits.
        """
        from .plausibility_kernels import within

        return within(x, e, self._indices, self._bounds, self.elongation.size)

    def watch(self, x: np.ndarray, e: np.ndarray) -> Callable[[], bool]:
        """`within` of the arrays x and e as they are at each call, as a function of no
        arguments: one C call with one integer argument (an FMU checks after every doStep).

        Parameters
        ----------
        x : ndarray (NX,)
            The coordinates (m, rad), C-contiguous float64; it must stay where it is: the
            engine's own array (`Simulator` watches its last evaluation's).
        e : ndarray (NE,)
            The deformations (m, rad), likewise.

        Returns
        -------
        callable
            () -> bool, `within(x, e)` of their values at the call.

        Raises
        ------
        TypeError
            x or e is not C-contiguous.
        """
        arrays = (x, e, self._indices, self._bounds)
        if not all(a.flags.c_contiguous for a in arrays[:2]):
            raise TypeError("watch: x and e must be C-contiguous arrays")
        from ..numerics.array_tables import array_table

        table = np.append(array_table(arrays, "ffif"), self.elongation.size)
        address = int(table.ctypes.data)
        from .plausibility_kernels import within_entry

        check = within_entry.ctypes

        def within(_keep=(table, arrays)):  # the table points into the arrays: keep both
            return check(address) == 1

        return within

    def warnings(self, x: ArrayLike, e: ArrayLike) -> dict[str, str]:
        """What is beyond the limits in one state or many.

        Parameters
        ----------
        x : array_like (NX,) or (n, NX)
            The coordinates, m and rad.
        e : array_like (NE,) or (n, NE)
            The deformations, m and rad.

        Returns
        -------
        dict of str to str
            {"strain" or "distance": a message naming the element or coordinate worst beyond
            that limit, with its value}; empty when the states are within the range.
        """
        x, e = np.atleast_2d(x), np.atleast_2d(e)
        found = {}
        if self.elongation.size:
            strain = e[:, self.elongation] / self.length
            worst = _worst(np.abs(strain))
            if abs(strain[worst]) > STRAIN_LIMIT:
                name = self.model.deformation_names[self.elongation[worst[1]]]
                found["strain"] = (f"axial strain {strain[worst]:.3g} of {name} is beyond the "
                                   f"model's range of validity (|strain| <= {STRAIN_LIMIT:g})")
        if self.translational.size:
            distance = np.abs(x[:, self.translational] - self.start)
            worst = _worst(distance)
            if distance[worst] > DISTANCE_LIMIT * self.scale:
                name = self.model.coordinate_names[self.translational[worst[1]]]
                found["distance"] = (f"{name} moved {distance[worst]:.3g} m from the start, "
                                     f"beyond the model's range of validity ({DISTANCE_LIMIT:g} x "
                                     f"its size {self.scale:.3g} m)")
        return found


def _worst(values):
    """The (state, column) of the largest of `values` (n, k), the scene's order deciding among
    those within round-off of it (`ties.best_first`: the two ends of a rigid bar move alike,
    and which one a warning names must not depend on the CPU); (0, 0) when all are NaN."""
    if np.all(np.isnan(values)):
        return (0, 0)
    return np.unravel_index(best_first(values), values.shape)


def mechanism_size(model: Model) -> float:
    """The size of a model's mechanism (m): the diagonal of the box around its translational
    nodes' start positions; the longest element where that is zero (a single node on
    springs), 1 m without either.

    Parameters
    ----------
    model : Model

    Returns
    -------
    float
        m, > 0.
    """
    x0 = np.asarray(model.initial_coordinates, float)
    axes = model.coordinate_axis[model.translations].astype(str)
    spans = [np.ptp(x0[model.translations[axes == axis]]) for axis in np.unique(axes)]
    size = float(np.sqrt(np.sum(np.square(spans)))) if spans else 0.0
    if size > 0.0:
        return size
    lengths = [float(np.max(group.reference["l0"])) for group in model.groups
               if "l0" in group.reference and group.reference["l0"].size]
    return max(lengths) if lengths and max(lengths) > 0.0 else 1.0
