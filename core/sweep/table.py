"""The table of a design sweep (`flexure sweep`): one row per grid point, its parameter values,
its quantities (`flexure.core.sweep.grid`) and its status.

Every cell is text that reads back to the value written: a float as its repr (the same bits),
an integer, a string as is, a list as TOML; an absent quantity is blank. So a row read from
the CSV of an earlier run (`--resume`) is the row that run wrote, and two runs that computed
the same numbers write the same file. The CSV is appended to as the points finish (an
interrupted sweep keeps what it did) and rewritten in the order of the grid at the end; the
Parquet file (when pyarrow is importable) and the plot are made from the finished table.
"""

import csv
import math
from pathlib import Path

from ..errors import UsageError
from ..scene.overrides import parse_value
from ..scene.scene_writer import toml_value

__all__ = ["SweepTable", "cell"]

LEGEND_LINES = 12  # lines of a plot with a legend entry; more would hide the curves


def cell(value) -> str:
    """The text of one value in the table ("" for None)."""
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return value
    return toml_value(value)  # true/false, integers, lists


class SweepTable:
    """The header of a sweep's table and its rows as lists of cells."""

    def __init__(self, parameters, quantities, units=None):
        self.parameters = list(parameters)
        self.units = dict(units or {})  # {parameter: SI unit}, for the plot's axes
        self.quantities = list(quantities)
        self.header = [*self.parameters, *self.quantities, "status"]

    def key(self, point) -> tuple:
        """The parameter cells of a grid point {key: value}: how a row is matched to it."""
        return tuple(cell(point[name]) for name in self.parameters)

    def cells(self, point, row) -> list[str]:
        """The cells of a computed point (`evaluate_point`'s row)."""
        return [*self.key(point), *(cell(row.get(name)) for name in self.quantities),
                row["status"]]

    def read(self, path, option="--resume"):
        """The rows of an earlier run's CSV at `path`: ({key: cells} in the file's order, the
        number of lines that are no row of this table: an interrupted write, computed again).
        UsageError if the file's columns are not this table's."""
        try:
            with open(path, newline="") as handle:
                lines = list(csv.reader(handle))
        except (OSError, UnicodeDecodeError, csv.Error) as error:
            raise UsageError(f"{option}: cannot read {path}: "
                             f"{getattr(error, 'strerror', None) or error}") from None
        if not lines:
            return {}, 0
        if lines[0] != self.header:
            raise UsageError(f"{option}: {path} has the columns {', '.join(lines[0])}; this "
                             f"sweep writes {', '.join(self.header)}: resume with the same "
                             "--param keys, --analyses and --modes, or write another file")
        rows, unreadable = {}, 0
        for line in lines[1:]:
            if len(line) != len(self.header) or not line[-1]:
                unreadable += 1
                continue
            rows.setdefault(tuple(line[: len(self.parameters)]), line)
        return rows, unreadable

    def write_csv(self, path, rows):
        """Write the header and `rows` (lists of cells) to `path`."""
        with open(path, "w", newline="") as handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow(self.header)
            writer.writerows(rows)

    def append(self, handle, cells):
        """Append one row to an open CSV file, at once (a sweep may be interrupted)."""
        csv.writer(handle, lineterminator="\n").writerow(cells)
        handle.flush()

    def values(self, rows):
        """{column: list of values} of `rows`: parameters as TOML values, quantities as floats
        (NaN where blank), statuses as text."""
        columns = {}
        for i, name in enumerate(self.header):
            texts = [row[i] for row in rows]
            if name in self.parameters:
                columns[name] = [parse_value(text) for text in texts]
            elif name in self.quantities:
                columns[name] = [float(text) if text else math.nan for text in texts]
            else:
                columns[name] = texts
        return columns

    def write_parquet(self, path, rows):
        """Write `rows` as Parquet (pyarrow): numbers typed, blanks null."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        arrays = {}
        for name, values in self.values(rows).items():
            if name in self.quantities:
                values = [None if math.isnan(v) else v for v in values]
            try:
                arrays[name] = pa.array(values)
            except (pa.ArrowInvalid, pa.ArrowTypeError):  # mixed kinds: keep the text
                arrays[name] = pa.array([row[self.header.index(name)] for row in rows])
        pq.write_table(pa.table(arrays), path)

    def label(self, parameter):
        """A parameter's axis label: "KEY [UNIT]", or the key where it has no unit."""
        unit = self.units.get(parameter)
        return f"{parameter} [{unit}]" if unit else parameter

    def unit_suffix(self, parameter):
        """" UNIT" after a parameter's value in a legend, or ""."""
        unit = self.units.get(parameter)
        return f" {unit}" if unit and unit != "1" else ""

    def plot(self, path, rows, title=""):
        """Each quantity against the first parameter, one line per value of the others."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        values = self.values(rows)
        first, others = self.parameters[0], self.parameters[1:]
        x = values[first]
        numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in x)
        categories = list(dict.fromkeys(cell(v) for v in x))
        position = (x if numeric else [categories.index(cell(v)) for v in x])
        groups = {}
        for i, row in enumerate(rows):
            groups.setdefault(tuple(row[1: len(self.parameters)]), []).append(i)
        # a quantity no point has (modes past the DOF count, every point failed) gets no axes
        shown = [name for name in self.quantities
                 if any(not math.isnan(v) for v in values[name])]
        count = max(len(shown), 1)
        ncols = min(3, count)
        nrows = math.ceil(count / ncols)
        fig, axes = plt.subplots(nrows, ncols, figsize=(4.5 * ncols, 3.2 * nrows),
                                 squeeze=False)
        if not shown:
            axes[0, 0].text(0.5, 0.5, "no point has a result", ha="center", va="center")
        for ax, name in zip(axes.flat, shown, strict=False):
            for n, (group, members) in enumerate(groups.items()):
                members = sorted(members, key=lambda i: position[i])
                label = (", ".join(f"{k}={c}{self.unit_suffix(k)}"
                                   for k, c in zip(others, group, strict=True))
                         if others and n < LEGEND_LINES else None)
                ax.plot([position[i] for i in members], [values[name][i] for i in members],
                        "o-", markersize=3, label=label)
            ax.set_title(name, fontsize=9)
            ax.set_xlabel(self.label(first), fontsize=8)
            ax.tick_params(labelsize=7)
            if not numeric:
                ax.set_xticks(range(len(categories)), categories)
            ax.grid(True, alpha=0.3)
        for ax in list(axes.flat)[len(shown):]:
            ax.set_visible(shown == [])  # the one with the note stays
        if others and shown:
            axes.flat[0].legend(fontsize=6)
        fig.suptitle(title, fontsize=10)
        fig.tight_layout()
        fig.savefig(Path(path), dpi=110)
        plt.close(fig)
