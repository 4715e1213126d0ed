"""Where the entries of a sparse pattern sit in its packed values: `PatternSlots`.

A packed sparse matrix (`sparse_lu.StaticLU`: compressed columns in a column order) stores
entry (i, j) at one position of its values. Sorted keys, column position n + row, one per
stored entry in storage order, give that position by bisection. The packings look up many
entries as arrays and many one at a time (an element's pairs, a port's 4 x 4 block); a single
entry is looked up on Python lists, without the fixed cost of a dozen array operations
(5 against 16 us per entry, manipulator_control's augmented system).
"""

from bisect import bisect_left

import numpy as np


class PatternSlots:
    """The positions of a packed (n, n) pattern's entries.

    Parameters
    ----------
    keys : ndarray of int64
        Per stored entry, in storage order: its column's position times n plus its row
        (increasing).
    position_column : ndarray of int64 (n,)
        Each column's position in the storage order.
    """

    def __init__(self, keys, position_column):
        self.n = position_column.size
        self._keys, self._position_column = keys, position_column
        self._key_list = self._column_list = None  # for single entries, made when asked

    def __call__(self, rows, columns):
        """The positions of the entries (rows, columns) (arrays of int, any shape; the
        result has their shape); ValueError if an entry is not in the pattern."""
        rows, columns = np.asarray(rows, dtype=np.int64), np.asarray(columns, dtype=np.int64)
        if rows.size == 1:
            return np.full(rows.shape, self._one(int(rows.flat[0]), int(columns.flat[0])),
                           dtype=np.int64)
        keys = self._position_column[columns] * self.n + rows
        slots = np.searchsorted(self._keys, keys)
        missing = (slots >= self._keys.size) | (
            self._keys[np.minimum(slots, self._keys.size - 1)] != keys)
        if np.any(missing):
            first = np.flatnonzero(missing.reshape(-1))[0]
            raise ValueError(f"entry ({rows.reshape(-1)[first]}, {columns.reshape(-1)[first]})"
                             " is not in the pattern")
        return slots

    def _one(self, row, column):
        """The position of one entry, by bisection of the keys as a list."""
        if self._key_list is None:
            self._key_list = self._keys.tolist()
            self._column_list = self._position_column.tolist()
        inside = 0 <= row < self.n and 0 <= column < self.n
        key = self._column_list[column] * self.n + row if inside else -1
        at = bisect_left(self._key_list, key)
        if not inside or at == len(self._key_list) or self._key_list[at] != key:
            raise ValueError(f"entry ({row}, {column}) is not in the pattern")
        return at
