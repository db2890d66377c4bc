"""The FFT search for fill windows against brute force (paper §4.2)."""

import numpy as np
import pytest

from terrasynth_core.matching.fill_search import FillSearch


def test_fft_search_matches_brute_force(white_mountains):
    """The FFT SSD (offset removed) ranks windows like a direct computation."""
    E = white_mountains.heights[:160, :160]
    search = FillSearch(E, (32, 32), coarse_factor=1)
    filled = np.zeros((32, 32), bool)
    filled[:, :10] = True
    target = E[50:82, 70:102] + 123.0  # an exact match, shifted in height
    best = search.best(target, filled, 3, np.random.default_rng(0))
    (r, c), ssd, offset = best[0]
    assert (r, c) == (50, 70)
    assert ssd < 1e-3 and offset == pytest.approx(123.0, abs=1e-3)


def test_fft_search_ranks_by_normalised_ssd_like_brute_force(white_mountains):
    """The search ranks windows by the SSD over the two windows' variances
    (so rough candidates are not beaten by smooth ones just for being
    smooth): its best pick is the brute-force best."""
    E = white_mountains.heights[:120, :120].astype(np.float64)
    search = FillSearch(white_mountains.heights[:120, :120], (24, 24), coarse_factor=1)
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
    (r, c), _, _ = search.best(target, filled, 1, rng)[0]
    assert (r, c) == np.unravel_index(np.argmin(scores), scores.shape)
