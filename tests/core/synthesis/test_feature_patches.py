"""Feature patches: which example features a stroke gets, and warps that
never fold or streak."""

from __future__ import annotations

import numpy as np

from terrasynth_core.features.samples import FeatureSample
from terrasynth_core.matching.candidates import Candidate
from terrasynth_core.matching.usage import UsageRegistry
from terrasynth_core.synthesis.feature_patches import (
    MAX_STRETCH,
    prepare_feature,
    sample_prominence,
    standing_map,
)
from terrasynth_core.warping import ThinPlateSpline, framed, warp_distortion

R = 40.0


def _valley_example() -> np.ndarray:
    """Two east-west valleys on a plain: row 60 a deep pit on a faint
    groove, row 180 a groove evenly deep all along."""
    rr, cc = np.mgrid[0:240, 0:240].astype(np.float64)
    h = 500.0 + 0.0 * rr
    h -= 2.0 * np.exp(-((rr - 60) ** 2) / 18.0)
    h -= 120.0 * np.exp(-((rr - 60) ** 2 + (cc - 120) ** 2) / 8.0)
    h -= 60.0 * np.exp(-((rr - 180) ** 2) / 18.0)
    return h.astype(np.float32)


def _path_sample(row: float, col: float, kind: str = "valley") -> FeatureSample:
    return FeatureSample(np.array([row, col]), kind, np.array([[row, col - R], [row, col + R]]))


def test_prominence_is_read_along_the_feature_not_at_a_pit():
    heights = _valley_example()
    standing = standing_map(heights, 2 * R)
    pit, groove = _path_sample(60, 120), _path_sample(180, 120)
    prom = sample_prominence(standing, [pit, groove], "valley")
    # At its centre the pit stands out more than the groove ...
    assert -standing[60, 120] > -standing[180, 120]
    # ... but the groove is the better valley for a whole patch.
    assert prom[1] > prom[0]
    # Ridges read the other way: neither valley is a ridge.
    assert np.all(sample_prominence(standing, [pit, groove], "ridge") < prom.min())


class _Pool:
    """A pool that offers a fixed list of candidates."""

    def __init__(self, candidates):
        self.candidates = candidates

    def rank(self, sample, count, rng, *, exclude=None, crowding=None):
        return self.candidates[:count]


def test_folding_candidates_are_never_warped_while_a_fitting_one_exists():
    example = np.random.default_rng(0).normal(0, 10, (300, 300)).astype(np.float32)
    sample = _path_sample(100.0, 100.0, "ridge")
    target = np.vstack([sample.center, sample.crossings])
    # A hairpin: both crossings on one side of the centre (the map folds).
    hairpin = Candidate(0, np.array([150.0, 150.0]), np.array([[150.0, 150.0], [110.0, 175.0], [190.0, 175.0]]),
                        target, False, 0.01)
    straight = Candidate(0, np.array([150.0, 140.0]), np.array([[150.0, 140.0], [150.0, 100.0], [150.0, 180.0]]),
                         target, False, 0.02)
    window = dict(shape=(240, 240), patch_size=80, count=2, rng=np.random.default_rng(0),
                  usage=UsageRegistry(80), cap=5)
    bbox, warped, rigid = prepare_feature(sample, _Pool([hairpin, straight]), [example], **window)
    assert [c for c, _ in warped] == [straight] and not rigid
    # With only the hairpin, it is turned rigidly onto the stroke instead.
    bbox, warped, rigid = prepare_feature(sample, _Pool([hairpin]), [example], **window)
    assert [c for c, _ in warped] == [hairpin] and rigid
    r0, r1, c0, c1 = bbox
    bent = ThinPlateSpline.fit(*framed(hairpin.target, hairpin.control, reflect=False), regularization=1e-3)
    assert warp_distortion(bent, (r0, c0), (r1 - r0, c1 - c0)) > MAX_STRETCH


def test_a_window_too_thin_for_a_patch_prepares_nothing():
    example = np.zeros((300, 300), np.float32)
    sample = _path_sample(1.0, 100.0, "ridge")
    prepared = prepare_feature(sample, _Pool([]), [example], shape=(3, 240), patch_size=80, count=2,
                               rng=np.random.default_rng(0), usage=UsageRegistry(80), cap=5)
    assert prepared[1:] == ([], False)
