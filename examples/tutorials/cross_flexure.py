"""Tutorial 4: your own mechanism, a cross-flexure pivot: its rotational stiffness against the
hand formula, and a mesh-refinement study of its buckling load.

    python examples/tutorials/cross_flexure.py [--plot buckling.png]

Two steel leaves at +-45 degrees cross at their midpoints (they pass each other, not joined)
and carry a rigid body above a fixed base: a pivot about the crossing. The scene lists no DOFs:
flexure chooses the one this mechanism has and says which. Each leaf is one PLBEAM whose
bending is released and whose elongation is prescribed zero, split into `segments` beams for
the refinement study. SI units: m, N, kg.

1. Rotational stiffness: a moment M on the body turns it by theta about the crossing. A leaf
   clamped in the base whose upper end turns by theta about the leaf's midpoint has the end
   slope theta and the end deflection theta L / 2, which the quadratic theta x^2 / (2 L)
   meets: constant curvature theta / L, a bending moment EI theta / L along the leaf. Two
   leaves: K = M / theta = 2 EI / L, which one Hermite beam per leaf represents exactly.
2. Buckling under a vertical load on the body: the load factor of a 1 N reference load, with
   1, 2, 4, 8 and 16 beams per leaf. The buckled shape is no cubic, so the factor converges
   from above as the mesh is refined, its error falling as h^4 (as the course notes' refined
   springs do, tests/test_convergence.py).
"""

import argparse
import copy

from flexure.core import buckling_load_factors, build_model, static_equilibrium

E, WIDTH, THICKNESS, LENGTH = 2.1e11, 0.02, 0.0003, 0.04  # Pa, m, m, m (each leaf's length)
EI = E * WIDTH * THICKNESS ** 3 / 12.0  # N m^2
HALF = LENGTH / 8 ** 0.5  # m: the horizontal (and vertical) half extent of a 45-degree leaf
MOMENT = 1e-3  # N m: small, so the pivot answers linearly
SEGMENTS = (1, 2, 4, 8, 16)

SCENE = {
    "scene": {"name": "cross_flexure", "dimension": 2},
    "sections": {"leaf": {"E": E, "rho": 7850.0, "width": WIDTH, "height": THICKNESS},
                 "body": {"rho_A": 1.0}},
    "nodes": {
        # the base: where the leaves start, fixed
        "a": {"position": [-HALF, 0.0], "fixed": ["x", "y"]},
        "a_r": {"angle": 0.0, "fixed": ["phi"]},
        "b": {"position": [HALF, 0.0], "fixed": ["x", "y"]},
        "b_r": {"angle": 0.0, "fixed": ["phi"]},
        # the body: the leaves' upper ends and its middle, where the loads act
        "c": {"position": [HALF, 2 * HALF]},
        "c_r": {"angle": 0.0},
        "d": {"position": [-HALF, 2 * HALF]},
        "d_r": {"angle": 0.0},
        "m": {"position": [0.0, 2 * HALF]},
        "m_r": {"angle": 0.0, "moment": MOMENT},
    },
    "elements": {
        "leaf_1": {"type": "PLBEAM", "nodes": ["a", "a_r", "c", "c_r"], "section": "leaf",
                   "released": ["e2", "e3"]},
        "leaf_2": {"type": "PLBEAM", "nodes": ["b", "b_r", "d", "d_r"], "section": "leaf",
                   "released": ["e2", "e3"]},
        "body_1": {"type": "PLBEAM", "nodes": ["d", "d_r", "m", "m_r"], "section": "body"},
        "body_2": {"type": "PLBEAM", "nodes": ["m", "m_r", "c", "c_r"], "section": "body"},
    },
    "buckling": {"forces": [{"node": "m", "force": [0.0, -1.0]}]},
}


def model_with(segments):
    """The pivot with each leaf in `segments` beams."""
    data = copy.deepcopy(SCENE)
    for leaf in ("leaf_1", "leaf_2"):
        data["elements"][leaf]["segments"] = segments
    return build_model(data, source="examples/tutorials/cross_flexure.py")


def main(argv=None):
    """Print the stiffness beside 8 EI / L and the buckling study; return (stiffness N m/rad,
    hand N m/rad, [(segments, DOFs, load factor N)])."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="PNG", help="plot the load factor against the mesh")
    args = parser.parse_args(argv)

    model = model_with(1)
    print(f"DOFs chosen by flexure: {', '.join(model.chosen_dofs)}")
    static = static_equilibrium(model)
    theta = static.coordinates()["m_r.phi"]  # rad
    stiffness, hand = MOMENT / theta, 2.0 * EI / LENGTH
    print(f"rotational stiffness (N m/rad) {stiffness:.9g} {hand:.9g}")

    rows = []
    for n in SEGMENTS:
        refined = model_with(n)
        factor = buckling_load_factors(refined, 1)[0]  # N, for the 1 N reference load
        rows.append((n, refined.ndof, factor))
    print("\nsegments per leaf  DOFs  buckling load (N)  change from the coarser mesh")
    for k, (n, ndof, factor) in enumerate(rows):
        change = "" if k == 0 else f"{factor / rows[k - 1][2] - 1.0:+.3e}"
        print(f"{n:17d}  {ndof:4d}  {factor:17.9g}  {change}")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        figure, axes = plt.subplots(figsize=(6.0, 3.6))
        axes.semilogx([r[0] for r in rows], [r[2] for r in rows], "o-", base=2)
        axes.set_xlabel("beams per leaf")
        axes.set_ylabel("buckling load (N)")
        axes.set_title("cross-flexure pivot: the buckling load under mesh refinement")
        axes.grid(True, linewidth=0.3)
        figure.tight_layout()
        figure.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")
    return stiffness, hand, rows


if __name__ == "__main__":
    main()
