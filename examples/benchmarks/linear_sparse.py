"""One linearisation's CPU through the sparse Newton matrix's packing against the numpy path's,
on models whose statics step sparse (from 240 DOFs): `linearize` at a loaded equilibrium,
compiled=None (the default, `linear_sparse`) and compiled=False (numpy) alternating in one
process, after one warm-up call of each; medians of `--repeat` pairs.

    .venv/bin/python -m examples.benchmarks.linear_sparse [--repeat 7]

Prints per model its DOFs, the two medians (s of CPU, user + system of this process) and
their ratio, engine over numpy.
"""

import argparse
import time

import numpy as np

from flexure.core import build_model, load_scene
from flexure.core.analysis.linearization import linearize
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.mechanics.mechanics import Mechanics

from .spatial import cantilever_spec


def cantilever(beams):
    """The spatial strip of `beams` BEAMs with 1 N down at its tip; (model, inputs None)."""
    spec = cantilever_spec(beams, name=f"cantilever_{6 * beams}")
    spec["nodes"][str(beams)]["force"] = [0.0, 0.0, -1.0]
    return build_model(spec), None


def builtin(name):
    """A built-in scene with 1 N on every input."""
    model = load_scene(name)
    return model, np.ones(len(model.inputs))


MODELS = {"cantilever 288": lambda: cantilever(48), "cantilever 384": lambda: cantilever(64),
          "manipulator_reduced": lambda: builtin("manipulator_reduced"),
          "manipulator": lambda: builtin("manipulator")}


def cpu(call):
    """CPU seconds (process time) of call()."""
    start = time.process_time()
    call()
    return time.process_time() - start


def measure(name, repeat):
    """(NDOF, median engine CPU s, median numpy CPU s) of one linearisation of `name`."""
    model, inputs = MODELS[name]()
    mech = Mechanics(model)
    solution = static_equilibrium(model, inputs=inputs, mechanics=mech)
    engine = lambda: linearize(model, solution, mechanics=mech)  # noqa: E731
    numpy = lambda: linearize(model, solution, mechanics=mech, compiled=False)  # noqa: E731
    engine(), numpy()  # warm-up: the entry loaded, the caches filled
    pairs = [(cpu(engine), cpu(numpy)) for _ in range(repeat)]
    times = np.median(np.array(pairs), axis=0)
    return model.ndof, float(times[0]), float(times[1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    print("| model | DOFs | engine (s) | numpy (s) | engine / numpy |")
    print("|---|---|---|---|---|")
    for name in MODELS:
        ndof, engine, numpy = measure(name, args.repeat)
        print(f"| {name} | {ndof} | {engine:.4f} | {numpy:.4f} | {engine / numpy:.2f} |")


if __name__ == "__main__":
    main()
