"""Exudyn's whole process for the loop that `flexure loop` runs, as an Exudyn user would write
it: import exudyn and numpy, build the stage, step a discrete controller in a pre-step
function, print the tracking error.

    python examples/benchmarks/exudyn_loop_process.py CONTROLLER.npz

The controller's numbers (the discrete feedback's A, B, C, D, the reference and the open-loop
forces per sample, the sample rate) are flexure's design of `flexure loop`'s defaults, written
to CONTROLLER.npz beforehand by `save_controller` (latency.py does it once, outside every
timed run): this process imports no flexure, and pays nothing for a design, so the comparison
favours Exudyn. The stage is `exudyn_stage`'s with n = 4 cables per spring, the benchmark's
converged Exudyn model (compare.py, the loop group).
"""

import sys
from pathlib import Path

import numpy as np

# Run by its path, this file has no package for its relative imports: it joins
# examples.benchmarks, found from the repository's root (PEP 366; see __init__.py).
if not __package__:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    __package__ = "examples.benchmarks"

from .exudyn_stage import Stage  # noqa: E402
from .peer_exudyn import run_loop  # noqa: E402

CABLES_PER_SPRING = 4


class RecordedController:
    """A sampled loop's controller from its numbers: u_k+1 = C x + D e_k + u_ff,k+1 with
    x_k+1 = A x + B e_k, e_k = r_k - y_k (m, N); the interface of flexure's LoopController
    that `peer_exudyn.run_loop` steps."""

    def __init__(self, numbers):
        self.A, self.B, self.C, self.D = (np.atleast_2d(numbers[k]) for k in "ABCD")
        self.reference = numbers["reference"].reshape(-1, 1)  # (samples + 2, 1), m
        self.forces = numbers["forces"].reshape(-1)  # (samples + 2,), N
        self.fs, self.samples = float(numbers["fs"]), int(numbers["samples"])
        self.x = np.zeros(self.A.shape[0])

    def reset(self):
        self.x[:] = 0.0

    def initial_output(self):
        return self.forces[:1].copy()

    def step(self, k, y):
        k = min(int(k), self.samples)
        e = self.reference[k] - np.asarray(y, float)
        u = self.C @ self.x + self.D @ e
        self.x = self.A @ self.x + self.B @ e
        return u + self.forces[k + 1], e


def save_controller(path, loop_controller):
    """Write flexure's LoopController (a DiscreteController feedback, one loop) to `path`."""
    feedback = loop_controller.controller
    np.savez(path, A=feedback.A, B=feedback.B, C=feedback.C, D=feedback.D,
             reference=loop_controller.reference[:, 0],
             forces=loop_controller.open_loop_forces[:, 0], fs=loop_controller.fs,
             samples=loop_controller.samples)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    with np.load(argv[0]) as numbers:
        controller = RecordedController(numbers)
    t, position, _, _ = run_loop(controller, CABLES_PER_SPRING, 1,
                                 stage=Stage.from_scene("stage_planar_1dof"))
    error = np.max(np.abs(controller.reference[: t.size, 0] - position))
    stroke = np.ptp(controller.reference)
    print(f"max |error| {error:.3e} m, {error / stroke:.3e} of the stroke")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
