"""A touching BEAM's mass on its z-coordinates, from the BEAM's closed-form element mass.

A BEAM that joins a rigid cluster to the rest (a "touching" element, `rigid`) has its mass on
its z-coordinates, the masters' and its free nodes' coordinates that its own 14 follow:

    Me_z = T_e^T Me T_e  (mz, mz),   f_c = T_e^T Me c_e  (mz,)

with T_e (14, mz) its block of T (each row at most `DEPENDENCIES` weights: a slave's
translation moves with its master's translation and Euler parameters, its Euler parameters
with the master's), c_e the slaves' second-order accelerations at its coordinates (slot
rigid_c; m/s^2) and Me = Dp^T Mp Dp the BEAM's element mass in closed form
(`elements.beam_mass.beam_element_mass`). The generic path (`rigid_kernels.touching_mass`)
forms Dp_z = Dp T_e first and then Dp_z^T Mp Dp_z along rows of the padded width: about
7.7k multiplications a BEAM; here Me (about 970) and two passes over T_e's terms, each a
row of Me or of Me T_e scaled by a weight (about 62 terms a BEAM, each along a row of the
padded width): about 3k. The same products summed in another order: equal to round-off.

The inner loops run along whole rows of the padded width (`point_masses.padded_width`), a
length the compiler does not know, so that it runs them in vectors (a loop of a constant 16
is unrolled first and then runs scalar). Units as the coordinates: kg, kg m, kg m^2; N, N m.
"""

from ..elements.beam_mass import M, beam_element_mass
from ..mechanics.rigid_bodies import DEPENDENCIES
from ..numerics.jit import kernel
from .point_masses import padded_width

# the scratch (slot rigid_local) of `touching_beam_mass` and its caller: four (14, 16) rows'
# blocks and Me (14 * 14), then the caller's Me_z (at most 14 * 14), c_e and f_c (14 each)
SCRATCH = 4 * M * 16 + 2 * M * M + 2 * M

@kernel(inline="always")
def _rows_by_terms(terms, start, W, source, out, stride):
    """out[zl] += w source[a] (rows of `stride`) over every term (zl, w) of T_e's row a: out =
    T_e^T source, for T_e's terms from `start` in `terms` (slot rigid_terms) and weights W."""
    for a in range(M):
        row = source[a * stride: (a + 1) * stride]
        for u in range(DEPENDENCIES):
            p = start + 2 * (a * DEPENDENCIES + u)
            zl, w = terms[p], terms[p + 1]
            if w == -2:
                continue
            weight = 1.0 if w == -1 else W[w]
            target = out[zl * stride: (zl + 1) * stride]
            for j in range(stride):
                target[j] += weight * row[j]


@kernel
def touching_beam_mass(terms, start, W, mz, Mp, Dp, c_e, Me_z, f_c, local):
    """Me_z = T_e^T Me T_e (mz * mz, row by row; kg, kg m, kg m^2) and f_c = T_e^T Me c_e
    (mz,; N, N m per the c_e (14,) given, m/s^2) of a touching BEAM with mz <= 14
    z-coordinates whose T_e has its terms from `start` in `terms` (slot rigid_terms: per
    local coordinate `DEPENDENCIES` pairs of a z-local column and a weight's index into W,
    -1 a unit weight, -2 none), with Me = Dp^T Mp Dp in closed form for its Mp (24 * 24,
    flat) and Dp (24, 14) (of the structure `beam_mass.beam_structured` checks). `local`:
    scratch of at least 4 * 14 * 16 + 14 * 14 entries."""
    stride = padded_width(mz + 1)  # mz <= 14 (7 a node): one lane more for Me c_e
    size = M * stride
    Me = local[4 * size: 4 * size + M * M]
    padded, TM, MT, Z = (local[:size], local[size: 2 * size], local[2 * size: 3 * size],
                         local[3 * size: 4 * size])
    beam_element_mass(Mp, Dp, Me)
    # Me in rows of the padded width, Me c_e in the lane after its 14 columns
    for r in range(3 * size):
        padded[r] = 0.0
    for a in range(M):
        s = 0.0
        for b in range(M):
            padded[a * stride + b] = Me[a * M + b]
            s += Me[a * M + b] * c_e[b]
        padded[a * stride + M] = s
    _rows_by_terms(terms, start, W, padded, TM, stride)  # TM = T_e^T [Me, Me c_e] (mz rows)
    for zl in range(mz):  # MT = (T_e^T Me)^T = Me T_e (Me symmetric; 14 rows), and f_c
        for b in range(M):
            MT[b * stride + zl] = TM[zl * stride + b]
        f_c[zl] = TM[zl * stride + M]
    for r in range(size):
        Z[r] = 0.0
    _rows_by_terms(terms, start, W, MT, Z, stride)  # Z = T_e^T Me T_e (mz rows)
    for a in range(mz):
        for b in range(mz):
            Me_z[a * mz + b] = Z[a * stride + b]
