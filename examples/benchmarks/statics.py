"""The statics through the compiled engine against the numpy reference: CPU per static solve.

`static_equilibrium(..., compiled=True)` (Newton's balance and step from the engine's
operations, core/analysis/static_engine.py) over `compiled=False` (the numpy `Mechanics`),
the same loads, two load steps, in one process, alternating, medians of CPU seconds
(time.process_time: the shared machine's other load inflates walls far more); the engine
twice, on two copies of the model: its step on the sparse saddle-point system
(`engine.static_step`) and on the dense tangent (`engine.tangent`); each copy's engine
packing made once before the timed runs, as a second solve of the same model finds it. The
models:

- BEAM cantilevers of 16, 24, 32, 40, 48, 56, 64 elements (96 to 384 DOFs,
  `spatial.spatial_cantilever`) under 20 N at the tip (large deflection);
- `manipulator_control` (75 DOFs, 952 coordinates), 3 N on its x actuators;
- `manipulator_reduced` (507 DOFs) and `manipulator` (816 DOFs, its DF 1 % full), as
  `manipulator_control`.

The ratios decide the statics' default path (`static_engine.preferred`: from 300 free
coordinates; `static_engine.sparse_step`: the sparse step from 240 DOFs): a model where the
engine is the default meets its row when the ratio of the step it takes is at most 1; the
other rows (below 300 free coordinates, where a solve costs less than the engine's start-up
in a process, which these in-process figures leave out) are for information. The log
prints the three paths side by side with their Newton iterations.

Run alone: python -m examples.benchmarks.statics
"""

import time

import numpy as np

from .measure import alternate, log
from .table import Row


def _models(quick):
    from flexure.core import load_scene

    from .spatial import spatial_cantilever

    def manipulator(name):
        model = load_scene(name)
        loads = np.zeros(model.nx)
        loads[[port.coordinate for port in model.inputs]] = [3.0, 0.0] * 3
        return model, loads

    def cantilever(n):
        model = spatial_cantilever(n)
        return model, 20.0 * model.loads

    sizes = (16, 32) if quick else (16, 24, 32, 40, 48, 56, 64)
    models = {f"cantilever, {n} BEAMs": lambda n=n: cantilever(n) for n in sizes}
    models["manipulator_control"] = lambda: manipulator("manipulator_control")
    if not quick:
        models["manipulator_reduced"] = lambda: manipulator("manipulator_reduced")
        models["manipulator"] = lambda: manipulator("manipulator")
    return models


def statics(*, repeat=5, quick=False):
    """Rows: per model, the engine's static solve over the numpy one's (CPU s), the
    engine's step sparse (`engine.static_step`) and dense (`engine.tangent`); a table of
    the three on the log."""
    from flexure.core import static_equilibrium
    from flexure.core.analysis.static_engine import engine_balance, preferred, sparse_step

    rows, lines = [], []
    for label, make in _models(quick).items():
        model, loads = make()
        # one model per path: each keeps its own packed balance, packed before the runs
        dense_model, _ = make()
        for each, sparse in ((model, True), (dense_model, False)):
            engine_balance(each, sparse=sparse)
            static_equilibrium(each, loads=0.01 * loads, load_steps=1, compiled=True)

        def solve(each, compiled, loads=loads):
            start = time.process_time()
            solution = static_equilibrium(each, loads=loads, load_steps=2, compiled=compiled)
            return time.process_time() - start, solution.iterations

        t = alternate({"sparse": lambda m=model: solve(m, True),
                       "dense": lambda m=dense_model: solve(m, True),
                       "numpy": lambda m=model: solve(m, False)},
                      repeat, f"statics {label} (CPU s)")
        numpy = t["numpy"].median
        ratios = {name: t[name].median / numpy for name in ("sparse", "dense")}
        chosen = "sparse" if sparse_step(model) else "dense"
        ratio = ratios[chosen]
        default = preferred(model)
        lines.append(f"{label:24s} {model.ndof:4d} {1e3 * numpy:9.1f} "
                     f"{1e3 * t['dense'].median:9.1f} {1e3 * t['sparse'].median:9.1f} "
                     f"{ratios['dense']:6.3f} {ratios['sparse']:6.3f} "
                     f"{t['sparse'].median / t['dense'].median:6.3f}  "
                     f"{t['numpy'].info}/{t['dense'].info}/{t['sparse'].info}")
        log(f"statics {label}: {model.ndof} DOFs, engine/numpy dense {ratios['dense']:.3g}, "
            f"sparse {ratios['sparse']:.3g}")
        rows.append(Row(f"static solve, {label} ({model.ndof} DOFs), engine ({chosen} step)"
                        + (" (the default): <= numpy" if default else " (not the default)"),
                        t[chosen].text(), f"numpy {t['numpy'].text()}", ratio,
                        ratio <= 1.0 if default else None))
    log("model                    DOFs  numpy ms  dense ms sparse ms  dense/np sparse/np "
        "sparse/dense  iterations numpy/dense/sparse\n" + "\n".join(lines))
    return rows


if __name__ == "__main__":
    from .table import text_table

    print(text_table(statics(repeat=3), "static solves, engine over numpy (CPU s)"))
