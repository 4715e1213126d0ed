"""The sparsest-row pivot of the sparse LU (`sparse_lu.factor` with the head's H_SPARSEST).

Partial pivoting takes the largest |x| of a column, whatever its row's fill. Where a matrix
holds rows far sparser than the rest (J's unit rows of the DOF coordinates, a slave's row of
T: 1 to 7 entries against a BEAM's 12 a row), that choice passes them over and the rows it
takes fill L and U. Threshold pivoting of Markowitz's kind (Duff, Erisman & Reid, Direct
Methods for Sparse Matrices, 7.8) takes, of the rows with |x| >= KEEP max |x|, the one with
the fewest entries in A (the largest |x| of those on a tie): the multipliers stay within
1 / KEEP = 2, and on manipulator_control's J (154 unknowns; its 12 unit rows now each the
pivot of its column, 4 before) a refactorisation costs 2498 multiplications instead of 3802,
a solve 1297 instead of 1709 (docs/benchmarks.md, session 39, branch rhs6). On its
augmented system it saves under 2 %, so that keeps partial pivoting. The counts are A's own
rows, not the active submatrix's: a static estimate that needs no updates in the column
loop.
"""

from .jit import kernel


@kernel
def row_counts(Ap, Ai, n, counts):
    """counts (n,) = the number of stored entries in each row of A (CSC: Ap, Ai)."""
    counts[:] = 0
    for p in range(Ap[n]):
        counts[Ai[p]] += 1


@kernel
def sparsest_row(x, stack, top, n, pinv, counts, bound):
    """Of the rows stack[top:n] not yet pivotal (pinv < 0) with |x| >= bound, the one with
    the fewest entries in A (counts), the largest |x| of those on a tie; -1 if none."""
    chosen, fewest, value = -1, 0, 0.0
    for t in range(top, n):
        i = stack[t]
        if pinv[i] < 0:
            v = abs(x[i])
            if v >= bound and (chosen < 0 or counts[i] < fewest
                               or (counts[i] == fewest and v > value)):
                chosen, fewest, value = i, counts[i], v
    return chosen
