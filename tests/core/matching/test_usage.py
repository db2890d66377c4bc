"""The usage registry: how often a window is used, whether a neighbour uses
it, the run's cap, and the reuse measure."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from terrasynth_core.matching.usage import NEAR_WEIGHT, UsageRegistry, source_reuse, window_cap


def _rec(example, source, kind="path"):
    return SimpleNamespace(kind=kind, example=example, source=source)


def test_reuse_is_the_largest_share_of_feature_patches_in_one_window():
    recs = [_rec(0, (100, 100)), _rec(0, (110, 105)), _rec(0, (300, 300)), _rec(1, (100, 100)),
            _rec(-1, (100, 100), kind="fill"), _rec(-1, (0, 0), kind="stamp")]
    assert source_reuse(recs) == 2 / 4  # fill and stamp do not count; example 1 is another window
    assert source_reuse([_rec(0, (0, 0)), _rec(0, (50, 0))]) == 1 / 2
    assert source_reuse([_rec(-1, (0, 0), kind="fill")]) == 0.0


def test_cap_is_a_tenth_of_the_features_or_the_even_share_of_a_small_pool():
    assert window_cap(88, 60, 500) == 8
    assert window_cap(5, 5, 500) == 1
    assert window_cap(88, 60, 10) == 8  # pool < 20: at least ceil(60 / 10) = 6; the tenth is larger
    assert window_cap(30, 30, 4) == 8  # ceil(30 / 4)


def test_uses_count_the_fullest_window_a_candidate_would_join():
    reg = UsageRegistry(48)
    for src in [(100, 100), (115, 100), (130, 100)]:
        reg.record(0, src, (0, 48, 0, 48), (24, 24))
    # (115, 100) already has three sources within 20 cells; joining it makes four.
    uses = reg.uses(np.array([0, 0, 1, 0]), np.array([[115, 100], [145, 100], [115, 100], [400, 400]]))
    assert uses.tolist() == [4, 3, 1, 1]  # (145,100) joins (130,100)'s window: 2 there, +1 = 3


def test_neighbours_may_not_share_a_window_but_far_patches_may():
    reg = UsageRegistry(48)
    reg.record(0, (100, 100), (0, 48, 0, 48), (24, 24))
    ex, src = np.array([0, 0, 1]), np.array([[105, 100], [300, 300], [105, 100]])
    assert reg.neighbour_shares(ex, src, (30, 78, 0, 48), (54, 24)).tolist() == [True, False, False]
    assert reg.neighbour_shares(ex, src, (200, 248, 200, 248), (224, 224)).tolist() == [False, False, False]
    pen = reg.penalties(ex, src, (30, 78, 0, 48), (54, 24), cap=5)
    assert pen[0] > 0 and pen[1] == 0 and pen[2] == 0


def test_a_window_used_a_little_further_along_costs_more_to_take():
    """Two patch sizes off (not a neighbour) a window may still be taken,
    at a ranking cost: else two sources alternate down a straight stroke."""
    reg = UsageRegistry(48)
    reg.record(0, (100, 100), (0, 48, 0, 48), (24, 24))
    ex, src = np.array([0, 0]), np.array([[105, 100], [300, 300]])
    near = (66, 114, 0, 48), (90, 24)  # centres 66 cells apart
    assert reg.penalties(ex, src, *near, cap=5).tolist() == [0, 0]
    assert reg.crowding(ex, src, *near).tolist() == [NEAR_WEIGHT, 0.0]
    far = (130, 178, 0, 48), (154, 24)  # 130 cells: over two patch sizes
    assert reg.crowding(ex, src, *far).tolist() == [0.0, 0.0]


def test_a_snapshot_does_not_see_later_records():
    reg = UsageRegistry(48)
    snap = reg.snapshot()
    reg.record(0, (100, 100), (0, 48, 0, 48), (24, 24))
    assert len(snap) == 0 and len(reg) == 1
    assert snap.uses(np.array([0]), np.array([[100, 100]])).tolist() == [1]
    assert reg.uses(np.array([0]), np.array([[100, 100]])).tolist() == [2]
