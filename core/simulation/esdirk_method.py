"""The Butcher tableaus of the ESDIRK integrators, in exact fractions.

The order-3 and order-4 tables are from Kennedy, C. A. and Carpenter, M. H. (2003), "Additive
Runge-Kutta schemes for convection-diffusion-reaction equations", Applied Numerical
Mathematics 44, 139-181: the implicit parts of ARK3(2)4L[2]SA and ARK4(3)6L[2]SA, which
SUNDIALS' ARKODE uses as its default order-3 and order-4 implicit methods
(ARKODE_ARK324L2SA_DIRK_4_2_3, ARKODE_ARK436L2SA_DIRK_6_3_4). The order-2 table is TR-BDF2
(Bank et al. 1985, a trapezoidal stage to c = 2 - sqrt(2), then BDF2 to 1) as an ESDIRK with
the order-3 embedded solution of Hosea, M. E. and Shampine, L. F. (1996), "Analysis and
implementation of TR-BDF2", Applied Numerical Mathematics 20, 21-37 (ARKODE_TRBDF2_3_3_2; its
stages are those of ARKODE's default order-2 method, ARKODE_ARK2_DIRK_3_1_2).

Each has c_1 = 0 and a_11 = 0 (the first stage is explicit: "E" SDIRK), the same diagonal gamma
on the other stages, is stiffly accurate (the last row of A is b: the last stage is the
solution), L-stable (R(z) -> 0 as z -> -inf) and of stage order 2; `b_hat` is the embedded
solution for the error estimate: one order lower for the order-3 and order-4 tables, one
higher for TR-BDF2 (its estimate is then the order-2 solution's own local error). The order-4
table is exact in these fractions; the others' gamma is irrational (the order-3 table's
fractions are the paper's rational approximations, its order conditions hold to about 1e-20;
TR-BDF2's sqrt(2) is a fraction exact to 1e-40). `tests/test_esdirk.py` checks the order
conditions and the stability function.
"""

from dataclasses import dataclass
from fractions import Fraction as _F

import numpy as np


@dataclass(frozen=True)
class Tableau:
    """An ESDIRK tableau: A (s, s) lower triangular, b = A[-1], b_hat, c = A 1, and the floating
    point arrays the compiled integrator takes (`arrays`)."""

    name: str
    A: tuple
    b_hat: tuple
    order: int
    embedded_order: int
    # whether the Newton starts of stages 2 and 3 take the last step's slope and curvature
    # (`esdirk_kernels.keep_history`): measured to pay for TR-BDF2 alone (docs/decisions.md)
    history: bool = False

    @property
    def stages(self):
        return len(self.A)

    @property
    def b(self):
        return self.A[-1]

    @property
    def c(self):
        return tuple(sum(row, _F(0)) for row in self.A)

    @property
    def gamma(self):
        return self.A[1][1]

    def predictor(self):
        """Weights P[i][j] of the stage derivatives F_j (j < i) whose sum predicts f(z_i), the
        start of stage i's Newton iteration: the polynomial in c through the last (up to three)
        stages, evaluated at c_i."""
        c, s = self.c, self.stages
        P = [[_F(0)] * s for _ in range(s)]
        for i in range(1, s):
            nodes = list(range(max(0, i - 3), i))
            for j in nodes:
                weight = _F(1)
                for k in nodes:
                    if k != j:
                        weight *= (c[i] - c[k]) / (c[j] - c[k])
                P[i][j] = weight
        return P

    def arrays(self):
        """(A (s, s), b - b_hat (s,), predictor (s, s)) as float64 arrays."""
        def table(rows):
            return np.array([[float(v) for v in row] for row in rows])

        difference = [float(b - bh) for b, bh in zip(self.b, self.b_hat, strict=True)]
        return table(self.A), np.array(difference), table(self.predictor())


_G3 = _F(1767732205903, 4055673282236)
ESDIRK3 = Tableau(
    name="ESDIRK3(2)4L[2]SA",
    A=((0, 0, 0, 0),
       (_G3, _G3, 0, 0),
       (_F(2746238789719, 10658868560708), _F(-640167445237, 6845629431997), _G3, 0),
       (_F(1471266399579, 7840856788654), _F(-4482444167858, 7529755066697),
        _F(11266239266428, 11593286722821), _G3)),
    b_hat=(_F(2756255671327, 12835298489170), _F(-10771552573575, 22201958757719),
           _F(9247589265047, 10645013368117), _F(2193209047091, 5459859503100)),
    order=3, embedded_order=2)

_G4 = _F(1, 4)
ESDIRK4 = Tableau(
    name="ESDIRK4(3)6L[2]SA",
    A=((0, 0, 0, 0, 0, 0),
       (_F(1, 4), _G4, 0, 0, 0, 0),
       (_F(8611, 62500), _F(-1743, 31250), _G4, 0, 0, 0),
       (_F(5012029, 34652500), _F(-654441, 2922500), _F(174375, 388108), _G4, 0, 0),
       (_F(15267082809, 155376265600), _F(-71443401, 120774400), _F(730878875, 902184768),
        _F(2285395, 8070912), _G4, 0),
       (_F(82889, 524892), 0, _F(15625, 83664), _F(69875, 102672), _F(-2260, 8211), _G4)),
    b_hat=(_F(4586570599, 29645900160), 0, _F(178811875, 945068544), _F(814220225, 1159782912),
           _F(-3700637, 11593932), _F(61727, 225920)),
    order=4, embedded_order=3)


def _sqrt2():
    """sqrt(2) as a fraction exact to about 1e-44 (TR-BDF2's gamma is irrational)."""
    from decimal import Decimal, localcontext

    with localcontext() as context:
        context.prec = 45
        return _F(Decimal(2).sqrt())


_R2 = _sqrt2()
_G2 = 1 - 1 / _R2  # (2 - sqrt(2)) / 2
TRBDF2 = Tableau(
    name="TR-BDF2",
    A=((0, 0, 0),
       (_G2, _G2, 0),
       (_R2 / 4, _R2 / 4, _G2)),
    b_hat=((1 - _R2 / 4) / 3, (3 * _R2 / 4 + 1) / 3, _G2 / 3),
    order=2, embedded_order=3, history=True)

# The two-stage SDIRK of Alexander, R. (1977), "Diagonally implicit Runge-Kutta methods for
# stiff O.D.E.'s", SIAM J. Numer. Anal. 14, 1006-1021 (Hairer & Wanner, Solving ODEs II,
# IV.6, with gamma = 1 - sqrt(2)/2): order 2, L-stable, stiffly accurate, both stages
# implicit. Written as an ESDIRK with a first stage nobody reads (its column of A, b_1 and
# b_hat_1 zero): `esdirk_kernels.first_stage_unread` then skips F_1 = f(y_n), so an input
# changed at y_n costs no input response. Its embedded solution y_hat = y_n + h f(z_1) (the
# first implicit stage's slope over the whole step) is of order 1 (b_hat c =
# gamma, not 1/2): the estimate h gamma (F_3 - F_2) is the first-order solution's local error,
# O(h^2). Stages at c = gamma and 1, so the predictor's line through F_1 (the last step's
# last stage) and F_2 extrapolates to c = 1.
SDIRK2 = Tableau(
    name="SDIRK2 (Alexander)",
    A=((0, 0, 0),
       (0, _G2, 0),
       (0, 1 - _G2, _G2)),
    b_hat=(0, 1, 0),
    order=2, embedded_order=1)

# by method name (core/simulation/methods.py)
TABLEAUS = {"esdirk": ESDIRK4, "esdirk3": ESDIRK3, "esdirk2": TRBDF2, "sdirk2": SDIRK2}
MAX_STAGES = max(t.stages for t in TABLEAUS.values())
