"""The workers' shares of the engine's first compilation (tests/shared_compilation.py): every
entry named is one of the engine's, each goes to exactly one share, and the shares' compile
CPU is balanced as the greedy rule promises."""

import pytest
from shared_compilation import ENTRIES, entry, shares

from flexure.core.numerics.jit import CompiledEntry


def test_every_name_is_an_entry_of_the_engine():
    for name, _ in ENTRIES:
        assert isinstance(entry(name), CompiledEntry), name


@pytest.mark.parametrize("count", [1, 2, 3, 4])
def test_each_entry_is_in_one_share_and_the_shares_are_balanced(count):
    split = shares(count)
    assert len(split) == count
    assert sorted(sum(split, [])) == sorted(name for name, _ in ENTRIES)
    seconds = dict(ENTRIES)
    totals = [sum(seconds[name] for name in share) for share in split]
    # greedy (longest first): no share exceeds another by more than the largest entry it holds
    for share, total in zip(split, totals, strict=True):
        assert total - min(totals) <= max((seconds[name] for name in share), default=0.0)
