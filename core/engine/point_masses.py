"""One element's inertia through its points, as the engine's evaluations use it.

For an element with P inertia points p = p(x_e) (m, or rad for rotary inertia; Dp = dp/dx_e,
(P, m)) and their constant mass matrix Mp (P, P; kg, kg m^2): the point forces w = Mp f for
point values f (N per unit mass: gravity, minus the accelerations), the product Mp D with
rows of any length, and the element mass Me = Dp^T Mp Dp (m, m), visiting only the entries
of Mp that the element's type fills and the entries of Dp that are not zero (`motion`,
`tangent`, `rigid`'s touching elements). A touching element's Dp_z = Dp T_e and its mass go
along whole rows padded to a multiple of 16 entries (`padded_width`), the length from which
the compiler runs a loop of unknown length in vectors. The pattern of Mp is ascending (flat
p P + q), so its walks take p from its order.
"""

from ..numerics.jit import kernel
from ..numerics.native import call_inertia


@kernel(inline="always")
def element_points(inertia, scratch, i, x, xdot, order):
    """Element i of an inertia group (`slots.group_inertia`'s tuple) through its inertia
    entry: its point values (P,), Dp (P, m) and, for order 2, acc = (D2p v) v (P,) into the
    buffers `scratch` (`slots.inertia_scratch`'s tuple), from the coordinates x (NX,; m,
    rad) and, for order 2 only (the entries read v for acc alone), the velocities xdot (NX,;
    m/s, rad/s) of its coordinates, gathered into the scratch's x and v."""
    _, m, P, width, function, coords, refs, _, _, _ = inertia
    xl, vl, point, acc, _, Dp, _ = scratch
    for a in range(m):
        xl[a] = x[coords[i * m + a]]
        if order == 2:
            vl[a] = xdot[coords[i * m + a]]
    call_inertia(function, xl.ctypes.data, vl.ctypes.data, refs + 8 * i * width, order,
                 point.ctypes.data, Dp.ctypes.data, acc.ctypes.data, m, P, width)


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
    pp, end = 0, P  # the pattern is ascending: its rows p in order (`pattern_entry`)
    for e in range(pattern.size):
        pp, qq, mpq, end = pattern_entry(Mp, pattern[e], pp, end, P)
        for u in range(counts[pp]):
            a = columns[pp * m + u]
            da = mpq * Dp[pp, a]
            for v in range(counts[qq]):
                b = columns[qq * m + v]
                Me[a * m + b] += da * Dp[qq, b]


@kernel
def dense_element_mass(Mp, pattern, P, m, D, MD, Me, stride, column):
    """Me = D^T Mp D (m * m, row by row) as D^T (Mp D), for a D (P, m) whose rows are mostly
    full (a touching element's Dp T_e: a slave's point moves with its master's translation
    and rotation), stored with the row length `stride` >= m (`padded_width`; D's entries past
    m in a row zero). MD = Mp D (P * stride; `mass_rows_product`) scratch; Me needs room
    for m * stride. The inner loops run along whole padded rows, which the compiler
    vectorises (a row of a length it cannot know runs in vectors only when long enough: 16),
    instead of over the few non-zeros `element_mass` visits. The same products summed in
    another order: equal to round-off. `column` (m,; or empty) receives column m of D^T Mp D
    computed over D's first m columns, D_m^T Mp d for a vector d that the caller put in
    column m of D (stride > m): the product's padding lane, read before the packing."""
    mass_rows_product(Mp, pattern, P, D, stride, MD)
    for a in range(m * stride):
        Me[a] = 0.0
    for pp in range(P):
        source = MD[pp * stride: (pp + 1) * stride]
        for a in range(m):
            d = D[pp * stride + a]
            if d == 0.0:
                continue
            out = Me[a * stride: (a + 1) * stride]
            for b in range(stride):
                out[b] += d * source[b]
    if column.size > 0:
        for a in range(m):
            column[a] = Me[a * stride + m]
    for a in range(1, m):  # the rows packed to length m (each moves to a lower index)
        for b in range(m):
            Me[a * m + b] = Me[a * stride + b]


@kernel
def sparse_rows_product(P, m, Dp, columns, T, stride, D):
    """D = Dp T (P rows of length `stride`; flat) for T (m rows of length `stride`; flat),
    row p of D summing Dp[p, a] T[a] over the non-zero columns a of Dp's row p that
    `point_columns` left in `columns`, in their order."""
    counts = columns[P * m:]
    for r in range(P * stride):
        D[r] = 0.0
    for pp in range(P):
        out = D[pp * stride: (pp + 1) * stride]
        for u in range(counts[pp]):
            a = columns[pp * m + u]
            d = Dp[pp, a]
            source = T[a * stride: (a + 1) * stride]
            for b in range(stride):
                out[b] += d * source[b]


@kernel
def mass_rows_product(Mp, pattern, P, D, stride, MD):
    """MD = Mp D for D of P rows of length `stride` (flat; MD likewise), over the entries of
    Mp in `pattern` (flat p P + q): row p of MD sums Mp[p, q] D[q] in the pattern's order,
    along whole rows."""
    for r in range(P * stride):
        MD[r] = 0.0
    pp, end = 0, P  # the pattern is ascending: its rows p in order (`pattern_entry`)
    for e in range(pattern.size):
        pp, qq, mpq, end = pattern_entry(Mp, pattern[e], pp, end, P)
        out, source = MD[pp * stride: (pp + 1) * stride], D[qq * stride: (qq + 1) * stride]
        for b in range(stride):
            out[b] += mpq * source[b]


@kernel
def pattern_entry(Mp, flat, pp, end, P):
    """(p, q, Mp[p, q], (p + 1) P) of the pattern entry `flat` (= p P + q) of Mp (P P,
    flat), walking on from the previous entry's (pp, end): the pattern of Mp ascends, so its
    walks take p from its order instead of a division per entry."""
    while flat >= end:
        pp += 1
        end += P
    return pp, flat - end + P, Mp[flat], end


@kernel(inline="always")
def padded_width(m):
    """The row length `dense_element_mass` stores rows of m entries with: m rounded up to a
    multiple of 16."""
    return 16 * ((m + 15) // 16)


@kernel
def point_columns(P, m, Dp, columns):
    """The non-zero columns of each row p of Dp (P, m) into `columns` (at p m ...) and their
    counts (at P m + p)."""
    counts = columns[P * m:]
    for pp in range(P):
        k = 0
        for a in range(m):  # no branch: the next place moves on where Dp is not zero
            columns[pp * m + k] = a
            k += Dp[pp, a] != 0.0
        counts[pp] = k


@kernel
def point_forces(Mp, pattern, P, point, w):
    """w = Mp point (P,) over the entries of Mp in `pattern` (flat p P + q)."""
    for pp in range(P):
        w[pp] = 0.0
    pp, end = 0, P  # the pattern is ascending: its rows p in order (`pattern_entry`)
    for e in range(pattern.size):
        pp, qq, mpq, end = pattern_entry(Mp, pattern[e], pp, end, P)
        w[pp] += mpq * point[qq]


@kernel(inline="always")  # into its two callers' element loops
def add_point_forces(r, coords, P, m, Dp, w, columns):
    """r[coords] += Dp^T w (N, N m) over Dp's non-zeros, as `point_columns` lists them:
    one element's point forces w (P,) on its m coordinates `coords`."""
    counts = columns[P * m: P * m + P]
    for pp in range(P):
        for u in range(counts[pp]):
            a = columns[pp * m + u]
            r[coords[a]] += Dp[pp, a] * w[pp]


@kernel
def massless(Mp, pattern):
    """Whether every entry of Mp in `pattern` (flat p P + q) is zero: an element without mass
    (a rigid body's inner elements), whose point forces and mass are zero."""
    for e in range(pattern.size):
        if Mp[pattern[e]] != 0.0:
            return False
    return True
