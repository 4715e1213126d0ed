"""The compiled and numpy inverse dynamics along the manipulator's 4 mm x move, mid-move
(examples/benchmarks/inverse_round_off.py): their forces differ by the coordinates' round-off
alone, where the rates are largest (the move's first 15 ms, tests/test_inverse_engine.py,
have nearly none)."""

import pytest

from examples.benchmarks import inverse_round_off

# N: the forces' round-off floor on manipulator_control, a few times what one Newton step of
# the kinematics from a converged configuration moves them by (2e-8 to 7e-8 N measured along
# the move, docs/benchmarks.md 2026-12-01), so that a CPU whose step moves nothing still
# has one
FLOOR = 3e-8


@pytest.mark.slow
def test_the_two_paths_forces_differ_by_what_the_coordinates_round_off_moves():
    """At 0.25 s (the move's largest acceleration) and 0.5 s (its largest rate) both paths
    solve the same state: their forces within 10 times what one more Newton step of numpy's
    kinematics from its converged x moves them by (S^-1 dQ, at least FLOOR; measured 1.4 and
    0.47 times), with forces of 1.4 and 6.3 N; their configurations within 1e-14 m (measured
    3.1e-15 and 9.7e-16 m) and the walk a round-off's (within 1e-15 m, measured 2.8e-16 and
    5e-16). Checked to fail: the engine's Q scaled by 1 + 1e-6 moves the forces at 0.25 s
    by 2.8e-6 N, above the bound's 3e-7 N."""
    rows = inverse_round_off.compare(end=0.5, times=(0.25, 0.5))
    assert [row["t"] for row in rows] == pytest.approx([0.25, 0.5], abs=1e-12)
    for row in rows:
        assert row["w"] > 1.0, row
        assert row["walk_dx"] <= 1e-15, row
        assert row["dw"] <= 10 * max(row["walk_dw"], FLOOR), row
        assert row["dx"] <= 1e-14, row
