"""The synthesis engine: parameters, events, determinism, cancellation,
bad input, and that the terrain follows the sketch."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.measures import feature_tpi_score
from terrasynth_core.errors import ParamsError, SynthesisCancelled
from terrasynth_core.features.sketch import SketchMap, read_sketch, sketch_features
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem
from terrasynth_core.synthesis import (
    PatchPlaced,
    Session,
    StageFinished,
    StageStarted,
    SynthesisFinished,
    SynthesisParams,
)
from terrasynth_core.matching.fill_search import FillSearch

SMALL = SynthesisParams(patch_size=32, k=3, seed=3)


@pytest.fixture(scope="module")
def example(dems_dir) -> HeightField:
    """A 400x400 corner of the White Mountains: quick but real."""
    field = load_dem(dems_dir / "N44W072.hgt")
    return field.with_heights(field.heights[300:700, 300:700].copy())


@pytest.fixture(scope="module")
def y_sketch(sketch_dir) -> SketchMap:
    return read_sketch(sketch_dir / "y_junction_512.png").resized((192, 192))


@pytest.fixture(scope="module")
def y_result(example, y_sketch):
    return Session([example], y_sketch, params=SMALL).run()


def test_params_are_validated():
    with pytest.raises(ParamsError, match="patch_size"):
        SynthesisParams(patch_size=4)
    with pytest.raises(ParamsError, match="order"):
        SynthesisParams(order="spiral")
    with pytest.raises(ParamsError, match="overlap"):
        SynthesisParams(patch_size=40, overlap=30)
    with pytest.raises(ParamsError, match="unknown"):
        SynthesisParams.from_dict({"patch_sise": 80})
    assert SynthesisParams().overlap_cells == 80 // 3
    assert SynthesisParams.from_dict(SynthesisParams(seed=5).to_dict()) == SynthesisParams(seed=5)


def test_result_covers_the_output(y_result):
    r = y_result
    assert r.heights.shape == (192, 192) and r.heights.dtype == np.float32
    assert np.isfinite(r.heights).all()
    assert (r.patch_id >= 0).all(), "every cell comes from some patch"
    assert r.patch_id.max() == len(r.patches) - 1
    counts = r.counts()
    assert counts["branch"] >= 1 and counts["path"] >= 3 and counts["fill"] >= 1
    assert r.seam_mask.any()
    report = r.report()
    assert report["patch_counts"] == counts and report["total_seconds"] > 0
    assert set(report["timings"]) >= {"analyse", "features", "fill"}


def test_terrain_follows_the_sketch(y_result, y_sketch):
    """Independent of the algorithm: the sketched ridge stands above its
    surroundings (topographic position index in standard deviations)."""
    ridges = sketch_features(y_sketch).ridges
    score = feature_tpi_score(y_result.heights, ridges, radius=12)
    assert score > 0.5


def test_same_seed_same_bytes(example, y_sketch, y_result):
    again = Session([example], y_sketch, params=SMALL).run()
    assert again.heights.tobytes() == y_result.heights.tobytes()
    other = Session([example], y_sketch, params=SynthesisParams(patch_size=32, k=3, seed=4)).run()
    assert other.heights.tobytes() != y_result.heights.tobytes()


def test_events_come_in_order(example, y_sketch):
    events = list(Session([example], y_sketch, params=SMALL).iter_run())
    kinds = [type(e) for e in events]
    assert kinds[0] is StageStarted and kinds[-1] is SynthesisFinished
    stages = [e.stage for e in events if isinstance(e, StageStarted)]
    assert stages == ["analyse", "features", "fill", "finish"]
    placed = [e for e in events if isinstance(e, PatchPlaced)]
    assert [e.index for e in placed] == list(range(len(placed)))
    # Feature patches (breadth-first from the branch) come before the fill.
    first_fill = next(i for i, e in enumerate(placed) if e.kind == "fill")
    assert all(e.kind != "fill" for e in placed[:first_fill])
    assert placed[0].kind == "branch"
    result = events[-1].result
    for e in placed:
        r0, r1, c0, c1 = e.bbox
        assert 0 <= r0 < r1 <= 192 and 0 <= c0 < c1 <= 192
        assert e.heights.shape == (r1 - r0, c1 - c0)
    # The last patch's window shows the final heights.
    r0, r1, c0, c1 = placed[-1].bbox
    assert np.array_equal(placed[-1].heights, result.heights[r0:r1, c0:c1])
    assert sum(isinstance(e, StageFinished) for e in events) == 4


def test_cancel_stops_at_a_patch(example, y_sketch):
    session = Session([example], y_sketch, params=SMALL)
    seen = []

    def cancel():
        return len(seen) >= 3

    with pytest.raises(SynthesisCancelled):
        session.run(progress=lambda e: seen.append(e) if isinstance(e, PatchPlaced) else None, cancel=cancel)
    assert len(seen) == 3


def test_raster_order_and_plain_paste_also_run(example, y_sketch):
    params = SynthesisParams(patch_size=32, k=2, order="raster", seam="paste", blend="none")
    r = Session([example], y_sketch, params=params).run()
    assert np.isfinite(r.heights).all() and not r.seam_mask.any()


def test_blank_sketch_gives_non_feature_synthesis(example):
    blank = SketchMap(np.zeros((96, 96), bool), np.zeros((96, 96), bool))
    session = Session([example], blank, params=SMALL)
    assert any("no strokes" in w for w in session.warnings)
    r = session.run()
    assert r.counts()["fill"] > 0 and r.counts()["path"] == 0


def test_example_smaller_than_a_patch_is_refused(y_sketch):
    tiny = HeightField(np.random.default_rng(0).random((20, 20), dtype=np.float32), source="tiny.npy")
    with pytest.raises(ParamsError, match="tiny.npy.*smaller than a patch"):
        Session([tiny], y_sketch, params=SMALL)


def test_example_without_needed_features_is_refused(y_sketch):
    ramp = np.add.outer(np.arange(200.0), np.arange(200.0)).astype(np.float32)
    with pytest.raises(ParamsError, match="no example has ridge features"):
        Session([HeightField(ramp, source="ramp")], y_sketch, params=SMALL)


def test_nodata_in_the_example_is_cropped(example, y_sketch):
    h = example.heights.copy()
    h[:40, :] = np.nan
    session = Session([example.with_heights(h)], y_sketch, params=SMALL)
    assert any("cropped" in w for w in session.warnings)
    assert session.examples[0].heights.shape == (360, 400)


def test_sketch_is_scaled_to_the_output_size(example, y_sketch):
    session = Session([example], y_sketch, shape=(128, 160), params=SMALL)
    assert session.sketch.shape == (128, 160)
    with pytest.raises(ParamsError, match="smaller than a patch"):
        Session([example], y_sketch, shape=(20, 300), params=SMALL)


def test_fft_search_matches_brute_force(example):
    """The FFT SSD (offset removed) ranks windows like a direct computation."""
    E = example.heights[:160, :160]
    search = FillSearch(E, (32, 32), coarse_factor=1)
    filled = np.zeros((32, 32), bool)
    filled[:, :10] = True
    target = E[50:82, 70:102] + 123.0  # an exact match, shifted in height
    best = search.best(target, filled, 3, np.random.default_rng(0))
    (r, c), ssd, offset = best[0]
    assert (r, c) == (50, 70)
    assert ssd < 1e-3 and offset == pytest.approx(123.0, abs=1e-3)


def test_fft_search_ranks_by_normalised_ssd_like_brute_force(example):
    """The search ranks windows by the SSD over the two windows' variances
    (so rough candidates are not beaten by smooth ones just for being
    smooth): its best pick is the brute-force best."""
    E = example.heights[:120, :120].astype(np.float64)
    search = FillSearch(example.heights[:120, :120], (24, 24), coarse_factor=1)
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


def test_analysis_disk_cache_round_trips_and_survives_damage(example, tmp_path, monkeypatch):
    from terrasynth_core.exemplars import prepare as an

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    an._CACHE.clear()
    first = an.prepare_example(example, 32)
    files = list(tmp_path.glob("example-*.npz"))
    assert len(files) == 1
    an._CACHE.clear()
    second = an.prepare_example(example, 32)  # from disk
    for kind in ("ridge", "valley"):
        a, b = first.samples[kind], second.samples[kind]
        assert len(a) == len(b) > 0
        assert all(np.array_equal(x.crossings, y.crossings) and np.array_equal(x.center, y.center)
                   for x, y in zip(a, b))
    assert np.array_equal(first.strong_mask, second.strong_mask) and first.relief == second.relief
    assert len(second.features.ridges.paths) == len(first.features.ridges.paths)
    files[0].write_bytes(b"not an npz")
    an._CACHE.clear()
    third = an.prepare_example(example, 32)  # damaged file: recomputed, not an error
    assert len(third.samples["ridge"]) == len(first.samples["ridge"])
