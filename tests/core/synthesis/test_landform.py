"""The landform pass: a coarse synthesis of the same problem becomes the
level field, and the full-resolution pass copies only the detail above it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.examples import builtin_example
from terrasynth_core.features import read_sketch
from terrasynth_core.features.network import graph_mask
from terrasynth_core.features.sketch import SketchMap, sketch_features
from terrasynth_core.synthesis import Session, SynthesisParams
from terrasynth_core.synthesis.landform import (
    COHERENT_REACH,
    COHERENT_SHARE,
    FACTORS,
    coarse_factor,
    coherence,
    coarse_patch,
    detail_above,
    drawn_level,
    drawn_split,
    landform_lowpass,
    landform_pass,
    preview_patch,
    FIT_QUANTILES,
    MAX_GAIN,
    STROKE_SIDE,
    fitted_heights,
    split_sigma,
    fitted_to_examples,
    _open_valleys,
)

P = SynthesisParams(patch_size=32, k=2, seed=1)


@pytest.fixture(scope="module")
def y_sketch(sketch_dir):
    return read_sketch(sketch_dir / "y_junction_512.png").resized((256, 256))


def test_detail_and_level_bands_add_up_to_the_example_power():
    # Red noise has every wavelength, most power at the long ones, like a
    # terrain: the detail keeps (1 - g)^2 of its power and the level's
    # low-pass the rest, so together they keep all of it (a plain g for
    # the level would lose up to half where the bands cross).
    rng = np.random.default_rng(0)
    f = np.hypot(np.fft.fftfreq(512)[:, None], np.fft.fftfreq(512)[None, :])
    noise = np.fft.ifft2(np.fft.fft2(rng.normal(0, 1, (512, 512))) / np.maximum(f, 1 / 512)).real
    noise = noise.astype(np.float32)
    sigma = 6.0
    high, low = detail_above(noise, sigma), landform_lowpass(noise, sigma)
    assert high.var() + low.var() == pytest.approx(noise.var(), rel=0.05)
    plain = ndimage.gaussian_filter(noise.astype(np.float64), sigma, mode="reflect")
    assert high.var() + plain.var() < 0.97 * noise.var()
    assert abs(float(high.mean())) < 0.01 * noise.std()


def test_about_the_strokes_aligned_bands_add_up_to_the_landform_in_amplitude():
    # A ridge the coarse pass put on a stroke and a feature patch put there
    # again: the same landform in both bands.  With the power-complementary
    # level the two add to more than the landform (l + 1 - g > 1); with
    # full coherence they add to it exactly.
    cols = np.arange(512, dtype=np.float64)
    ridge = np.tile(100.0 * np.exp(-0.5 * ((cols - 256) / 12.0) ** 2), (64, 1)).astype(np.float32)
    sigma = 6.0
    detail = detail_above(ridge, sigma)
    independent = landform_lowpass(ridge, sigma) + detail
    aligned = landform_lowpass(ridge, sigma, np.ones(ridge.shape)) + detail
    half = landform_lowpass(ridge, sigma, np.full(ridge.shape, 0.5)) + detail
    assert independent.max() > 1.05 * ridge.max()
    np.testing.assert_allclose(aligned, ridge, atol=0.01 * float(ridge.max()))
    assert ridge.max() < half.max() < independent.max()


def test_coherence_is_the_share_about_the_strokes_and_nothing_far_away(y_sketch):
    maps = sketch_features(y_sketch)
    patch, f = 32, 2
    weight = coherence(maps, patch, f)
    assert weight.shape == y_sketch.shape
    away = ndimage.distance_transform_edt(~(graph_mask(maps.ridges) | graph_mask(maps.valleys))) * f
    assert weight[away <= COHERENT_REACH * patch].min() == pytest.approx(COHERENT_SHARE)
    assert weight[away >= 2 * COHERENT_REACH * patch + f].max() == 0.0
    blank = np.zeros((64, 64), bool)
    assert coherence(sketch_features(SketchMap(blank, blank)), patch, f) is None
    assert coherence(None, patch, f) is None


def test_both_bands_are_local_and_exact_on_planes():
    rr, cc = np.mgrid[0:200, 0:300].astype(np.float32)
    plane = 3.0 * rr - 2.0 * cc + 500.0
    assert np.abs(detail_above(plane, 8.0)[30:-30, 30:-30]).max() < 0.05
    assert np.abs(landform_lowpass(plane, 8.0) - plane)[40:-40, 40:-40].max() < 0.05


def test_fitted_heights_is_monotone_smooth_and_holds_its_gain():
    rng = np.random.default_rng(1)
    heights = rng.uniform(200, 800, 4000)
    source = np.quantile(heights, FIT_QUANTILES)
    target = source * 1.5 - 100.0
    mapped = fitted_heights(heights, source, target)
    # The quantiles land on the target, and the order of heights is kept.
    assert np.quantile(mapped, FIT_QUANTILES) == pytest.approx(target, rel=1e-3)
    assert np.array_equal(np.argsort(mapped), np.argsort(heights))
    # No step or crease: the map's slope changes smoothly through a knot.
    knot = source[len(source) // 2]
    x = np.linspace(knot - 1.0, knot + 1.0, 201)
    slope = np.diff(fitted_heights(x, source, np.quantile(heights, FIT_QUANTILES) ** 1.05)) / np.diff(x)
    assert np.abs(np.diff(slope)).max() < 0.01 * slope.mean()
    # A stretch beyond MAX_GAIN is held to it, counted out from the median.
    steep = fitted_heights(heights, source, source * 10.0)
    assert np.ptp(steep) == pytest.approx(MAX_GAIN * np.ptp(heights), rel=0.02)
    # A flat terrain is moved, not shaped.
    flat = np.full(50, 300.0)
    assert np.all(fitted_heights(flat, np.full(len(FIT_QUANTILES), 300.0), target) == target[len(target) // 2])


def test_fitted_to_examples_fits_regional_relief_and_keeps_landforms(y_sketch):
    # A coarse terrain that sank and holds under half the example's relief,
    # in regional relief and landforms: the fit brings its heights onto
    # the example's, moving only the largest scales (the landforms' shapes,
    # the level's wavelengths up to a few patches, stay as they are).
    example = builtin_example("white-mountains").load()
    session = Session([example], y_sketch, shape=(256, 256), params=P)
    layout, f = session.layout, 2
    sigma = split_sigma(P.patch_size)
    ex = np.asarray(session.layout.examples[0].heights, np.float64)
    rng = np.random.default_rng(3)
    span = np.ptp(np.percentile(ex, [0.5, 99.5]))

    def field(s):
        noise = ndimage.gaussian_filter(rng.normal(0, 1, (128, 128)), s, mode="wrap")
        return noise / np.ptp(noise)

    sunk = float(np.median(ex)) - 400.0 + 0.25 * span * (field(3) + field(20))
    fitted = fitted_to_examples(sunk.astype(np.float32), layout, f, sigma).astype(np.float64)
    want = np.percentile(ex, [0.5, 50, 99.5])
    got = np.percentile(fitted, [0.5, 50, 99.5])
    assert abs(got[1] - want[1]) < 0.1 * (want[2] - want[0])
    # (The level takes a little less than the example's whole spread: the
    # fit leaves room for the detail the full-resolution pass adds.)
    assert np.ptp(np.percentile(sunk, [0.5, 99.5])) / (want[2] - want[0]) < 0.5
    assert 0.75 <= (got[2] - got[0]) / (want[2] - want[0]) <= 1.1
    # The change is regional: at the landforms' own scale (the detail above
    # the split, on the coarse grid) it is nearly nothing.
    change = fitted - sunk
    # (A uniform stretch of the terrain changes it there by a third of the
    # change's spread: np.std(detail_above(sunk, ...)) / np.std(sunk).)
    assert np.std(detail_above(change, sigma / f)) < 0.08 * np.std(change)
    assert np.std(detail_above(sunk, sigma / f)) > 0.25 * np.std(sunk)
    assert fitted_to_examples(sunk.astype(np.float32), layout, f, sigma).tobytes() == fitted.astype(np.float32).tobytes()


def _fitted_with_and_without(sketch, seed: int):
    """A flat-ish coarse terrain (128 x 128 under a 256 x 256 output) fitted
    to the White Mountains without and with ``sketch``'s strokes, the
    strokes, and the height percentile of a mask's cells."""
    example = builtin_example("white-mountains").load()
    session = Session([example], sketch, shape=(256, 256), params=P)
    sigma, f = split_sigma(P.patch_size), 2
    rng = np.random.default_rng(seed)
    terrain = (500.0 + 50.0 * ndimage.gaussian_filter(rng.normal(0, 1, (128, 128)), 3, mode="wrap"))
    strokes = sketch_features(sketch.resized((128, 128)))
    plain = fitted_to_examples(terrain.astype(np.float32), session.layout, f, sigma)
    drawn = fitted_to_examples(terrain.astype(np.float32), session.layout, f, sigma, strokes)
    pct = lambda h, m: float((h[m][:, None] > h.ravel()[None, :]).mean())  # noqa: E731
    return plain, drawn, strokes, pct


def test_fitted_to_examples_raises_the_regions_of_the_drawn_ridges(y_sketch):
    # Under the Y's ridges the fitted regional relief stands high about the
    # strokes, and not only where the coarse terrain happened to stand high.
    plain, drawn, strokes, pct = _fitted_with_and_without(y_sketch, 4)
    ridge = graph_mask(strokes.ridges)
    assert pct(drawn, ridge) > pct(plain, ridge) + 0.1
    assert pct(drawn, ridge) > 0.75


def test_fitted_to_examples_lowers_a_valley_drawn_between_close_ridges(sketch_dir):
    # The S-valley: two ridges flank the valley closer than the regional
    # scale.  Its valley must be the low of its region, not raised by the
    # ridges on either side, and the ridges the highs.
    sketch = read_sketch(sketch_dir / "s_valley_1000.png").resized((256, 256))
    plain, drawn, strokes, pct = _fitted_with_and_without(sketch, 5)
    valley, ridge = graph_mask(strokes.valleys), graph_mask(strokes.ridges)
    assert pct(drawn, valley) < pct(plain, valley) - 0.1
    assert pct(drawn, valley) < 0.3
    assert pct(drawn, ridge) > pct(plain, ridge) + 0.1


def test_fitted_to_examples_keeps_a_drawn_ridge_high_and_a_valley_low_along_their_whole_length():
    # A coarse terrain with a deep valley running down its left half and a
    # high belt down its right; a ridge drawn across the map (row 40)
    # crosses the deep valley, a valley drawn across it to the border (row
    # 90) the high belt.  Each stays on its side of the level's quantiles
    # along its whole length, not only on average; away from the strokes
    # the terrain keeps its valley and belt.  A valley walled in by a ring
    # of ridges (row 112) is not lowered so: that would make a basin with
    # no way out.
    example = builtin_example("white-mountains").load()
    session = Session([example], None, shape=(256, 256), params=P)
    sigma, f = split_sigma(P.patch_size), 2
    cols = np.arange(128)
    profile = np.where(cols < 64, -300.0 * np.exp(-0.5 * ((cols - 32) / 8.0) ** 2),
                       300.0 * np.exp(-0.5 * ((cols - 96) / 8.0) ** 2))
    terrain = np.tile(500.0 + profile, (128, 1)).astype(np.float32)
    ridge, valley = np.zeros((128, 128), bool), np.zeros((128, 128), bool)
    ridge[40, 8:120] = True
    valley[90, :] = True
    valley[112, 74:118] = True
    ridge[104, 66:126] = ridge[120, 66:126] = True
    ridge[104:121, 66] = ridge[104:121, 125] = True
    strokes = sketch_features(SketchMap(ridge, valley))
    drawn = fitted_to_examples(terrain, session.layout, f, sigma, strokes).astype(np.float64)
    level = landform_lowpass(drawn, sigma / f)
    lo, hi = np.quantile(level, [1 - STROKE_SIDE[0], STROKE_SIDE[0]])
    # (Within a tenth of the relief: the lift is averaged along the stroke.)
    slack = 0.1 * float(np.ptp(level))
    assert level[40, 8:120].min() > hi - slack
    assert level[90, 2:126].max() < lo + slack
    assert level[112, 74:118].max() > lo + slack
    # Where the ridge crosses the deep valley it was lifted out of the
    # lowest tenth to a saddle (the lift is averaged along the stroke);
    # the valley far from the strokes stays in the lowest quarter.
    assert level[40, 32] > np.quantile(level, 0.35)
    assert level[10, 32] < np.quantile(level, 0.25)


def test_open_valleys_are_those_not_walled_in_by_ridges():
    ridges = np.zeros((60, 60), bool)
    ridges[10, 10:40] = ridges[39, 10:40] = True
    ridges[10:40, 10] = ridges[10:40, 39] = True
    inside, outside, leaving = (np.zeros((60, 60), bool) for _ in range(3))
    inside[25, 15:35] = True
    outside[50, 5:55] = True
    leaving[20, 20:60] = True  # from inside the ring out through it to the border
    valleys = inside | outside | leaving
    kept = _open_valleys(valleys, ridges)
    assert not (kept & inside).any()
    assert (kept == (outside | leaving)).all()
    # A ridge drawn with diagonal steps leaves no gap for a valley inside.
    diagonal = np.zeros((60, 60), bool)
    for i in range(20):
        diagonal[30 - i, 10 + i] = diagonal[30 + i, 10 + i] = True
        diagonal[10 + i, 30 + i] = diagonal[50 - i, 30 + i] = True
    middle = np.zeros((60, 60), bool)
    middle[30, 25:36] = True
    assert not _open_valleys(middle, diagonal).any()


def test_coarse_factor_is_the_largest_the_examples_allow():
    assert coarse_factor(80, 1200) == FACTORS[0]
    # 32-cell patches: coarse patches are at least 24 cells, so 120 cells
    # hold 1.5 of them at 3x but not at 4x.
    f = coarse_factor(32, 120)
    assert f == 3 and 120 // f >= 1.5 * coarse_patch(32, f)
    assert coarse_factor(32, 90) is None
    assert coarse_factor(80, 239) is None


def test_the_pass_makes_the_level_and_detail_above_it(white_mountains, y_sketch):
    session = Session([white_mountains], y_sketch, params=P)
    landform, note = landform_pass(session)
    assert note is None and landform is not None
    assert landform.level.shape == (256, 256)
    assert landform.sigma == split_sigma(32)
    assert landform.coarse.heights.shape == tuple(-(-n // landform.factor) for n in (256, 256))
    # The coarse run follows the sketch too: it placed feature patches.
    assert landform.coarse.counts()["branch"] >= 1
    # The level field is smooth (nothing shorter than the split) and stays
    # in the example's heights.
    ex = white_mountains.heights
    assert ex.min() - 1 <= landform.level.min() and landform.level.max() <= ex.max() + 1
    assert np.abs(np.diff(landform.level, 2, axis=0)).max() < 0.05 * float(np.ptp(ex))


def test_a_run_puts_its_detail_on_the_landform(white_mountains, y_sketch):
    on = Session([white_mountains], y_sketch, params=P).run()
    off = Session([white_mountains], y_sketch, params=SynthesisParams(patch_size=32, k=2, seed=1,
                                                                       landform=False)).run()
    assert "landform" in on.timings and "landform" not in off.timings
    assert not np.array_equal(on.heights, off.heights)
    # Same seed, same bytes.
    again = Session([white_mountains], y_sketch, params=P).run()
    assert np.array_equal(on.heights, again.heights)


def test_the_pass_fills_on_warm_worker_processes_with_the_same_bytes(white_mountains, y_sketch, monkeypatch):
    """A process that has run before finds its workers warm: the coarse
    pass fills its windows there too, and the level is the same bytes as a
    pass in this process alone (a fresh process's, whose workers are still
    starting, when its fill is short)."""
    from terrasynth_core.synthesis import landform, workers
    from terrasynth_core.synthesis.fill_workers import fill_window

    with monkeypatch.context() as m:
        m.setattr(landform, "running", lambda processes: False)
        alone = landform_pass(Session([white_mountains], y_sketch, params=replace(P, workers=2)))[0]
    workers.warm_up(2, P.patch_size)
    assert workers.wait_warm() and workers.running(2)
    sent = []
    kit_submit = workers.KitWorkers.submit
    monkeypatch.setattr(workers.KitWorkers, "submit", lambda self, task, *a: sent.append(task) or kit_submit(self, task, *a))
    coarse, _, _ = landform.coarse_session(Session([white_mountains], y_sketch, params=replace(P, workers=2)))
    assert coarse.params.workers == 2
    warm = landform_pass(Session([white_mountains], y_sketch, params=replace(P, workers=2)))[0]
    assert fill_window in sent
    np.testing.assert_array_equal(alone.level, warm.level)
    np.testing.assert_array_equal(alone.coarse.heights, warm.coarse.heights)
    # Workers that are not warm: this process alone, unless the coarse
    # fill is long enough to wait for them.
    monkeypatch.setattr(landform, "running", lambda processes: False)
    coarse, _, _ = landform.coarse_session(Session([white_mountains], y_sketch, params=replace(P, workers=2)))
    assert coarse.params.workers == 1
    monkeypatch.setattr(landform, "COARSE_PARALLEL_WINDOWS", 1)
    coarse, _, _ = landform.coarse_session(Session([white_mountains], y_sketch, params=replace(P, workers=2)))
    assert coarse.params.workers == 2


def test_too_small_or_one_landform_examples_skip_it_with_a_reason(helens, y_sketch):
    small = helens.with_heights(helens.heights[:60, :60].copy())
    session = Session([small], None, shape=(256, 256), params=P)
    landform, note = landform_pass(session)
    assert landform is None
    assert "landform pass skipped" in note and "an example is only 57 cells across" in note and "larger example" in note
    result = session.run()
    assert any("landform pass skipped" in w for w in result.warnings)


def test_a_coarse_session_it_cannot_make_is_named_at_its_own_scale(white_mountains, y_sketch, monkeypatch):
    # The coarse session's error speaks of coarse cells (its patch size,
    # its windows): the note says that they are, and how they map to the run's.
    from terrasynth_core.errors import ParamsError
    from terrasynth_core.synthesis import landform, session as session_module

    session = Session([white_mountains], y_sketch, params=P)

    def refused(self, *args, **kwargs):
        raise ParamsError("holed has no 24x24 window without nodata, which a patch of 20x20 needs")

    monkeypatch.setattr(session_module.Session, "__init__", refused)
    coarse, f, note = landform.coarse_session(session)
    assert coarse is None and f == 0
    pc = landform.coarse_patch(P.patch_size, landform.coarse_factor(P.patch_size, min(white_mountains.shape)))
    assert note.startswith("landform pass skipped: at its scale (the examples down-sampled ")
    assert f"a patch of {pc} coarse cells spanning " in note and note.endswith("a patch of 20x20 needs")


def test_without_the_pass_the_drawing_gives_the_landforms(helens, sketch_dir, monkeypatch):
    # An example too small for the pass: the level rises about the drawn
    # ridges and falls about the valley (smoothly, no step), fitted to the
    # example's heights; the patches give their detail above a wider split,
    # so the strokes stand above and below the rest, and the run says so.
    small = helens.with_heights(helens.heights[:90, :300].copy())
    sketch = read_sketch(sketch_dir / "s_valley_1000.png").resized((256, 256))
    session = Session([small], sketch, shape=(256, 256), params=P)
    assert landform_pass(session)[0] is None
    level = drawn_level(session)
    strokes = session.sketch_maps
    ridges, valleys = graph_mask(strokes.ridges), graph_mask(strokes.valleys)
    ridge, valley = level[ridges].mean(), level[valleys].mean()
    assert valley < float(np.median(level)) < ridge
    assert np.abs(np.diff(level, axis=0)).max() < 0.1 * (ridge - valley)  # strokes 45 cells apart
    lo, hi = np.nanpercentile(small.heights, [0.5, 99.5])
    assert lo - 0.1 * (hi - lo) < level.min() and level.max() < hi + 0.1 * (hi - lo)  # the example's heights
    asked, real = [], session.detail_above
    monkeypatch.setattr(session, "detail_above", lambda sigma: asked.append(sigma) or real(sigma))
    result = session.run()
    assert asked == [drawn_split(P.patch_size)] == [3 * split_sigma(P.patch_size)]  # the examples' detail split
    assert any("the regional relief follows the drawing alone" in w for w in result.warnings)
    rank = result.heights.argsort(axis=None).argsort().reshape(result.heights.shape) / result.heights.size
    assert rank[ridges].mean() >= 0.75 and rank[valleys].mean() <= 0.25
    # Nothing drawn, no landforms.
    assert drawn_level(Session([small], None, shape=(256, 256), params=P)) is None


def test_stamps_stand_on_a_flat_level(white_mountains, helens):
    from terrasynth_core.synthesis import Controls, Stamp

    stamp = Stamp(helens, (128, 128), scale=0.4)
    session = Session([white_mountains], None, shape=(256, 256), params=P, controls=Controls(stamps=(stamp,)))
    landform, _ = landform_pass(session)
    st = session.layout.stamps[0]
    r0, r1, c0, c1 = st.bbox
    under = landform.level[r0:r1, c0:c1][st.core]
    assert np.ptp(under) < 1e-3
    # ... and the level eases back to the landform without a step, the
    # ramp no steeper than the landform's slopes away from the stamp (over
    # half a patch alone it was up to three times steeper: a moat or a wall).
    steps = np.abs(np.diff(landform.level, axis=0)).max(), np.abs(np.diff(landform.level, axis=1)).max()
    assert max(steps) < 0.05 * float(np.ptp(landform.level))
    core = np.zeros(landform.level.shape, bool)
    core[r0:r1, c0:c1] = st.core
    dist = ndimage.distance_transform_edt(~core)
    slope = np.hypot(*np.gradient(landform.level.astype(np.float64)))
    # (The landform's own slope adds to the ramp's: 1.1x here, 1.96x before.)
    assert slope[(dist > 0) & (dist <= P.patch_size)].max() <= 1.25 * slope[dist > 2 * P.patch_size].max()


def test_several_style_regions_keep_their_flat_levels(white_mountains, lowland, y_sketch):
    from terrasynth_core.synthesis import Controls, Style

    style_map = np.zeros((256, 256), np.int16)
    style_map[:, 128:] = 1
    controls = Controls(styles=(Style(white_mountains), Style(lowland)), style_map=style_map)
    session = Session([], y_sketch, params=P, controls=controls)
    landform, note = landform_pass(session)
    assert landform is None and "several style regions" in note


def test_the_pass_reports_its_patches_and_can_be_cancelled_during_it(white_mountains, y_sketch):
    from terrasynth_core.errors import SynthesisCancelled
    from terrasynth_core.synthesis import LandformProgress

    session = Session([white_mountains], y_sketch, params=P)
    seen = []
    with pytest.raises(SynthesisCancelled):
        session.run(progress=seen.append, cancel=lambda: len(seen) >= 4)
    assert [type(e).__name__ for e in seen] == ["StageStarted"] + ["LandformProgress"] * 3
    assert all(isinstance(e, LandformProgress) and 0 < e.done <= e.total for e in seen[1:])


def test_the_pass_previews_its_patches_on_the_output_grid(white_mountains, y_sketch):
    """Each coarse patch comes with its terrain stretched onto the output's
    cells, so a viewer paints landforms long before the first fine patch;
    the previews cover the output and hold the coarse run's heights."""
    from terrasynth_core.synthesis import LandformProgress

    session = Session([white_mountains], y_sketch, params=P)
    covered = np.zeros(session.shape, bool)
    previews = []
    for event in session.iter_run():
        if isinstance(event, LandformProgress):
            r0, r1, c0, c1 = event.bbox
            assert 0 <= r0 < r1 <= 256 and 0 <= c0 < c1 <= 256
            assert event.heights.shape == (r1 - r0, c1 - c0) and event.heights.dtype == np.float32
            covered[r0:r1, c0:c1] = True
            previews.append(event.heights)
        elif type(event).__name__ == "PatchPlaced":
            break
    assert covered.all()
    lo, hi = float(white_mountains.heights.min()), float(white_mountains.heights.max())
    values = np.concatenate([p.ravel() for p in previews])
    assert np.isfinite(values).all() and lo - 0.2 * (hi - lo) < np.median(values) < hi


@pytest.mark.parametrize("coarse_shape, shape, bbox", [((64, 50), (256, 200), (3, 27, 0, 50)),
                                                      ((37, 41), (100, 130), (36, 37, 5, 6)),
                                                      ((1, 9), (3, 40), (0, 1, 2, 9))])
def test_a_preview_is_the_patch_stretched_bilinearly(coarse_shape, shape, bbox):
    """The preview's separable interpolation gives map_coordinates' bilinear
    values, edges clamped, on odd scales and one-cell patches too."""
    r0, r1, c0, c1 = bbox
    heights = np.random.default_rng(1).normal(0, 100, (r1 - r0, c1 - c0)).astype(np.float32)
    out, preview = preview_patch(bbox, heights, coarse_shape, shape)
    sr, sc = shape[0] / coarse_shape[0], shape[1] / coarse_shape[1]
    rr, cc = np.meshgrid((np.arange(out[0], out[1]) + 0.5) / sr - 0.5 - r0,
                         (np.arange(out[2], out[3]) + 0.5) / sc - 0.5 - c0, indexing="ij")
    expected = ndimage.map_coordinates(heights, [rr, cc], order=1, mode="nearest")
    assert preview.shape == expected.shape and preview.dtype == np.float32
    np.testing.assert_allclose(preview, expected, atol=1e-3)
