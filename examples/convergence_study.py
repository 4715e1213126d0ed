"""Mesh convergence of the PLBEAM element: buckling of the leaf-spring stage and the elastica.

1. Buckling. The stage of `stage_planar_1dof.toml` with each leaf spring split into n PLBEAMs
   (bending released, elongation rigid) under 1 N downward on the bar, half over each spring:
   the load factor converges to the continuous clamped-guided value 2 pi^2 EI / l0^2 = 77.72 N
   (one element gives 2 x 10 EI / l0^2 = 78.75 N). Equal loads matter: with the whole 1 N over
   one spring (the course-note load case) one element still gives 78.75 N, because its
   geometric stiffness is linear in the load, but the continuous frame then buckles at a lower
   load (about 76.5 N), as the unloaded spring's stiffness is not linear in the other's load.
2. Elastica. A clamped cantilever of n inextensible PLBEAMs under a tip load P perpendicular
   to it (dead load, fixed direction): the tip displacements converge to the exact elastica,
   computed here by shooting on EI theta'' = -P cos(theta) (an independent computation), and
   published by Mattiasson (1981) for P L^2 / EI up to 10.

Run `python examples/convergence_study.py` for the tables and convergence_study.png.
"""

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from flexure.core import buckling_load_factors, build_model, static_equilibrium

E, WIDTH, THICKNESS, RHO = 2.1e11, 0.018, 0.0005, 7850.0
EI = E * WIDTH * THICKNESS**3 / 12  # N m^2, one leaf spring: 0.039375
L0 = 0.1  # m

# Mattiasson, K. (1981) Numerical results from large deflection beam and frame problems
# analysed by means of elliptic integrals. Int. J. Numer. Meth. Eng. 17, 145-153, Table I:
# P L^2 / EI -> (horizontal tip displacement u / L, vertical tip displacement w / L).
MATTIASSON_1981 = {
    1.0: (0.05643, 0.30172),
    2.0: (0.16064, 0.49346),
    3.0: (0.25442, 0.60325),
    4.0: (0.32894, 0.66996),
    5.0: (0.38763, 0.71379),
    10.0: (0.55500, 0.81061),
}


def _spring_nodes(prefix, x, n, *, fixed_base):
    """Nodes of a vertical spring at abscissa x from y = 0 to L0 split into n elements."""
    nodes = {}
    for j in range(n + 1):
        t = {"position": [x, L0 * j / n]}
        r = {"angle": 0.0}
        if j == 0 and fixed_base:
            t["fixed"], r["fixed"] = ["x", "y"], ["phi"]
        elif 0 < j < n:
            t["dof"], r["dof"] = ["x"], ["phi"]
        nodes[f"{prefix}{j}"], nodes[f"{prefix}{j}r"] = t, r
    return nodes


def refined_stage(n):
    """The 1-DOF leaf-spring stage with n PLBEAMs per spring (4n - 3 DOFs)."""
    nodes = {**_spring_nodes("L", 0.0, n, fixed_base=True),
             **_spring_nodes("R", L0, n, fixed_base=True)}
    nodes[f"L{n}"]["dof"] = ["x"]
    elements = {
        "bar": {"type": "PLBEAM", "nodes": [f"L{n}", f"L{n}r", f"R{n}", f"R{n}r"],
                "section": "bar"},
    }
    for side in "LR":
        for j in range(n):
            elements[f"{side}{j}"] = {
                "type": "PLBEAM", "section": "leaf", "released": ["e2", "e3"],
                "nodes": [f"{side}{j}", f"{side}{j}r", f"{side}{j + 1}", f"{side}{j + 1}r"],
            }
    return build_model({
        "scene": {"name": f"stage_refined_{n}"},
        "sections": {"leaf": {"E": E, "width": WIDTH, "height": THICKNESS, "rho": RHO},
                     "bar": {"rho_A": 2.06}},
        "nodes": nodes,
        "elements": elements,
        "buckling": {"forces": [{"node": f"L{n}", "force": [0.0, -0.5]},
                                {"node": f"R{n}", "force": [0.0, -0.5]}]},
    })


def buckling_convergence(counts=(1, 2, 4, 8, 16)):
    """Rows (n, load factor, relative error) against 2 pi^2 EI / l0^2."""
    exact = 2 * np.pi**2 * EI / L0**2
    rows = []
    for n in counts:
        factor = buckling_load_factors(refined_stage(n), 1)[0]
        rows.append((n, factor, factor / exact - 1.0))
    return exact, rows


def cantilever(n, load_parameter, *, length=1.0, flexural_rigidity=1.0):
    """A clamped cantilever along x of n inextensible PLBEAMs, tip load -P in y.

    P = load_parameter * EI / L^2. The DOFs are the bending deformations e2, e3 of every
    element (relative DOFs stay regular at any deflection).
    """
    nodes = {"0": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
             "0r": {"angle": 0.0, "fixed": ["phi"]}}
    elements = {}
    for j in range(1, n + 1):
        nodes[str(j)] = {"position": [length * j / n, 0.0]}
        nodes[f"{j}r"] = {"angle": 0.0}
        elements[f"b{j}"] = {"type": "PLBEAM", "section": "s", "dof": ["e2", "e3"],
                             "nodes": [str(j - 1), f"{j - 1}r", str(j), f"{j}r"]}
    load = load_parameter * flexural_rigidity / length**2
    nodes[str(n)]["force"] = [0.0, -load]
    return build_model({
        "scene": {"name": f"cantilever_{n}"},
        "sections": {"s": {"EA": 1.0, "EI": flexural_rigidity}},
        "nodes": nodes, "elements": elements,
    })


def cantilever_tip(n, load_parameter, *, load_steps=20):
    """(u / L, w / L) of the tip of the n-element cantilever."""
    model = cantilever(n, load_parameter)
    x = static_equilibrium(model, load_steps=load_steps).coordinates()
    return 1.0 - x[f"{n}.x"], -x[f"{n}.y"]


def elastica_tip(load_parameter):
    """The exact tip displacements (u / L, w / L) of the elastica, by shooting.

    theta'' = -alpha cos(theta) on s in [0, 1], theta(0) = 0, theta'(1) = 0, integrated with
    rtol 1e-12; the root curvature is found by Brent's method to 1e-14.
    """
    alpha = load_parameter

    def shoot(curvature):
        solution = solve_ivp(
            lambda s, y: [y[1], -alpha * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])],
            (0.0, 1.0), [0.0, curvature, 0.0, 0.0], rtol=1e-12, atol=1e-14)
        return solution.y[:, -1]

    curvature = brentq(lambda k: shoot(k)[1], 1e-9, alpha, xtol=1e-14)
    _, _, x_tip, y_tip = shoot(curvature)
    return 1.0 - x_tip, y_tip


def elastica_convergence(load_parameter=10.0, counts=(4, 8, 16, 32)):
    """Rows (n, u/L, w/L, relative error of w) against the exact elastica."""
    _, w_exact = elastica_tip(load_parameter)
    rows = []
    for n in counts:
        u, w = cantilever_tip(n, load_parameter)
        rows.append((n, u, w, w / w_exact - 1.0))
    return rows


def observed_order(errors, ratio=2.0):
    """Observed orders of convergence log(e_n / e_2n) / log(2) of successive errors."""
    errors = np.abs(np.asarray(errors))
    return np.log(errors[:-1] / errors[1:]) / np.log(ratio)


def main(plot="convergence_study.png"):
    from flexure.core.reporting.tables import format_table

    exact, rows = buckling_convergence()
    orders = observed_order([r[2] for r in rows])
    print(format_table(["elements per spring", "load factor (N)", "relative error", "order"],
                       [(*r, o) for r, o in zip(rows, [np.nan, *orders], strict=True)],
                       title=f"buckling of the stage -> 2 pi^2 EI / l0^2 = {exact:.5f} N"))
    table = []
    for alpha, (u_pub, w_pub) in MATTIASSON_1981.items():
        u_ex, w_ex = elastica_tip(alpha)
        u_fe, w_fe = cantilever_tip(32, alpha)
        table.append((alpha, u_pub, u_ex, u_fe, w_pub, w_ex, w_fe))
    print(format_table(["PL^2/EI", "u/L publ.", "u/L exact", "u/L n=32", "w/L publ.",
                        "w/L exact", "w/L n=32"], table,
                       title="\nelastica: Mattiasson (1981), shooting, flexure with 32 PLBEAMs"))
    elastica = elastica_convergence()
    print(format_table(["elements", "u/L", "w/L", "relative error of w", "order"],
                       [(*r, o) for r, o in zip(elastica, [np.nan, *observed_order(
                           [r[3] for r in elastica])], strict=True)],
                       title="\nelastica convergence at P L^2 / EI = 10"))
    if plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5, 4))
        ax.loglog([r[0] for r in rows], np.abs([r[2] for r in rows]), "o-",
                  label="buckling load factor")
        ax.loglog([r[0] for r in elastica], np.abs([r[3] for r in elastica]), "s-",
                  label="elastica tip deflection, PL²/EI = 10")
        ax.set_xlabel("elements per spring / cantilever")
        ax.set_ylabel("relative error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(plot, dpi=120)
        print(f"\nwrote {plot}")


if __name__ == "__main__":
    main()
