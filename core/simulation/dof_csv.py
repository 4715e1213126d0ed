"""A trajectory on the DOFs as CSV: what `flexure simulate --dofs` writes and `flexure view
--simulation` reads.

    time [s],3.x [m],3.y [m],4.phi [rad]
    0,0,0.1,0
    0.001,1.2e-07,0.1,-3.1e-08

The first column is the time (s); then one column per DOF, named as `Model.dof_names` (a
coordinate "NODE.AXIS", a deformation "ELEMENT.eK") with its unit in brackets: m on
translations and on deformations (every deformation is a length, flexure's convention), rad on
a planar rotation, 1 on Euler parameters and dimensionless deformations. The values are the
DOFs themselves (not their change from the start), so the kinematics gives every coordinate.
A reader matches the columns by name (the order and the units in brackets do not matter).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import UsageError

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

TIME = "time"
UNIT = re.compile(r"\s*\[[^\]]*\]\s*$")  # a trailing " [unit]"


def dof_units(model: Model) -> list[str]:
    """The unit of each DOF, in the order of q: the coordinates' (`Node.units`), then the
    deformations' ("m", or "1" where the element declares a dimensionless one)."""
    from ..mechanics.scales import deformation_unit_names

    units = {}
    for node in model.nodes:
        units.update(zip(node.coordinates, node.units, strict=True))
    deformations = deformation_unit_names(model)
    return ([units.get(int(i), "m") for i in model.dof_coordinates]
            + [deformations[int(i)] for i in model.dof_deformations])


def write_dof_csv(path, model: Model, times: np.ndarray, q: np.ndarray) -> None:
    """Write times (n,) s and the DOFs q (n, NDOF) to `path` (module docstring)."""
    header = ",".join([f"{TIME} [s]"] + [f"{name} [{unit}]" for name, unit in
                                         zip(model.dof_names, dof_units(model), strict=True)])
    data = np.column_stack([np.asarray(times, float), np.asarray(q, float)])
    # %.17g: every float64 reads back exactly, so a view of the file shows the run itself
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.17g")


def read_dof_csv(path, model: Model, *, option: str = "--simulation"
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(times (n,) s, q (n, NDOF)) from a CSV of `write_dof_csv`'s form for `model`.

    Raises
    ------
    UsageError
        The file cannot be read, its first column is not the time, a DOF of the model has no
        column or a column names no DOF (naming it, and saying so when the columns are the
        scene's outputs, what `flexure simulate --out` writes), a value is not a finite
        number (naming its row and column), or the times decrease.
    """
    where = f"{option} {path}"
    try:
        lines = [line for line in Path(path).read_text().splitlines() if line.strip()]
    except (OSError, UnicodeDecodeError) as error:
        raise UsageError(f"{where}: cannot read: {getattr(error, 'strerror', None) or error}"
                         ) from None
    if len(lines) < 2:
        raise UsageError(f"{where}: expected a header line and at least one row of values")
    columns = [UNIT.sub("", name).strip() for name in lines[0].split(",")]
    if columns[0] != TIME:
        raise UsageError(f"{where}: the first column is {columns[0]!r}; expected {TIME!r} "
                         "(a header time [s],DOF [unit],...: `flexure simulate --dofs` "
                         "writes it)")
    _check_columns(where, columns[1:], model)
    values = _numbers(where, lines[1:], columns)
    order = [columns.index(name) for name in model.dof_names]
    times = values[:, 0]
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        raise UsageError(f"{where}: line {back[0] + 3}: time "
                         f"{times[back[0] + 1]:g} s is before the time {times[back[0]]:g} s "
                         "of the row above")
    return times, values[:, order]


def _check_columns(where: str, columns: list[str], model: Model) -> None:
    """UsageError naming a missing or unknown DOF column, or a column given twice."""
    dofs = model.dof_names
    twice = [name for k, name in enumerate(columns) if name in columns[:k]]
    if twice:
        raise UsageError(f"{where}: the column {twice[0]!r} is given twice")
    unknown = [name for name in columns if name not in dofs]
    missing = [name for name in dofs if name not in columns]
    outputs = {port.name for port in model.outputs}
    if unknown and set(unknown) <= outputs:
        raise UsageError(
            f"{where}: the columns {', '.join(unknown)} are the outputs of {model.name!r} "
            f"(what `flexure simulate --out` writes), not its {len(dofs)} DOFs; write the "
            "DOFs with `flexure simulate ... --dofs FILE.csv`")
    if unknown:
        raise UsageError(f"{where}: the column {unknown[0]!r} is no DOF of {model.name!r} "
                         f"(its DOFs: {_listed(dofs)})")
    if missing:
        raise UsageError(f"{where}: no column for the DOF {missing[0]!r} of {model.name!r} "
                         f"({len(missing)} of its {len(dofs)} DOFs missing: {_listed(missing)})")


def _numbers(where: str, rows: list[str], columns: list[str]) -> np.ndarray:
    """The rows as an (n, columns) array of finite numbers; UsageError naming the first
    row and column that is not one."""
    values = np.empty((len(rows), len(columns)))
    for r, row in enumerate(rows):
        cells = row.split(",")
        if len(cells) != len(columns):
            raise UsageError(f"{where}: line {r + 2} has {len(cells)} values; expected "
                             f"{len(columns)}, one per column of the header")
        for c, cell in enumerate(cells):
            try:
                values[r, c] = float(cell)
            except ValueError:
                values[r, c] = np.nan
            if not np.isfinite(values[r, c]):
                raise UsageError(f"{where}: line {r + 2}, column {columns[c]!r}: expected a "
                                 f"finite number, got {cell.strip()!r}")
    return values


def _listed(names: list[str], most: int = 8) -> str:
    """The first `most` names, and how many more."""
    shown = ", ".join(names[:most])
    return shown + (f" and {len(names) - most} more" if len(names) > most else "")
