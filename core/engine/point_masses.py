"""One element's inertia through its points, as the engine's evaluations use it.

For an element with P inertia points p = p(x_e) (m, or rad for rotary inertia; Dp = dp/dx_e,
(P, m)) and their constant mass matrix Mp (P, P; kg, kg m^2): the point forces w = Mp f for
point values f (N per unit mass: gravity, minus the accelerations), and the element mass
Me = Dp^T Mp Dp (m, m), visiting only the entries of Mp that the element's type fills and the
entries of Dp that are not zero (`motion`, `rigid`'s touching elements).
"""

from ..numerics.jit import kernel


@kernel
def element_mass(Mp, pattern, P, m, Dp, point, w, Me, columns):
    """One element's w = Mp point (P,) and Me = Dp^T Mp Dp (m * m, row by row), visiting
    only the entries of Mp in `pattern` (flat p P + q) and the non-zero entries of Dp (each
    point moves with few coordinates: a BEAM's with 1 or 4 of 14). Leaves in `columns` the
    non-zero columns of each row p of Dp (at p m ...) and their counts (at P m + p)."""
    point_columns(P, m, Dp, columns)
    counts = columns[P * m:]
    point_forces(Mp, pattern, P, point, w)
    for a in range(m * m):
        Me[a] = 0.0
    for e in range(pattern.size):
        pp, qq = divmod(pattern[e], P)
        mpq = Mp[pattern[e]]
        for u in range(counts[pp]):
            a = columns[pp * m + u]
            da = mpq * Dp[pp, a]
            for v in range(counts[qq]):
                b = columns[qq * m + v]
                Me[a * m + b] += da * Dp[qq, b]


@kernel
def dense_element_mass(Mp, pattern, P, m, D, MD, Me):
    """Me = D^T Mp D (m * m, row by row) as D^T (Mp D), MD = Mp D (P * m) scratch, for a D
    (P, m) whose rows are mostly full (a touching element's Dp T_e: a slave's point moves with
    its master's translation and rotation): the inner loops run along contiguous rows, which
    vectorise, instead of over the few non-zeros `element_mass` visits. The same products
    summed in another order: equal to round-off."""
    for r in range(P * m):
        MD[r] = 0.0
    for e in range(pattern.size):
        pp, qq = divmod(pattern[e], P)
        mpq = Mp[pattern[e]]
        for b in range(m):
            MD[pp * m + b] += mpq * D[qq, b]
    for a in range(m * m):
        Me[a] = 0.0
    for pp in range(P):
        for a in range(m):
            d = D[pp, a]
            if d == 0.0:
                continue
            for b in range(m):
                Me[a * m + b] += d * MD[pp * m + b]


@kernel
def point_columns(P, m, Dp, columns):
    """The non-zero columns of each row p of Dp (P, m) into `columns` (at p m ...) and their
    counts (at P m + p)."""
    counts = columns[P * m:]
    for pp in range(P):
        k = 0
        for a in range(m):
            if Dp[pp, a] != 0.0:
                columns[pp * m + k] = a
                k += 1
        counts[pp] = k


@kernel
def point_forces(Mp, pattern, P, point, w):
    """w = Mp point (P,) over the entries of Mp in `pattern` (flat p P + q)."""
    for pp in range(P):
        w[pp] = 0.0
    for e in range(pattern.size):
        pp, qq = divmod(pattern[e], P)
        w[pp] += Mp[pattern[e]] * point[qq]
