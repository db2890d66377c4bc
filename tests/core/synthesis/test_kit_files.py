"""What a stage's tasks share goes to the worker processes as a kit file;
a later stage with the same kit sends the same file (synthesis/workers.py)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from terrasynth_core.synthesis import workers


@dataclass(frozen=True, eq=False)
class _Kit:
    tables: list
    weights: np.ndarray
    seed: int


def test_the_same_kit_is_sent_once_and_a_replaced_file_goes_when_unused():
    tables = [np.arange(6.0), None]
    first = workers._ship(_Kit(tables, np.ones(3), 1))
    # The same objects and equal values: the same file, the workers have it.
    again = workers._ship(_Kit(list(tables), np.ones(3), 1))
    assert again is first and first.users == 2
    # A copy of a table is not the same object: sent again (the check is
    # by identity, not by content, for the large parts).
    other = workers._ship(_Kit([tables[0].copy(), None], np.ones(3), 1))
    assert other.path != first.path
    # Replaced, but still in use by two stages: kept until both are done.
    assert Path(first.path).exists()
    workers._release(first)
    assert Path(first.path).exists()
    workers._release(again)
    assert not Path(first.path).exists()
    # A different seed or weights: another file; the unused last one goes at once.
    workers._release(other)
    assert Path(other.path).exists()  # the last of its type stays for the next stage
    newest = workers._ship(_Kit(tables, np.ones(3), 2))
    assert not Path(other.path).exists() and Path(newest.path).exists()
    workers._release(newest)
    workers._remove_kits()
    assert not Path(newest.path).exists()
