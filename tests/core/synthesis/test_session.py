"""The synthesis engine: parameters, events, determinism, cancellation,
bad input, and that the terrain follows the sketch."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.matching.usage import FEATURE_KINDS
from terrasynth_core.measures import feature_tpi_score
from terrasynth_core.errors import ParamsError, SynthesisCancelled
from terrasynth_core.features.sketch import SketchMap, read_sketch, sketch_features
from terrasynth_core.heightfield import HeightField
from terrasynth_core.synthesis import (
    PatchPlaced,
    Session,
    StageFinished,
    StageStarted,
    SynthesisFinished,
    SynthesisParams,
)

SMALL = SynthesisParams(patch_size=32, k=3, seed=3)


@pytest.fixture(scope="module")
def y_sketch(sketch_dir) -> SketchMap:
    return read_sketch(sketch_dir / "y_junction_512.png").resized((192, 192))


@pytest.fixture(scope="module")
def y_result(white_mountains, y_sketch):
    return Session([white_mountains], y_sketch, params=SMALL).run()


def test_params_are_validated():
    with pytest.raises(ParamsError, match="patch_size"):
        SynthesisParams(patch_size=4)
    with pytest.raises(ParamsError, match="order"):
        SynthesisParams(order="spiral")
    with pytest.raises(ParamsError, match="overlap"):
        SynthesisParams(patch_size=40, overlap=30)
    with pytest.raises(ParamsError, match="overlap"):
        SynthesisParams(overlap=41)  # an automatic patch is at most 80 cells
    with pytest.raises(ParamsError, match="patch_size"):
        SynthesisParams(patch_size=True)
    with pytest.raises(ParamsError, match="unknown"):
        SynthesisParams.from_dict({"patch_sise": 80})
    assert SynthesisParams().patch_size is None  # automatic
    assert SynthesisParams(patch_size=80).overlap_cells == 80 // 3
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


def test_same_seed_same_bytes(white_mountains, y_sketch, y_result):
    again = Session([white_mountains], y_sketch, params=SMALL).run()
    assert again.heights.tobytes() == y_result.heights.tobytes()
    other = Session([white_mountains], y_sketch, params=SynthesisParams(patch_size=32, k=3, seed=4)).run()
    assert other.heights.tobytes() != y_result.heights.tobytes()


def test_events_come_in_order(white_mountains, y_sketch):
    events = list(Session([white_mountains], y_sketch, params=SMALL).iter_run())
    kinds = [type(e) for e in events]
    assert kinds[0] is StageStarted and kinds[-1] is SynthesisFinished
    stages = [e.stage for e in events if isinstance(e, StageStarted)]
    assert stages == ["landform", "analyse", "features", "fill", "finish"]
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
    assert sum(isinstance(e, StageFinished) for e in events) == 5


def test_cancel_stops_at_a_patch(white_mountains, y_sketch):
    session = Session([white_mountains], y_sketch, params=SMALL)
    seen = []

    def cancel():
        return len(seen) >= 3

    with pytest.raises(SynthesisCancelled):
        session.run(progress=lambda e: seen.append(e) if isinstance(e, PatchPlaced) else None, cancel=cancel)
    assert len(seen) == 3


def test_raster_order_and_plain_paste_also_run(white_mountains, y_sketch):
    params = SynthesisParams(patch_size=32, k=2, order="raster", seam="paste", blend="none")
    r = Session([white_mountains], y_sketch, params=params).run()
    assert np.isfinite(r.heights).all() and not r.seam_mask.any()


def test_blank_sketch_gives_non_feature_synthesis(white_mountains):
    blank = SketchMap(np.zeros((96, 96), bool), np.zeros((96, 96), bool))
    session = Session([white_mountains], blank, params=SMALL)
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


def test_nodata_in_the_example_is_cropped(white_mountains, y_sketch):
    h = white_mountains.heights.copy()
    h[:40, :] = np.nan
    session = Session([white_mountains.with_heights(h)], y_sketch, params=SMALL)
    assert any("cropped" in w for w in session.warnings)
    # 360 x 400 valid cells of 93 x 66 m, at square 66 m cells.
    rows, cols = session.examples[0].heights.shape
    dy, dx = white_mountains.cell_size
    assert rows == pytest.approx(360 * dy / dx, abs=4) and cols == pytest.approx(400, abs=4)


def test_voids_inside_the_example_are_never_copied(white_mountains, y_sketch):
    """A void inside the example (an SRTM hole the largest valid rectangle
    would halve the example for) is kept, filled, and no patch of the run,
    fill or feature, takes a cell of it."""
    h = white_mountains.heights.copy()
    h[150:210, 60:260] = np.nan
    session = Session([white_mountains.with_heights(h)], y_sketch, params=SMALL)
    assert any("filled and kept out of every patch" in w for w in session.warnings)
    example = session.examples[0]
    assert example.valid is not None and example.heights.shape[1] == pytest.approx(400, abs=4)
    result = session.run()
    p = SMALL.patch_size
    margin = int(np.ceil(p / 2 * 1.1)) + 1
    kinds = set()
    for rec in result.patches:
        kinds.add(rec.kind)
        r, c = (int(round(v)) for v in rec.source)
        if rec.kind == "fill":
            assert example.valid[r:r + p, c:c + p].all(), rec
        elif rec.kind in FEATURE_KINDS:
            assert example.valid[r - margin:r + margin + 1, c - margin:c + margin + 1].all(), rec
    assert "fill" in kinds and kinds & set(FEATURE_KINDS)


def test_sketch_is_scaled_to_the_output_size(white_mountains, y_sketch):
    session = Session([white_mountains], y_sketch, shape=(128, 160), params=SMALL)
    assert session.sketch.shape == (128, 160)
    # (The square sketch stretched to 4:5: said; scaled in proportion: not.)
    assert any("sketch (" in w and "stretched" in w and "128x160" in w for w in session.warnings)
    same = Session([white_mountains], y_sketch, shape=(160, 160), params=SMALL)
    assert not any("stretched" in w for w in same.warnings)
    with pytest.raises(ParamsError, match="smaller than a patch"):
        Session([white_mountains], y_sketch, shape=(20, 300), params=SMALL)
