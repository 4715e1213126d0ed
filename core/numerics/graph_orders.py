"""Orders of a sparse pattern from its graph: a maximum matching of rows to columns and the
reverse Cuthill-McKee order, on the pattern's (row, column) entries.

Every model's packing orders its constraint Jacobian and augmented system with these (the
engine's `orders`). scipy.sparse.csgraph has both, but importing it costs a command 0.23 s of
CPU (scipy.sparse and, through csgraph, scipy.linalg): more than a 10 ms simulation takes,
for graphs of at most a few thousand nodes that plain Python orders in milliseconds.

Both are deterministic, with ties broken by index (a node's own number in the pattern), so the
same pattern gives the same order on every machine:

- `matching`: Hopcroft-Karp (augmenting paths along shortest alternating paths, O(E sqrt(V)))
  after a greedy start; each row's columns are tried in increasing order.
- `reverse_cuthill_mckee`: as George & Liu and scipy's: the components started from their
  node of least degree, breadth first, each node's unvisited neighbours appended by increasing
  degree; the whole order reversed.
"""

from collections import deque

import numpy as np


def _adjacency(first, second, n):
    """Each node's neighbours (sorted, unique) from the entries (first[k], second[k])."""
    neighbours = [set() for _ in range(n)]
    for a, b in zip(first.tolist(), second.tolist(), strict=True):
        neighbours[a].add(b)
    return [sorted(s) for s in neighbours]


def matching(rows, cols, n):
    """A maximum matching of the rows to the columns of an (n, n) pattern.

    Parameters
    ----------
    rows, cols : array of int
        The pattern's entries (duplicates allowed).
    n : int
        Its size.

    Returns
    -------
    ndarray of int64 (n,)
        The column matched to each row, -1 for a row left unmatched (a structurally singular
        pattern).
    """
    adjacency = _adjacency(np.asarray(rows), np.asarray(cols), n)
    column_of_row = [-1] * n
    row_of_column = [-1] * n
    for r in range(n):  # greedy start: the first free column of each row
        for c in adjacency[r]:
            if row_of_column[c] < 0:
                column_of_row[r], row_of_column[c] = c, r
                break
    unreached = n + 1
    while True:
        # breadth first from the free rows: each row's distance along alternating paths
        distance = [unreached] * n
        queue = deque(r for r in range(n) if column_of_row[r] < 0)
        for r in queue:
            distance[r] = 0
        found = False
        while queue:
            r = queue.popleft()
            for c in adjacency[r]:
                mate = row_of_column[c]
                if mate < 0:
                    found = True
                elif distance[mate] == unreached:
                    distance[mate] = distance[r] + 1
                    queue.append(mate)
        if not found:
            return np.asarray(column_of_row, dtype=np.int64)
        for r in range(n):
            if column_of_row[r] < 0:
                _augment(r, adjacency, distance, column_of_row, row_of_column)


def _augment(start, adjacency, distance, column_of_row, row_of_column):
    """One augmenting path from the free row `start` along increasing distances (an explicit
    stack: paths may be longer than Python's recursion allows); True when found."""
    path = [(start, 0)]  # (row, index of the next column to try)
    while path:
        r, k = path[-1]
        if k == len(adjacency[r]):
            distance[r] = len(distance) + 1  # a dead end in this phase
            path.pop()
            continue
        path[-1] = (r, k + 1)
        c = adjacency[r][k]
        mate = row_of_column[c]
        if mate < 0:  # a free column: flip the path's edges
            for row, next_index in reversed(path):
                column = adjacency[row][next_index - 1]
                column_of_row[row], row_of_column[column] = column, row
            return True
        if distance[mate] == distance[r] + 1:
            path.append((mate, 0))
    return False


def reverse_cuthill_mckee(rows, cols, n):
    """The reverse Cuthill-McKee order of the symmetric pattern of entries (rows, cols) plus
    their transposes.

    Returns
    -------
    ndarray of int64 (n,)
        order[i]: the node at position i.
    """
    rows, cols = np.asarray(rows), np.asarray(cols)
    adjacency = _adjacency(np.concatenate([rows, cols]), np.concatenate([cols, rows]), n)
    degree = [len(a) for a in adjacency]
    by_degree = sorted(range(n), key=lambda node: (degree[node], node))
    visited = [False] * n
    order = []
    for start in by_degree:
        if visited[start]:
            continue
        visited[start] = True
        queue = deque([start])
        while queue:
            node = queue.popleft()
            order.append(node)
            fresh = [m for m in adjacency[node] if not visited[m]]
            fresh.sort(key=lambda m: (degree[m], m))
            for m in fresh:
                visited[m] = True
            queue.extend(fresh)
    return np.asarray(order[::-1], dtype=np.int64)
