"""Plot axes that do not magnify round-off.

matplotlib scales an axis to its data's span, so an output that stays put to the last bits
(a held coordinate at 1e-20 m, an angle at 1e-17 rad) is drawn as a curve filling the axes.
`hold_round_off` gives such an axis a span of ROUND_OFF times the quantity's scale around its
values instead, so it is drawn as the flat line it is, and says so.
"""

import numpy as np

ROUND_OFF = 1e-12  # relative: far above float64's 1e-16, far below a picometre on a metre
ANGLE_SCALE = 1.0  # rad: the scale of an angle


def unit_scales(values, units):
    """The scale of each unit among the columns of `values` (n, k) with `units` (k,): the
    largest |value| of its columns, at least ANGLE_SCALE for rad (an angle is of order 1)."""
    values = np.asarray(values, float)
    scales = {}
    for column, unit in enumerate(units):
        finite = values[:, column][np.isfinite(values[:, column])]
        largest = float(np.max(np.abs(finite), initial=0.0))
        scales[unit] = max(scales.get(unit, 0.0), largest)
    if "rad" in scales:
        scales["rad"] = max(scales["rad"], ANGLE_SCALE)
    return scales


def hold_round_off(ax, values, scale):
    """Give `ax` a span of 2 ROUND_OFF `scale` around `values` when they vary by less than
    that (round-off), with a note on the axes. Returns whether it did.

    Parameters
    ----------
    ax : matplotlib Axes
    values : array_like
        The values drawn on the axis (m, rad, ...).
    scale : float
        The quantity's scale in the same unit (`unit_scales`); 0 or less: nothing done.
    """
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    floor = ROUND_OFF * scale
    if values.size == 0 or floor <= 0 or np.ptp(values) >= floor:
        return False
    centre = 0.5 * (values.max() + values.min())
    ax.set_ylim(centre - floor, centre + floor)
    ax.text(0.01, 0.04, f"constant to round-off (varies by {np.ptp(values):.2g})",
            transform=ax.transAxes, fontsize=8, va="bottom", color="0.4")
    return True
