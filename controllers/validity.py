"""A loop's motion against the model's range of validity (flexure.core.RangeCheck): a move or
a stroke that takes a node farther than 0.25 times the mechanism's size from where it
started leaves the small-deformation flexure the scene describes. Said before the run (the
requested strokes and move targets) and after it (the positions the loops recorded), as
warnings: the run still goes, as `flexure simulate` does beyond the range."""

import numpy as np


def motion_warnings(model, displacements):
    """Messages for the displacements beyond the range of validity.

    Parameters
    ----------
    model : Model
    displacements : dict of str to float
        {name: largest displacement from the start}, m where the name is a translational
        coordinate ("3.x"); other names (angles) are not judged here.

    Returns
    -------
    list of str
        One message per coordinate beyond the bound, naming it, its displacement and the
        bound (m).
    """
    from flexure.core import RangeCheck

    check = RangeCheck(model)
    translations = {model.coordinate_names[i] for i in model.translations}
    return [f"{name} moves {abs(value):.3g} m, beyond the model's range of validity "
            f"({check.distance_bound:.3g} m: 0.25 x its size {check.scale:.3g} m); "
            "the result is not that of the flexure the scene describes"
            for name, value in displacements.items()
            if name in translations and np.isfinite(value) and abs(value) > check.distance_bound]


def loop_coordinates(model, design):
    """The coordinate each loop's output reads ("3.x"), or None for an angle about a global
    axis, in the loops' order."""
    names = []
    for pair in design.pairs:
        port = model.outputs[pair.output_index]
        names.append(None if port.coordinate is None else model.coordinate_names[port.coordinate])
    return names
