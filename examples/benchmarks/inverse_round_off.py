"""The compiled and numpy inverse dynamics at single states of the manipulator's 4 mm x move:
how far apart the two paths' forces and accelerations are, and what round-off alone moves.

The move is examples/manipulator_feedforward.py's forward check (manipulator_control with E's
outputs, the end effector 4 mm along x in 1 s, Radau IIA at 2.5 ms, Newton to 1e-14). The
inverse dynamics run once through the engine to `end`; at the step ends nearest `times` both
evaluators (`inverse_engine.EngineMotion`, `inverse_evaluation.NumpyMotion` on the sparse
`Mechanics`) take the same state (t, q_i, qdot_i), each from the run's coordinates as its
Newton start, and `Partitioned.evaluate` solves it for the free DOFs' accelerations qddot_i
(m/s^2, rad/s^2) and the six forces w (N). Printed per state (largest entries):

- |w|, engine - numpy w, |qddot_i|, engine - numpy qddot_i;
- the configurations' difference x (m) and the generalised forces' Q (N, at qddot = 0);
- "walk": what one more Newton step of numpy's kinematics from its own converged x moves x
  and Q (the coordinates are fixed only to a few ulps: each step from a converged x lands
  elsewhere by round-off), and the forces' first-order change from that Q change,
  S^-1 dQ (S the balance's matrix [M_i - M_d C_d^-1 C_i, -B], inverse_dynamics_partition);
- kappa = (|S^-1 dQ| / |w|) / (|dx| / |x|) of the walk: the forces' condition number with
  respect to the coordinates' round-off, so that their floor is |w| eps kappa (|x| about 1 m);
- ratio: engine - numpy w over the walk's S^-1 dQ.

The paths are the same equations, so their forces may differ by what the coordinates'
round-off moves: a ratio of order one is that floor, a defect would stand above it.

python -m examples.benchmarks.inverse_round_off [end] (default 1.0 s)
"""

import sys

import numpy as np
import scipy.linalg

from examples.manipulator_feedforward import MOVES, control_model
from examples.manipulator_loop import targets

TIMES = (0.1, 0.25, 0.375, 0.5, 0.625, 0.75, 1.0)  # s: the states compared
STEP = 2.5e-3  # s: Radau IIA's step
TOLERANCE = 1e-14  # the Newton tolerance, of each DOF's unit


class _Start:
    """A Newton start: coordinates x (NX,) alone."""

    def __init__(self, x):
        self.x = np.array(x, dtype=float)


def _parts(model, wanted):
    """(path, output ports, input ports) of `move_inverse_dynamics` for `wanted`."""
    from flexure.controllers.move_path import move_targets, target_port
    from flexure.controllers.profiles import ThirdOrderProfile
    from flexure.core import output_value, static_equilibrium
    from flexure.core.analysis.inverse_dynamics_free import resolved_ports

    pairs, names, delta = move_targets(model, wanted)
    rest = static_equilibrium(model)
    own = {port.name: port for port in model.outputs}
    start = np.array([output_value(model, own.get(name) or target_port(model, name), rest.x)
                      for name in names])
    profile = ThirdOrderProfile(1.0, 1.0)

    def path(t):
        s, rate, acceleration, _ = profile.evaluate(t)
        return start + delta * s, delta * rate, delta * acceleration

    return (path, *resolved_ports(model, names, [pair.input_name for pair in pairs]))


def _balance_matrix(model, part, config):
    """S = [M_i - M_d C_d^-1 C_i, -B] at `config` (M from numpy's evaluation)."""
    from flexure.core.mechanics.ports import input_columns, output_rows

    d, i = part.dependent, part.independent
    M = np.asarray(part.evaluator.mech.mass_matrix(config))
    C = output_rows(model, config.x, config.DF, part.out_ports)
    B = config.DF.T @ input_columns(model, config.x, part.in_ports)
    return np.hstack([M[:, i] - M[:, d] @ scipy.linalg.solve(C[:, d], C[:, i]), -B])


def compare(end=1.0, times=TIMES):
    """Rows {t, w, dw, a, da, dx, dQ, walk_dx, walk_dQ, walk_dw, kappa, ratio} at the steps
    ends nearest `times` (module docstring; N, m/s^2, m)."""
    from flexure.controllers.dynamic_feedforward import move_inverse_dynamics
    from flexure.core.analysis.inverse_dynamics_free import start_at_rest
    from flexure.core.analysis.inverse_dynamics_partition import Partitioned
    from flexure.core.analysis.inverse_engine import engine_motion
    from flexure.core.analysis.inverse_evaluation import NumpyMotion
    from flexure.core.mechanics.mechanics import Mechanics

    model = control_model()
    wanted = targets(*MOVES["4 mm x"])
    run = move_inverse_dynamics(model, wanted, duration=1.0, end=end, step=STEP,
                                tolerance=TOLERANCE)
    path, out_ports, in_ports = _parts(model, wanted)
    mech = Mechanics(model)
    parts = {}
    for name, evaluator in (("engine", engine_motion(model)), ("numpy", NumpyMotion(mech))):
        _, config = start_at_rest(model, mech, evaluator, path, out_ports, run.times)
        parts[name] = Partitioned(model, evaluator, path, out_ports, in_ports, config,
                                  TOLERANCE, 30)
    rows = []
    for wanted_t in times:
        k = int(np.argmin(np.abs(run.times - wanted_t)))
        t, i = float(run.times[k]), parts["numpy"].independent
        found = {}
        for name, part in parts.items():
            part.config = part.evaluator.solve(run.q[k], _Start(run.x[k]))
            config, qdot, qddot, w = part.evaluate(t, run.q[k][i], run.qdot[k][i])
            found[name] = (config, qdot, qddot[i], w, part.evaluator.motion(config, qdot)[2])
        (ce, _, ae, we, Qe), (cn, qdot, an, wn, Qn) = found["engine"], found["numpy"]
        numpy = parts["numpy"].evaluator
        walked = numpy.solve(cn.q, _Start(cn.x))  # one Newton step more from a converged x
        walk_dQ = numpy.motion(walked, qdot)[2] - Qn
        walk_dw = np.linalg.solve(_balance_matrix(model, parts["numpy"], cn), walk_dQ)[i.size:]
        dw, w = np.abs(we - wn).max(), np.abs(wn).max()
        walk_dx, walk_dw = np.abs(walked.x - cn.x).max(), np.abs(walk_dw).max()
        rows.append({"t": t, "w": w, "dw": dw, "a": np.abs(an).max(),
                     "da": np.abs(ae - an).max(), "dx": np.abs(ce.x - cn.x).max(),
                     "dQ": np.abs(Qe - Qn).max(), "walk_dx": walk_dx,
                     "walk_dQ": np.abs(walk_dQ).max(), "walk_dw": walk_dw,
                     "kappa": walk_dw / w / (walk_dx / np.abs(cn.x).max()),
                     "ratio": dw / walk_dw})
    return rows


def print_rows(rows):
    """The rows as a markdown table."""
    print("| t (s) | max abs w (N) | engine - numpy w | max abs qddot_i | engine - numpy "
          "qddot_i | x (m) | Q (N) | walk: x | Q | S^-1 dQ (N) | kappa | ratio |")
    print("| ---: " * 12 + "|")
    for r in rows:
        print(f"| {r['t']:.3f} | {r['w']:.3g} | {r['dw']:.1e} | {r['a']:.2e} | {r['da']:.1e} "
              f"| {r['dx']:.1e} | {r['dQ']:.1e} | {r['walk_dx']:.1e} | {r['walk_dQ']:.1e} "
              f"| {r['walk_dw']:.1e} | {r['kappa']:.1e} | {r['ratio']:.2f} |")


if __name__ == "__main__":
    print_rows(compare(float(sys.argv[1]) if len(sys.argv) > 1 else 1.0))
