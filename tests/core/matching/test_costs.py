"""The match cost: overlap SSD after the best shift, the settled shift and
the relief-normalised cost."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.matching.costs import (
    ANCHOR_WEIGHT,
    OFFSET_WEIGHT,
    anchor_weight,
    level_spread,
    NEAR_BEST,
    match_cost,
    near_best_limit,
    overlap_ssd,
    pick_near_best,
    settle,
)


def test_overlap_ssd_removes_the_best_shift_and_ignores_empty_cells():
    rng = np.random.default_rng(4)
    patch = rng.normal(100.0, 30.0, (16, 16)).astype(np.float32)
    noise = rng.normal(0.0, 2.0, (16, 16))
    existing = (patch + 42.0 + noise).astype(np.float32)
    filled = np.zeros((16, 16), bool)
    filled[:, :5] = True
    existing[~filled] = np.nan  # never read
    ssd, offset = overlap_ssd(existing, patch, filled)
    diff = existing[filled].astype(np.float64) - patch[filled]
    assert offset == pytest.approx(diff.mean(), rel=1e-12)
    assert offset == pytest.approx(42.0, abs=1.0)
    assert ssd == pytest.approx(diff.var(), rel=1e-12)
    # The SSD after any other shift is larger.
    for other in (offset - 1.0, offset + 0.5):
        assert ((diff - other) ** 2).mean() > ssd
    assert overlap_ssd(existing, patch, np.zeros((16, 16), bool)) == (0.0, 0.0)


@pytest.mark.parametrize("ssd, offset, mean, relief", [(3.0, 20.0, 0.0, 50.0), (0.5, -8.0, 12.0, 7.0),
                                                        (0.0, 0.0, -30.0, 120.0)])
def test_settle_minimises_the_match_cost_over_the_shift(ssd, offset, mean, relief):
    settled_ssd, shift = settle(ssd, offset, mean)
    assert settled_ssd == pytest.approx(ssd + (offset - shift) ** 2)

    def cost(s):
        # Moving the shift away from the SSD-optimal one adds its square to the SSD.
        return match_cost(ssd + (offset - s) ** 2, s + mean, relief)

    grid = shift + np.linspace(-5.0, 5.0, 2001)
    assert cost(shift) <= min(cost(s) for s in grid) + 1e-12
    assert shift == pytest.approx((offset - OFFSET_WEIGHT * mean) / (1.0 + OFFSET_WEIGHT))


def test_settling_pulls_part_of_the_way_back_to_the_level_field():
    _, shift = settle(0.0, 60.0)
    assert 0.0 < shift < 60.0
    assert shift == pytest.approx(60.0 / (1.0 + OFFSET_WEIGHT))


def test_match_cost_is_in_units_of_the_relief():
    assert match_cost(400.0, 0.0, 20.0) == pytest.approx(1.0)
    assert match_cost(0.0, 20.0, 20.0) == pytest.approx(OFFSET_WEIGHT)
    # Same mismatch, twice the relief: a quarter of the cost.
    assert match_cost(90.0, 6.0, 40.0) == pytest.approx(match_cost(90.0, 6.0, 20.0) / 4)


def test_level_spread_is_the_spread_of_window_means():
    rng = np.random.default_rng(0)
    flat_noise = rng.normal(0, 50, (300, 300)).astype(np.float32)
    # Means of 60x60 windows of white noise spread by sigma / 60.
    assert level_spread(flat_noise, 60) == pytest.approx(50 / 60, rel=0.25)
    rr = np.mgrid[0:300, 0:300][0].astype(np.float32)
    assert level_spread(rr * 2.0, 60) > 100  # a slope's windows sit at many levels


def test_level_spread_counts_only_windows_of_valid_cells():
    """An example's filled voids (here a plateau at 900 m beside noise about
    0) do not spread its window levels."""
    rng = np.random.default_rng(1)
    detail = rng.normal(0, 50, (300, 300)).astype(np.float32)
    valid = np.ones(detail.shape, bool)
    valid[:, 200:] = False
    detail[~valid] = 900.0
    assert level_spread(detail, 60) > 100
    assert level_spread(detail, 60, valid) < 2  # (about 50 / 60: the noise's own)
    assert level_spread(detail, 60, np.zeros(detail.shape, bool)) == level_spread(detail, 60)  # no whole window


def test_anchor_weight_grows_as_window_levels_vary_less():
    assert anchor_weight(40.0, 10.0) == pytest.approx(ANCHOR_WEIGHT * 16)
    assert anchor_weight(40.0, 20.0) < anchor_weight(40.0, 10.0)
    # Never weaker than the flat-level anchor that bounds the drift.
    assert anchor_weight(10.0, 1000.0) == OFFSET_WEIGHT


def test_settle_and_match_cost_take_the_weight():
    _, shift = settle(0.0, 60.0, 0.0, weight=5.0)
    assert shift == pytest.approx(10.0)
    assert match_cost(0.0, 20.0, 20.0, weight=5.0) == pytest.approx(5.0)


def test_the_seed_picks_evenly_among_the_candidates_near_the_cheapest():
    totals = [1.30, 1.00, 1.08, 1.11, 1.095]  # within 10 %: indices 1, 2 and 4
    assert near_best_limit(1.0) == pytest.approx(1.0 + NEAR_BEST)
    picks = [pick_near_best(totals, np.random.default_rng(seed)) for seed in range(300)]
    assert set(picks) == {1, 2, 4}
    assert min(np.bincount(picks)[[1, 2, 4]]) > 60  # about 100 each
    # The same generator state, the same pick: a run's bytes stay its seed's.
    assert pick_near_best(totals, np.random.default_rng(7)) == pick_near_best(totals, np.random.default_rng(7))
    assert pick_near_best([0.0, 0.0, 1e-9], np.random.default_rng(0)) in (0, 1)
    assert pick_near_best([2.5], np.random.default_rng(0)) == 0
