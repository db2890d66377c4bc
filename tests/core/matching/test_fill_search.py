"""The fill searches (the engine's indexed one and the exhaustive FFT one)
against brute force (paper §4.2)."""

import numpy as np
import pytest

from terrasynth_core.matching.costs import ROUGHNESS_WEIGHT
from terrasynth_core.matching import window_index
from terrasynth_core.matching.fill_search import FftFillSearch, FillSearch, roughness_prior

SEARCHES = pytest.mark.parametrize("search_class", [FillSearch, FftFillSearch])


@SEARCHES
def test_search_matches_brute_force(white_mountains, search_class):
    """The SSD (offset removed) ranks windows like a direct computation."""
    E = white_mountains.heights[:160, :160]
    search = search_class(E, (32, 32), coarse_factor=1)
    filled = np.zeros((32, 32), bool)
    filled[:, :10] = True
    target = E[50:82, 70:102] + 123.0  # an exact match, shifted in height
    best = search.best(target, filled, 3, np.random.default_rng(0))
    (r, c), ssd, offset, _ = best[0]
    assert (r, c) == (50, 70)
    assert ssd < 1e-3 and offset == pytest.approx(123.0, abs=1e-3)


@SEARCHES
def test_search_ranks_by_normalised_ssd_like_brute_force(white_mountains, search_class):
    """The search ranks windows by the SSD over the two windows' variances
    plus the roughness prior (so rough candidates are not beaten by smooth
    ones just for being smooth): its best pick is the brute-force best."""
    E = white_mountains.heights[:120, :120].astype(np.float64)
    search = search_class(white_mountains.heights[:120, :120], (24, 24), coarse_factor=1)
    filled = np.zeros((24, 24), bool)
    filled[:8, :] = True
    filled[:, :6] = True
    rng = np.random.default_rng(1)
    target = E[30:54, 40:64] + rng.normal(0, 20, (24, 24))
    o = target[filled]
    scores = np.full((97, 97), np.inf)
    for r in range(97):
        for c in range(97):
            e = E[r:r + 24, c:c + 24][filled]
            d = o - e
            scores[r, c] = ((d - d.mean()) ** 2).mean() / (e.var() + o.var() + 1e-6)
            scores[r, c] += ROUGHNESS_WEIGHT * search.prior[r, c]
    (r, c), _, _, _ = search.best(target, filled, 1, rng)[0]
    assert (r, c) == np.unravel_index(np.argmin(scores), scores.shape)


def test_roughness_prior_is_zero_for_typical_windows_and_grows_both_ways():
    """A window as rough as the median one costs nothing; half or twice as
    rough costs ln(2)**2 either way."""
    rng = np.random.default_rng(0)
    cols = np.arange(96)
    # Three vertical bands of noise: amplitudes 1, 2 and 4 (the middle one typical).
    amp = np.select([cols < 32, cols < 64], [1.0, 2.0], 4.0)
    example = (rng.normal(0.0, 1.0, (64, 96)) * amp).astype(np.float32)
    allowed = np.ones((64 - 16 + 1, 96 - 16 + 1), bool)
    prior = roughness_prior(example, (16, 16), allowed, 1)
    assert prior.shape == allowed.shape
    assert prior[20, 40] == pytest.approx(0.0, abs=0.02)  # inside the typical band
    assert prior[20, 5] == pytest.approx(np.log(2) ** 2, rel=0.15)   # half as rough
    assert prior[20, 75] == pytest.approx(np.log(2) ** 2, rel=0.15)  # twice as rough


def test_search_prefers_the_typical_window_when_the_overlap_cannot_tell():
    """With nothing to match but a flat strip, a smooth window fits the
    overlap best; the prior makes the search take a typical one instead."""
    rng = np.random.default_rng(3)
    cols = np.arange(160)
    amp = np.select([cols < 40], [0.05], 1.0)  # a smooth quarter, the rest typical
    example = (rng.normal(0.0, 1.0, (96, 160)) * amp).astype(np.float32)
    search = FillSearch(example, (24, 24), coarse_factor=1)
    filled = np.zeros((24, 24), bool)
    filled[:, :4] = True
    target = np.zeros((24, 24), np.float32)
    (r, c), _, _, prior = search.best(target, filled, 1, rng)[0]
    assert c + 24 > 40 and prior < 0.5


@SEARCHES
def test_no_window_touching_a_void_is_offered_or_refined_to(white_mountains, search_class):
    """An example's voids (filled in its heights) are never copied: no window
    on offer, picked at random or refined at full resolution touches one."""
    E = white_mountains.heights[:200, :200].copy()
    void = np.zeros(E.shape, bool)
    void[60:100, 50:130] = True
    E[void] = E[~void].mean()  # a flat fill: the best match for a flat target if it were allowed
    window = (24, 24)
    search = search_class(E, window, coarse_factor=2, void_mask=void)
    plain = search_class(E, window, coarse_factor=2)
    assert 0 < search.allowed.sum() < plain.allowed.sum()

    def touches(r, c):
        return void[r:r + window[0], c:c + window[1]].any()

    rng = np.random.default_rng(0)
    assert not any(touches(*pos) for pos, *_ in search.best(np.zeros(window), np.zeros(window, bool), 20, rng))
    filled = np.zeros(window, bool)
    filled[:, :8] = True
    for target in (np.full(window, float(E[~void].mean())), E[70:94, 60:84] + 1.0):
        picks = search.best(target, filled, 5, rng)
        assert picks and not any(touches(*pos) for pos, *_ in picks)
    # Without the mask the flat fill is what a flat target finds.
    assert touches(*plain.best(np.full(window, float(E[~void].mean())), filled, 1, rng)[0][0])


def test_voids_that_leave_no_window_on_the_grid_make_it_finer(white_mountains):
    """The only void-free windows start at rows and columns 3-6: none on
    the 8-cell grid, so the search takes the largest grid that has one."""
    E = white_mountains.heights[:200, :200].copy()
    void = np.ones(E.shape, bool)
    void[3:30, 3:30] = False
    search = FillSearch(E, (24, 24), coarse_factor=8, void_mask=void)
    assert search.f == 6 and search.allowed.sum() == 1
    filled = np.zeros((24, 24), bool)
    filled[:, :6] = True
    for pos, *_ in search.best(E[10:34, 10:34], filled, 3, np.random.default_rng(0)):
        assert not void[pos[0]:pos[0] + 24, pos[1]:pos[1] + 24].any()
    with pytest.raises(Exception, match="no 24x24 window without nodata"):
        FillSearch(E, (24, 24), void_mask=np.ones(E.shape, bool))


def test_a_window_is_searched_in_the_examples_nearest_to_it(white_mountains, monkeypatch, tmp_path):
    """A library larger than ``SEARCHED_EXAMPLES``: each window is searched
    only in the examples whose indexes hold its nearest windows, the one
    it was cut from among them, and the answer is what a search over just
    those examples gives (their shortlists are not fetched twice).  Only
    the ``PROBED_EXAMPLES`` whose index centres come nearest are asked for
    their windows (a window reads so many indexes' lists, however large
    the library)."""
    from terrasynth_core.synthesis import fill_patches

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    heights = white_mountains.heights
    crops = [np.ascontiguousarray(heights[r:r + 150, c:c + 150]) for r in (0, 120, 240) for c in (0, 120, 240)]
    searches = [FillSearch(crop, (32, 32), coarse_factor=1) for crop in crops]
    assert all(s.indexes is not None for s in searches) and len(crops) > fill_patches.SEARCHED_EXAMPLES
    members = list(range(len(crops)))
    anchor = np.zeros(len(crops))
    filled = np.zeros((32, 32), bool)
    filled[:10] = True
    target = crops[7][60:92, 40:72] + 100.0
    chosen, shortlists = fill_patches._nearest_examples(searches, members, target, filled)
    assert len(chosen) == fill_patches.SEARCHED_EXAMPLES and 7 in chosen and chosen == sorted(chosen)
    args = (searches, crops, anchor)
    rng = np.random.default_rng
    pruned = fill_patches.search_fill(*args, members, 100.0, target, filled, rng(0), patch_size=32, k=4)
    direct = fill_patches.search_fill(*args, chosen, 100.0, target, filled, rng(0), patch_size=32, k=4)
    assert pruned == direct
    assert any(ei == 7 for _, _, _, ei, _, _ in pruned)
    # Fewer indexes asked than the library holds: the nearest by centre.
    asked = []
    search = window_index.ZoneIndex.search
    monkeypatch.setattr(window_index.ZoneIndex, "search", lambda self, *a, **kw: asked.append(self) or search(self, *a, **kw))
    monkeypatch.setattr(fill_patches, "PROBED_EXAMPLES", 4)
    chosen, _ = fill_patches._nearest_examples(searches, members, target, filled)
    assert len(asked) == 4 and len(chosen) == 4 and 7 in chosen
    def centre(ei):
        zone = searches[ei].zone_index(filled)
        return zone.cluster_distance(zone.query_vector(target, filled))

    by_centre = sorted(members, key=centre)
    assert set(chosen) == set(by_centre[:4])
    # Fewer examples than the limit: every one is searched, as before.
    few = fill_patches.search_fill(*args, members[:3], 100.0, target, filled, rng(0), patch_size=32, k=4)
    assert {ei for _, _, _, ei, _, _ in few} <= {0, 1, 2}
