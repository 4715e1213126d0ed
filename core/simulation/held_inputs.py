"""The inputs a simulator holds (zero-order hold), checked before it takes them."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SimulationError

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike


def checked_inputs(u: ArrayLike, names: list[str], t: float) -> tuple[np.ndarray, list]:
    """The inputs u as an array and as a list, once their count and values are checked.

    Parameters
    ----------
    u : array_like (n_inputs,)
        N, N m for forces and moments, V for actuators' drive signals.
    names : list of str
        The model's input names, in order.
    t : float
        The simulator's time (s), for the message.

    Returns
    -------
    ndarray (n_inputs,), list of float
        The same values.

    Raises
    ------
    SimulationError
        The wrong number of inputs, or one that is not finite, named.
    """
    u = np.array(u, dtype=float).reshape(-1)
    if u.size != len(names):
        raise SimulationError(f"t = {t:.9g} s: expected {len(names)} inputs "
                              f"({', '.join(names)}), got {u.size}")
    values = u.tolist()  # a few numbers: Python's loop beats numpy's per-call cost here
    for name, value in zip(names, values, strict=True):
        if not math.isfinite(value):
            raise SimulationError(f"t = {t:.9g} s: input {name!r} is not finite ({value})")
    return u, values
