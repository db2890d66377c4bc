"""Ranking example feature samples against a sketch sample (paper §4.1):
rotation is free, mirrors and cyclic alignments are tried, the nearest
degree stands in for a missing one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrasynth_core.features.samples import FeatureSample
from terrasynth_core.matching.candidates import FeaturePool

RADIUS = 16.0


def _sample(center, angles_deg, kind="ridge", *, mirror=False) -> FeatureSample:
    """A sample whose crossings lie on its circle at the given angles
    (counter-clockwise on a north-up map), stored counter-clockwise."""
    a = np.radians(np.asarray(angles_deg, float))
    if mirror:
        a = math.pi - a  # left-right flip
    pts = np.column_stack([-np.sin(a), np.cos(a)]) * RADIUS + np.asarray(center, float)
    order = np.argsort(np.arctan2(-(pts[:, 0] - center[0]), pts[:, 1] - center[1]), kind="stable")
    return FeatureSample(np.asarray(center, float), kind, pts[order])


def _firsts(ranked) -> list:
    """Each example's best candidate, in rank order (a pool offers every
    alignment of a sample, so one example may rank several times)."""
    seen = {}
    for c in ranked:
        seen.setdefault(c.example, c)
    return list(seen.values())


def _rng():
    return np.random.default_rng(0)


def _turn(rel: np.ndarray, angle: float) -> np.ndarray:
    cos, sin = math.cos(angle), math.sin(angle)
    return rel @ np.array([[cos, -sin], [sin, cos]]).T


def test_a_turned_copy_ranks_first_whatever_its_first_crossing():
    sketch = _sample((60, 60), [10, 130, 200])
    # The same branch turned by 75 degrees: its counter-clockwise order starts
    # at another arm, so only one cyclic alignment fits.
    same = _sample((30, 40), [85, 205, 275])
    other = _sample((90, 90), [0, 60, 120])
    pool = FeaturePool([(0, [other]), (1, [same])], RADIUS, mirror=False)
    best, second = _firsts(pool.rank(sketch, 6, _rng()))
    assert best.example == 1 and best.deformation < 1e-5
    assert second.example == 0 and second.deformation > 0.1
    assert not best.mirrored
    # Control points correspond one to one: the example's, relative to its
    # centre, are the sketch's turned by the same angle.
    src = best.target[1:] - best.target[0]
    dst = best.control[1:] - best.control[0]
    angle = math.atan2(src[0, 0] * dst[0, 1] - src[0, 1] * dst[0, 0], src[0] @ dst[0])
    np.testing.assert_allclose(_turn(src, angle), dst, atol=1e-6)
    np.testing.assert_allclose(best.target[0], sketch.center)
    np.testing.assert_allclose(best.control[0], same.center)


def test_a_mirror_image_fits_only_with_mirrors_on():
    sketch = _sample((60, 60), [0, 100, 160])
    flipped = _sample((30, 30), [0, 100, 160], mirror=True)
    plain = FeaturePool([(0, [flipped])], RADIUS, mirror=False).rank(sketch, 1, _rng())[0]
    assert plain.deformation > 0.05
    mirrored = FeaturePool([(0, [flipped])], RADIUS, mirror=True).rank(sketch, 1, _rng())[0]
    assert mirrored.mirrored and mirrored.deformation < 1e-5


def test_missing_degree_falls_back_to_the_nearest():
    three = _sample((30, 30), [0, 120, 240])
    five = _sample((70, 70), [0, 72, 144, 216, 288])
    pool = FeaturePool([(0, [three, five])], RADIUS, mirror=True)
    assert pool.degrees == [3, 5] and pool.size() == 2 and pool.size(4) == 0
    assert pool.nearest_degree(4) == 5  # a tie goes to the higher degree
    assert pool.nearest_degree(2) == 3
    four = _sample((60, 60), [0, 90, 180, 270])
    ranked = pool.rank(four, 10, _rng())
    assert {c.example for c in ranked} == {0}
    # The sketch's four crossings meet the five of the stand-in: both are
    # trimmed to four evenly spread ones.
    assert all(c.control.shape == c.target.shape == (5, 2) for c in ranked)
    np.testing.assert_allclose(ranked[0].control[0], five.center)
    assert FeaturePool([], RADIUS, mirror=False).rank(four, 3, _rng()) == []


def test_ties_are_broken_by_the_seed():
    sketch = _sample((60, 60), [0])
    ends = [_sample((20 + 10 * i, 40), [30 * i]) for i in range(8)]
    pool = FeaturePool([(i, [s]) for i, s in enumerate(ends)], RADIUS, mirror=False)
    first = [c.example for c in pool.rank(sketch, 8, np.random.default_rng(1))]
    again = [c.example for c in pool.rank(sketch, 8, np.random.default_rng(1))]
    other = [c.example for c in pool.rank(sketch, 8, np.random.default_rng(2))]
    assert first == again and sorted(first) == list(range(8)) and first != other
    assert all(c.deformation < 1e-5 for c in pool.rank(sketch, 8, np.random.default_rng(1)))


@pytest.mark.parametrize("degree", [3, 4])
def test_deformation_grows_with_the_distortion_of_a_branch(degree):
    base = np.arange(degree) * 360.0 / degree
    sketch = _sample((60, 60), base)
    bent = [_sample((30, 30 + 40 * i), base + np.r_[0.0, 8.0 * i, np.zeros(degree - 2)]) for i in range(4)]
    pool = FeaturePool([(i, [s]) for i, s in enumerate(bent)], RADIUS, mirror=False)
    ranked = _firsts(pool.rank(sketch, 4 * 2 * degree, _rng()))
    assert [c.example for c in ranked] == [0, 1, 2, 3]
    costs = [c.deformation for c in ranked]
    assert costs[0] < 1e-5 and all(b > a for a, b in zip(costs, costs[1:]))


def test_excluded_samples_rank_after_every_allowed_one_least_used_first():
    sketch = _sample((60, 60), [0, 180], kind="ridge")
    straight = [_sample((30 + 40 * i, 40), [0, 180 - 5 * i]) for i in range(4)]  # straightest first
    pool = FeaturePool([(0, straight)], RADIUS, mirror=False)
    plain = [c.center[0] for c in pool.rank(sketch, 8, _rng())]
    assert plain[0] == 30

    def exclude(examples, centres):  # the two straightest are used: the first more
        return np.where(centres[:, 0] == 30, 5, np.where(centres[:, 0] == 70, 3, 0))

    ranked = [c.center[0] for c in pool.rank(sketch, 8, _rng(), exclude=exclude)]
    assert len(ranked) == 8  # as many as asked, the excluded at the end
    # A path has two alignments (a half turn apart, which rotation makes equal).
    assert ranked == [110, 110, 150, 150, 70, 70, 30, 30]


def test_prominence_ranks_share_ties_and_span_zero_to_one():
    from terrasynth_core.matching.candidates import prominence_ranks

    ranks = prominence_ranks(np.array([5.0, -1.0, 5.0, 2.0]))
    assert ranks.tolist() == pytest.approx([(2 + 3) / 2 / 3, 0.0, (2 + 3) / 2 / 3, 1 / 3])
    assert prominence_ranks(np.array([7.0])).tolist() == [1.0]


def test_equally_shaped_candidates_rank_by_prominence():
    # Two identical straight samples: the more prominent one comes first.
    same = [_sample((100, 100), [0, 180])]
    pool = FeaturePool([(0, same), (1, list(same))], RADIUS, mirror=False,
                       prominence=[np.array([0.5]), np.array([2.0])])
    ranked = pool.rank(_sample((50, 50), [0, 180]), 4, _rng())
    assert ranked[0].example == 1 and ranked[0].prominence == 1.0
    assert ranked[-1].prominence == 0.0 and ranked[-1].plainness > 0


def test_prominence_does_not_promote_a_candidate_that_fits_badly():
    from terrasynth_core.matching.candidates import PROMINENCE_SLACK

    # Example 1 is more prominent but bent 60 degrees away from the straight
    # sketch sample: far beyond the slack, it must not outrank the straight one.
    straight = [_sample((100, 100), [0, 180])]
    bent = [_sample((100, 100), [0, 120])]
    pool = FeaturePool([(0, straight), (1, bent)], RADIUS, mirror=False,
                       prominence=[np.array([0.0]), np.array([9.0])])
    ranked = pool.rank(_sample((50, 50), [0, 180]), 4, _rng())
    assert ranked[0].example == 0
    assert ranked[0].deformation + PROMINENCE_SLACK < min(c.deformation for c in ranked if c.example == 1)


@pytest.mark.parametrize("mirror", [False, True])
def test_a_pool_ranks_every_sample_as_a_fresh_pool_does(mirror):
    """The alignments a pool keeps per degree after its first ranking give
    the very rankings (costs to the bit) a fresh pool gives, for several
    samples in a row, a degree the pool lacks among them."""
    gen = np.random.default_rng(11)
    examples = [_sample((200.0 + 7 * i, 300.0 - 5 * i), sorted(gen.uniform(0, 360, size=d)))
                for i, d in enumerate([2, 3, 2, 1, 3, 2, 3, 1, 2])]
    kept = FeaturePool([(0, examples[:5]), (1, examples[5:])], RADIUS, mirror=mirror)
    sketches = [_sample((50.0, 60.0), angles) for angles in ([10, 170], [0, 100, 230], [20, 190], [5, 95, 185, 275])]
    for sketch in sketches + sketches:
        fresh = FeaturePool([(0, examples[:5]), (1, examples[5:])], RADIUS, mirror=mirror)
        got, want = kept.rank(sketch, 6, np.random.default_rng(2)), fresh.rank(sketch, 6, np.random.default_rng(2))
        assert len(got) == len(want) > 0
        for a, b in zip(got, want):
            assert (a.example, a.mirrored, a.deformation, a.prominence) == (b.example, b.mirrored, b.deformation,
                                                                          b.prominence)
            assert a.control.tobytes() == b.control.tobytes() and a.target.tobytes() == b.target.tobytes()


def test_a_pool_kept_in_the_example_cache_ranks_as_one_in_memory_and_maps_its_arrays():
    """A library's pool is stored and mapped (a worker then holds file pages
    the system can drop, not its own copy): made again from the store it
    ranks every sample exactly as a pool kept in memory."""
    from terrasynth_core.exemplars import cache
    from terrasynth_core.features.samples import SampleTable

    rng = np.random.default_rng(3)
    n = 20_000  # large enough for the arrays to be files of their own
    centers = rng.uniform(0, 1000, (n, 2))
    angles = np.sort(rng.uniform(0, 2 * math.pi, (n, 3)), axis=1)
    crossings = (centers[:, None, :] + RADIUS * np.stack([-np.sin(angles), np.cos(angles)], axis=-1)).reshape(-1, 2)
    table = SampleTable("ridge", centers, np.full(n, 3), crossings)
    prominence = [rng.random(n)]

    def keep(name, make, dtype):
        return cache.kept_array(f"test-pool-{name}", make, name=name, dtype=dtype)

    plain = FeaturePool([(0, table)], RADIUS, mirror=True, prominence=prominence)
    stored, again = (FeaturePool([(0, table)], RADIUS, mirror=True, prominence=prominence, keep=keep)
                     for _ in range(2))
    for s in (table[5], table[n // 2], _sample((10.0, 10.0), [0, 100, 230])):
        ranked = [p.rank(s, 12, _rng()) for p in (plain, stored, again)]
        assert [(c.example, c.center.tolist(), c.deformation, c.mirrored) for c in ranked[0]] == \
               [(c.example, c.center.tolist(), c.deformation, c.mirrored) for c in ranked[1]] == \
               [(c.example, c.center.tolist(), c.deformation, c.mirrored) for c in ranked[2]]
    assert isinstance(again._groups[3][2], np.memmap) and isinstance(again._aligned[3][2], np.memmap)
