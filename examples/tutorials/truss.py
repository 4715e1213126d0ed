"""Tutorial 1: a mass on a truss spring, from a Python dictionary to a static deflection, a
natural frequency and a step response, each against its hand calculation.

    python examples/tutorials/truss.py

A PLTRUSS from a fixed node to a node that slides along x (its y fixed) carries a 0.2 kg mass.
The truss's axial stiffness is k = EA / l0; its own mass rho_A l0 adds a third to the moving
end (the consistent mass of a rod). SI units: m, kg, N, s.
"""

import numpy as np

from flexure.core import build_model, natural_frequencies, simulate, static_equilibrium

EA, L0, MASS, RHO_A, FORCE = 100.0, 0.1, 0.2, 0.3, 1.0  # N, m, kg, kg/m, N

SCENE = {
    "scene": {"name": "tutorial_truss", "dimension": 2},
    "sections": {"rod": {"EA": EA, "rho_A": RHO_A}},
    "nodes": {
        "base": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
        "tip": {"position": [L0, 0.0], "fixed": ["y"], "dof": ["x"], "mass": MASS,
                "force": [FORCE, 0.0]},
    },
    "elements": {"rod": {"type": "PLTRUSS", "nodes": ["base", "tip"], "section": "rod",
                         "released": ["e1"]}},
    "outputs": {"x": {"node": "tip", "coordinate": "x"}},
}


def main():
    """Build, analyse and simulate; print each result beside its hand calculation and return
    them as {name: (flexure, hand)}."""
    model = build_model(SCENE, source="examples/tutorials/truss.py")
    k = EA / L0                       # N/m
    m = MASS + RHO_A * L0 / 3.0       # kg: the tip mass and a third of the rod's
    # 1. the static deflection under the 1 N at the tip (the nonlinear statics: a truss is
    #    linear along its axis, so it is FORCE / k exactly)
    static = static_equilibrium(model)
    deflection = static.q[0] - L0
    # 2. the natural frequency of the linearised model
    frequency = natural_frequencies(model).frequencies_hz[0]
    # 3. the undamped step response x(t) = L0 + FORCE / k (1 - cos(w t)): its first peak
    w = np.sqrt(k / m)
    t_peak = np.pi / w
    result = simulate(model, t_peak, rtol=1e-10, output_times=np.linspace(0.0, t_peak, 201))
    peak = result.outputs["x"].max() - L0
    rows = {"static deflection (m)": (deflection, FORCE / k),
            "natural frequency (Hz)": (frequency, w / (2 * np.pi)),
            "first peak of the step response (m)": (peak, 2 * FORCE / k)}
    print(f"{'quantity':38s} {'flexure':>14s} {'by hand':>14s}")
    for name, (ours, hand) in rows.items():
        print(f"{name:38s} {ours:14.9g} {hand:14.9g}")
    return rows


if __name__ == "__main__":
    main()
