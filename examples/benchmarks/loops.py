"""The closed-loop row groups: `loop` (`flexure loop` against Exudyn's n = 4 stage under the
same controller) and `realtime` (the loop on the 3-DOF and 19-DOF stages, simulated time
over wall)."""

import numpy as np

from .measure import alternate, log, peer
from .table import Row


def loop(*, repeat=5, quick=False):
    """`flexure loop` defaults against Exudyn's n = 4 stage under the same controller."""
    from flexure.controllers.runner import run_loop

    exu = peer()

    def ours():
        result = run_loop("stage_planar_1dof")
        return result.wall_time_s, result.max_abs_error / abs(result.stroke)

    def theirs():
        result = exu.closed_loop(4)
        return result["wall_time_s"], result["error_ratio"]

    t = alternate({"flexure": ours, "exudyn": theirs if exu else None}, repeat, "loop")
    f = t["flexure"]
    rows = []
    if "exudyn" in t:
        e = t["exudyn"]
        ratio = f.median / e.median
        rows.append(Row("flexure loop defaults (stage_planar_1dof, 1.25 s at 4 kHz): wall "
                        "<= 0.5 x Exudyn's (n = 4 cables per spring)", f.text(),
                        e.text(), ratio, ratio <= 0.5))
        peer_error = f"limit 1e-7 (Exudyn n = 4: {e.info:.2e}, model difference)"
    else:
        rows.append(Row("flexure loop defaults: wall <= 0.5 x Exudyn's", f.text(),
                        "exudyn not installed"))
        peer_error = "limit 1e-7"
    rows.append(Row("flexure loop defaults: max |error| / stroke <= 1e-7", f"{f.info:.2e}",
                    peer_error, f.info / 1e-7, f.info <= 1e-7))
    return rows


def realtime(*, repeat=5, quick=False):
    """The loop's defaults on the 3-DOF and the 19-DOF stage: simulated time / wall, and the
    plant's deviation from the same loop at rtol 1e-10."""
    from flexure.controllers.runner import run_loop

    limits = {"stage_planar_3dof": 10.0, "stage_spatial_19dof": 2.0}

    def case(scene):
        def run():
            result = run_loop(scene)
            return result.wall_time_s, result
        return run

    t = alternate({scene: case(scene) for scene in limits}, repeat, "realtime")
    rows = []
    for scene, limit in limits.items():
        timing = t[scene]
        result = timing.info
        log(f"realtime: {scene} at rtol 1e-10 (the accuracy reference)")
        reference = run_loop(scene, rtol=1e-10)
        stroke = abs(result.stroke)
        deviation = np.max(np.abs(result.position - reference.position)) / stroke
        speed = result.t[-1] / timing.median
        rows.append(Row(f"loop on {scene} (1 mm in 1 s + 0.25 s, 4 kHz): >= {limit:g} x real "
                        "time", f"{speed:.2f} x ({timing.text()}; tracking error "
                        f"{result.max_abs_error / stroke:.1e}, plant {deviation:.0e} from rtol "
                        f"1e-10, both of the stroke; rtol {result.settings['rtol']:g})",
                        f">= {limit:g} x", speed / limit, speed >= limit))
    return rows
