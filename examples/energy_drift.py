"""Energy drift of the undamped stage_planar_3dof in free vibration over 10 s.

The damping of the leaf springs is removed; the stage is released from rest in the static
equilibrium under the modal load M0 phi_1 (1 N sideways), so that it vibrates in its first
mode (10.6 Hz) with the stiff modes (2.1 and 3.6 kHz) excited only by the nonlinearity. The
mechanical energy (kinetic plus strain, `flexure.core.mechanics.energy.mechanical_energy`: the plain
numpy formulas, independent of the compiled engine that integrates) is compared with its
initial value every 0.5 s.

    python examples/energy_drift.py [--t-end 10] [--rtol 1e-9] [--method cvode-adams]
"""

import argparse
import time
import tomllib

import numpy as np
import scipy.linalg

from flexure.core import Simulator, build_model, linearize, scene_path, static_equilibrium
from flexure.core.mechanics.energy import mechanical_energy
from flexure.core.reporting.tables import format_table


def undamped_stage():
    data = tomllib.loads(scene_path("stage_planar_3dof").read_text())
    for section in data["sections"].values():
        section.pop("EdA", None)
        section.pop("EdI", None)
    return build_model(data, source="stage_planar_3dof (undamped)")


def modal_release(model, force=1.0):
    """The DOFs of the static equilibrium under the load M0 phi_1 scaled to `force` N on x."""
    lin = linearize(model)
    _, shapes = scipy.linalg.eigh(lin.K, lin.M0)
    f = lin.M0 @ shapes[:, 0]
    loads = model.loads.copy()
    loads[model.dof_coordinates] = force * f / abs(f[0])
    return static_equilibrium(model, loads=loads).q


def drift(*, t_end=10.0, rtol=1e-9, method="cvode-adams", interval=0.5):
    """Rows (t, relative energy change, steps, wall time) and the largest |drift|."""
    model = undamped_stage()
    q0 = modal_release(model)
    sim = Simulator(model, method=method, rtol=rtol)
    sim.reset(q0=q0)
    e0 = mechanical_energy(model, q0, np.zeros(q0.size))
    rows, start = [], time.perf_counter()
    for t in np.arange(interval, t_end + 0.5 * interval, interval):
        sim.advance_to(t)
        change = (mechanical_energy(model, sim.q, sim.qdot) - e0) / e0
        rows.append((t, change, sim.statistics["steps"], time.perf_counter() - start))
    return rows, max(abs(r[1]) for r in rows)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=10.0)
    parser.add_argument("--rtol", type=float, default=1e-9)
    parser.add_argument("--method", default="cvode-adams")
    parser.add_argument("--interval", type=float, default=0.5)
    args = parser.parse_args(argv)
    rows, worst = drift(t_end=args.t_end, rtol=args.rtol, method=args.method,
                        interval=args.interval)
    print(format_table(["t (s)", "relative energy change", "steps", "wall (s)"], rows,
                       title=f"undamped stage_planar_3dof, {args.method}, rtol {args.rtol:g}"))
    print(f"largest relative drift: {worst:.2e} (target < 1e-6)")
    return worst


if __name__ == "__main__":
    main()
