"""Section properties of spatial beams from their dimensions: rectangles and circles.

Axes: x' along the beam, y' the principal axis the scene gives, z' = x' x y'. A rectangle
has `height` h along y' and `width` b along z' (as the planar scenes: height is the in-plane
bending thickness), so that

    A = b h,   Iz' = b h^3 / 12 (bending about z', deflection along y'),   Iy' = h b^3 / 12,
    Wz' = b h^2 / 6,   Wy' = h b^2 / 6                              (section moduli, m^3)

Torsion constant of a rectangle with long side a and short side t (Saint-Venant, the series
of Timoshenko and Goodier, Theory of Elasticity, sec. 109):

    It = a t^3 / 3 [1 - 192 / pi^5 (t / a) sum_{n odd} tanh(n pi a / (2 t)) / n^5]

and the largest shear stress, at the middle of the long sides, tau = T / Wt with

    Wt = It / (t [1 - 8 / pi^2 sum_{n odd} 1 / (n^2 cosh(n pi a / (2 t)))]).

A circle of diameter d: A = pi d^2 / 4, Iy' = Iz' = pi d^4 / 64, It = pi d^4 / 32,
Wy' = Wz' = pi d^3 / 32, Wt = pi d^3 / 16. Series terms are summed until they no longer change
the result in double precision (they fall off as n^-5 and n^-2 exp(-n pi a / 2t)).

The polar radius of gyration squared, the BEAM's Ip_A = (Iy' + Iz') / A (m^2, the factor of the
torsion term of its elongation): (b^2 + h^2) / 12 for a rectangle, d^2 / 8 for a circle. A
section given by its properties has it from (EIy + EIz) / EA (a homogeneous section), else from
(rho_Iy + rho_Iz) / rho_A, else not at all (0: no torsion term).

A planar section's rectangle has `height` in the plane (the bending thickness) and `width` out
of it: A = width height, EI = E width height^3 / 12, Wz = width height^2 / 6 (`planar_properties`).

The keys of a section's shape and material (E, width, rho, ...) are not properties an element
reads: `PLANAR` and `SPATIAL` (a `SectionCalculator` each) declare them with their units and
the properties they derive, so a section takes them where an element that uses it reads one of
those properties (`flexure.core.scene.scene_sections`).
"""

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..elements.protocol import SchemaKey


def _odd_terms(count=2001):
    return np.arange(1, 2 * count, 2, dtype=float)


def rectangle(width, height):
    """Section properties of a solid width x height rectangle (m): a dict in SI units.

    Keys A, Iy, Iz, It (m^4), Wy, Wz, Wt (m^3); `circular` = 0.
    """
    long_side, short_side = max(width, height), min(width, height)
    ratio = long_side / short_side
    n = _odd_terms()
    # n pi ratio / 2 >= 700 for every n >= 1 once ratio > 446: capping the ratio there keeps the
    # arguments as they were and their product finite for any strip, however thin
    argument = np.minimum(n * np.pi * min(ratio, 1e3) / 2.0, 700.0)
    torsion_sum = np.sum(np.tanh(argument) / n**5)
    it = long_side * short_side**3 / 3.0 * (1.0 - 192.0 / np.pi**5 / ratio * torsion_sum)
    decay = np.exp(-argument)
    shear_sum = np.sum(2.0 * decay / (1.0 + decay**2) / n**2)  # 1 / cosh without overflow
    wt = it / (short_side * (1.0 - 8.0 / np.pi**2 * shear_sum))
    return {"A": width * height, "Iy": height * width**3 / 12.0, "Iz": width * height**3 / 12.0,
            "It": float(it), "Wy": height * width**2 / 6.0, "Wz": width * height**2 / 6.0,
            "Wt": float(wt), "circular": 0.0}


def circle(diameter):
    """Section properties of a solid circle of `diameter` (m): a dict as `rectangle`."""
    d = diameter
    return {"A": np.pi * d**2 / 4.0, "Iy": np.pi * d**4 / 64.0, "Iz": np.pi * d**4 / 64.0,
            "It": np.pi * d**4 / 32.0, "Wy": np.pi * d**3 / 32.0, "Wz": np.pi * d**3 / 32.0,
            "Wt": np.pi * d**3 / 16.0, "circular": 1.0}


def beam_properties(values):
    """The BEAM section properties from a scene section (dict of numbers, SI units).

    Dimensions (`width` and `height`, or `diameter`) with `E` give A, EA, EIy, EIz, GIt and the
    section moduli; G from `G`, else from Poisson's ratio `nu` (default 0.3) as
    E / (2 (1 + nu)); `rho` gives rho_A, rho_Iy, rho_Iz; `beta` (s) gives stiffness-
    proportional damping EdA = beta EA, GdIt = beta GIt, ... ; Ip_A = (Iy + Iz) / A from the
    dimensions, else from the stiffnesses or the inertias (module docstring). Properties the
    section gives directly take precedence. Returns a new dict; raises ValueError naming what
    is missing.
    """
    result = dict(values)
    shape = None
    if "diameter" in values:
        if {"width", "height"} & values.keys():
            raise ValueError("give either diameter (a circle) or width and height (a "
                             "rectangle), not both")
        shape = circle(values["diameter"])
    elif {"width", "height"} & values.keys():
        missing = {"width", "height"} - values.keys()
        if missing:
            raise ValueError(f"a rectangle needs width and height; missing {sorted(missing)}")
        shape = rectangle(values["width"], values["height"])
    if shape is not None:
        for key in ("A", "Wy", "Wz", "Wt", "circular"):
            result.setdefault(key, shape[key])
        result.setdefault("Ip_A", (shape["Iy"] + shape["Iz"]) / shape["A"])
        if "E" in values:
            E = values["E"]
            G = values.get("G", E / (2.0 * (1.0 + values.get("nu", 0.3))))
            result.setdefault("EA", E * shape["A"])
            result.setdefault("EIy", E * shape["Iy"])
            result.setdefault("EIz", E * shape["Iz"])
            result.setdefault("GIt", G * shape["It"])
        elif not {"EA", "EIy", "EIz", "GIt"} <= values.keys():
            raise ValueError("a section with dimensions needs E (or EA, GIt, EIy and EIz)")
        if "rho" in values:
            result.setdefault("rho_A", values["rho"] * shape["A"])
            result.setdefault("rho_Iy", values["rho"] * shape["Iy"])
            result.setdefault("rho_Iz", values["rho"] * shape["Iz"])
    if "beta" in values:
        for damping, stiffness in (("EdA", "EA"), ("GdIt", "GIt"), ("EdIy", "EIy"),
                                   ("EdIz", "EIz")):
            result.setdefault(damping, values["beta"] * result.get(stiffness, 0.0))
    for whole, parts in (("EA", ("EIy", "EIz")), ("rho_A", ("rho_Iy", "rho_Iz"))):
        if "Ip_A" not in result and result.get(whole, 0.0) > 0.0:
            result["Ip_A"] = sum(result.get(part, 0.0) for part in parts) / result[whole]
    return result


def planar_properties(values):
    """The planar section properties from a scene section (dict of numbers, SI units).

    With `E`, `width` and `height` (a rectangle, height in the plane): EA, EI, and A, Wz for
    the stresses; with `rho` as well: rho_A. Properties the section gives directly take
    precedence. Returns a new dict; raises ValueError naming what is missing.
    """
    result = dict(values)
    dims = {"E", "width", "height"}
    if dims & values.keys():
        missing = dims - values.keys()
        if missing:
            raise ValueError(f"a rectangle needs E, width and height; missing {sorted(missing)}")
        area = values["width"] * values["height"]
        result.setdefault("EA", values["E"] * area)
        result.setdefault("EI", values["E"] * values["width"] * values["height"] ** 3 / 12)
        # for the stresses (sigma = N/A +- M/W): height is the in-plane thickness
        result.setdefault("A", area)
        result.setdefault("Wz", values["width"] * values["height"] ** 2 / 6)
        if "rho" in values:
            result.setdefault("rho_A", values["rho"] * area)
    return result


@dataclass(frozen=True)
class SectionCalculator:
    """The shape and material keys a section may give (`inputs`), the element properties they
    derive (`outputs`) and the function that derives them (`derive(values) -> values`, a new
    dict; ValueError naming what is missing)."""

    inputs: tuple
    outputs: frozenset
    derive: Callable


_E = SchemaKey("E", "Pa", "Young's modulus, with the dimensions: the stiffnesses")
_RHO = SchemaKey("rho", "kg/m3", "density, with the dimensions: the mass per length")
PLANAR = SectionCalculator(
    inputs=(_E, _RHO,
            SchemaKey("width", "m", "rectangle width, out of the plane", positive=True),
            SchemaKey("height", "m", "rectangle height, in the plane (the bending thickness)",
                      positive=True)),
    outputs=frozenset({"EA", "EI", "A", "Wz", "rho_A"}),
    derive=planar_properties)
SPATIAL = SectionCalculator(
    inputs=(_E, _RHO,
            SchemaKey("G", "Pa", "shear modulus (default E / (2 (1 + nu)))"),
            SchemaKey("nu", "1", "Poisson's ratio, for G", default=0.3),
            SchemaKey("width", "m", "rectangle width, along z'", positive=True),
            SchemaKey("height", "m", "rectangle height, along y'", positive=True),
            SchemaKey("diameter", "m", "circle diameter", positive=True),
            SchemaKey("beta", "s", "stiffness-proportional damping: EdA = beta EA, ...",
                      damping=True)),
    outputs=frozenset({"A", "Wy", "Wz", "Wt", "circular", "EA", "EIy", "EIz", "GIt", "rho_A",
                       "rho_Iy", "rho_Iz", "EdA", "GdIt", "EdIy", "EdIz", "Ip_A"}),
    derive=beam_properties)
CALCULATORS = {2: PLANAR, 3: SPATIAL}  # by the scene's dimension
