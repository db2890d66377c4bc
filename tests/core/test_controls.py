"""Artist controls: style regions, stamps, water, elevation pins, height
range, local re-synthesis and variations, on real DEMs."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from terrasynth_core.errors import ParamsError, SketchError
from terrasynth_core.features.labels import read_label_map, read_mask
from terrasynth_core.features.sketch import SketchMap
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem
from terrasynth_core.controls.pins import Pin, apply_pins
from terrasynth_core.synthesis import Controls, Session, Stamp, Style, SynthesisParams, Water, run_variations
from terrasynth_core.controls.stamps import render_stamp
from terrasynth_core.controls.water import apply_water

P = SynthesisParams(patch_size=32, k=2, seed=5)
SHAPE = (160, 240)


@pytest.fixture(scope="module")
def lowland(dems_dir) -> HeightField:
    """Gabon plateau, 300x300: gentle, a few hundred metres up."""
    f = load_dem(dems_dir / "N00E010.hgt")
    return f.with_heights(f.heights[400:700, 400:700].copy())


@pytest.fixture(scope="module")
def highland(dems_dir) -> HeightField:
    """Himalaya (Mandakini), its valid core: rugged, thousands of metres up."""
    return load_dem(dems_dir / "Mandakini.bil").crop_valid()


@pytest.fixture(scope="module")
def helens(dems_dir) -> HeightField:
    return load_dem(dems_dir / "SainteHelens.dem")


def _halves() -> np.ndarray:
    labels = np.zeros(SHAPE, np.int16)
    labels[:, SHAPE[1] // 2:] = 1
    return labels


@pytest.fixture(scope="module")
def two_styles(lowland, highland):
    controls = Controls(styles=(Style(lowland, name="low"), Style(highland, name="high")), style_map=_halves())
    session = Session([], None, shape=SHAPE, params=P, controls=controls)
    return session, session.run()


def _slope(h: np.ndarray) -> np.ndarray:
    gy, gx = np.gradient(h.astype(np.float64))
    return np.hypot(gy, gx)


def test_each_region_takes_patches_from_its_own_example(two_styles):
    session, result = two_styles
    labels = session.controls.style_map
    for rec in result.patches:
        r0, r1, c0, c1 = rec.bbox
        inside = np.unique(labels[r0:r1, c0:c1])
        if inside.size == 1:
            assert rec.example == int(inside[0])
    assert result.style_map is not None and (result.style_map == labels).all()


def test_regions_keep_their_own_levels_and_meet_without_a_cliff(two_styles, lowland, highland):
    _, result = two_styles
    h = result.heights
    low, high = h[:, :60], h[:, -60:]
    # Each side sits at its own style's level: the two medians differ by
    # most of the difference between the examples' medians.
    wanted = float(np.median(highland.heights) - np.median(lowland.heights))
    assert float(np.median(high) - np.median(low)) > 0.5 * wanted
    assert np.median(low) < np.median(lowland.heights) + 0.5 * np.ptp(lowland.heights)
    slope = _slope(h)
    border = slope[:, 120 - 8:120 + 8]
    # The steepest cells at the border are no steeper than the rugged
    # style's own steepest cells: levels meet on a slope, not a cliff.
    assert np.percentile(border, 99.5) <= 1.1 * np.percentile(_slope(highland.heights), 99.9)


def test_style_map_errors_name_the_problem(lowland):
    bad = np.full(SHAPE, 3, np.int16)
    with pytest.raises(ParamsError, match="label 3"):
        Session([], None, shape=SHAPE, params=P, controls=Controls(styles=(Style(lowland),), style_map=bad))
    with pytest.raises(ParamsError, match="no style and no default example"):
        Session([], None, shape=SHAPE, params=P,
                controls=Controls(styles=(Style(lowland),), style_map=np.full(SHAPE, -1, np.int16)))
    with pytest.raises(ParamsError, match="aspect ratio"):
        Session([], None, shape=SHAPE, params=P,
                controls=Controls(styles=(Style(lowland),), style_map=np.zeros((100, 100), np.int16)))
    with pytest.raises(ParamsError, match="relief scale"):
        Session([], None, shape=SHAPE, params=P, controls=Controls(styles=(Style(lowland, relief_scale=0),)))


def test_relief_scale_and_height_range(lowland):
    flat = Session([], None, shape=SHAPE, params=P,
                   controls=Controls(styles=(Style(lowland, relief_scale=0.25),))).run().heights
    full = Session([], None, shape=SHAPE, params=P, controls=Controls(styles=(Style(lowland),))).run().heights
    assert np.std(flat) < 0.5 * np.std(full)
    ranged = Session([lowland], None, shape=SHAPE, params=P,
                     controls=Controls(height_range=(-100.0, 900.0))).run().heights
    assert ranged.min() == pytest.approx(-100.0, abs=0.01) and ranged.max() == pytest.approx(900.0, abs=0.01)


def test_stamp_is_placed_rotated_and_kept(lowland, helens):
    stamp = Stamp(helens, (80, 120), rotation=0.0, scale=0.5)
    rendered = render_stamp(stamp, SHAPE, 32)
    result = Session([lowland], None, shape=SHAPE, params=P, controls=Controls(stamps=(stamp,))).run()
    r0, r1, c0, c1 = rendered.bbox
    core = rendered.core
    placed = result.heights[r0:r1, c0:c1][core]
    # The core keeps the stamp's shape exactly (up to the constant level).
    assert np.corrcoef(placed, rendered.detail[core])[0, 1] > 0.999
    assert result.counts()["stamp"] == 1


def test_stamp_rotation_turns_counter_clockwise(helens):
    square = (100, 260, 80, 240)
    plain = render_stamp(Stamp(helens, (80, 120), window=square), (400, 400), 32)
    quarter = render_stamp(Stamp(helens, (80, 120), rotation=90.0, window=square), (400, 400), 32)
    assert plain.detail.shape == quarter.detail.shape
    # Counter-clockwise on screen: the stamp's top row becomes its left column.
    both = np.rot90(plain.valid) & quarter.valid
    assert both.sum() > 0.9 * plain.valid.sum()
    assert np.allclose(np.rot90(plain.detail)[both], quarter.detail[both], atol=1e-3)
    half = render_stamp(Stamp(helens, (80, 120), scale=0.5, window=square), (400, 400), 32)
    assert abs(half.valid.sum() - plain.valid.sum() / 4) < 0.1 * plain.valid.sum() / 4


def test_stamp_outside_the_output_is_refused(lowland, helens):
    with pytest.raises(ParamsError, match="outside"):
        Session([lowland], None, shape=SHAPE, params=P, controls=Controls(stamps=(Stamp(helens, (500, 20)),)))


def test_pins_are_met_and_stay_local():
    rng = np.random.default_rng(0)
    h = ndimage.gaussian_filter(rng.normal(size=(200, 200)), 3).astype(np.float32) * 100
    pins = [Pin(100, 100, 500.0), Pin(110, 120, -50.0)]
    out, errors = apply_pins(h, pins, radius=40)
    assert max(abs(e.error) for e in errors) < 1e-3
    far = np.hypot(*np.mgrid[:200, :200] - np.array([105, 110])[:, None, None]) > 70
    assert (out[far] == h[far]).all()
    # Smooth: the correction's steepest step is far below the pin's height change.
    d = out.astype(np.float64) - h
    assert np.abs(np.diff(d, axis=0)).max() < 0.1 * 550


def test_pins_in_a_run_are_under_a_percent_of_the_range(lowland):
    pins = (Pin(40, 60, 900.0), Pin(120, 200, 50.0))
    result = Session([lowland], None, shape=SHAPE, params=P, controls=Controls(pins=pins)).run()
    span = float(np.ptp(result.heights))
    assert len(result.pin_errors) == 2
    for e in result.pin_errors:
        assert abs(e.error) < 0.01 * span
        assert result.heights[e.row, e.col] == pytest.approx(e.target, abs=1e-3)
    with pytest.raises(ParamsError, match="outside"):
        Session([lowland], None, shape=SHAPE, params=P, controls=Controls(pins=(Pin(400, 0, 1.0),)))


def test_water_is_below_the_level_and_the_banks_are_smooth(lowland):
    mask = np.zeros(SHAPE, bool)
    mask[:, :30] = True  # a sea
    mask[78:83, 30:200] = True  # a river
    level = float(np.median(lowland.heights))
    result = Session([lowland], None, shape=SHAPE, params=P, controls=Controls(water=Water(mask, level))).run()
    h = result.heights
    assert (h[mask] < level).all()
    shore = ndimage.binary_dilation(mask) & ~mask
    assert (h[shore] >= level).all()
    # No wall at the shore: the step across it is small against the relief.
    step = np.abs(np.diff(h, axis=1))[:, 28:32].max()
    assert step < 0.2 * np.ptp(lowland.heights)


def test_water_outside_a_lock_is_untouched():
    h = np.linspace(0, 100, 100 * 100, dtype=np.float32).reshape(100, 100)
    mask = np.zeros((100, 100), bool)
    mask[40:60, 40:60] = True
    locked = np.zeros((100, 100), bool)
    locked[:, :50] = True
    out = apply_water(h, Water(mask, 10.0), bank_width=8, locked=locked)
    assert (out[locked] == h[locked]).all() and not (out[~locked] == h[~locked]).all()


def test_local_resynthesis_changes_nothing_outside(two_styles, lowland, highland):
    session, first = two_styles
    selection = np.zeros(SHAPE, bool)
    selection[40:120, 90:170] = True
    mask = np.zeros(SHAPE, bool)
    mask[100:110, :] = True
    controls = Controls(styles=session.controls.styles, style_map=session.controls.style_map,
                        water=Water(mask, 500.0), pins=(Pin(80, 130, 3000.0),),
                        previous=first.heights, selection=selection)
    again = Session([], None, shape=SHAPE, params=SynthesisParams(patch_size=32, k=2, seed=99),
                    controls=controls).run()
    outside = ~selection
    assert np.array_equal(again.heights[outside], first.heights[outside])
    assert not np.array_equal(again.heights[selection], first.heights[selection])
    assert again.heights[80, 130] == pytest.approx(3000.0, abs=1e-3)
    assert (again.selection == selection).all()
    # The edge merges: the step across the selection border is like the steps inside.
    edge = ndimage.binary_dilation(selection) & ~ndimage.binary_erosion(selection)
    slope = _slope(again.heights)
    assert np.percentile(slope[edge], 99) < 2.0 * np.percentile(slope[selection], 99)


def test_resynthesis_needs_both_parts(lowland):
    with pytest.raises(ParamsError, match="both"):
        Session([lowland], None, shape=SHAPE, params=P, controls=Controls(selection=np.ones(SHAPE, bool)))
    with pytest.raises(ParamsError, match="empty"):
        Session([lowland], None, shape=SHAPE, params=P,
                controls=Controls(previous=np.zeros(SHAPE, np.float32), selection=np.zeros(SHAPE, bool)))


def test_variations_in_processes_match_single_runs(lowland):
    sketch = SketchMap(np.zeros(SHAPE, bool), np.zeros(SHAPE, bool))
    seen = []
    results = run_variations([lowland], sketch, seeds=[1, 2], params=P, workers=2,
                             progress=lambda i, r: seen.append(i))
    assert sorted(seen) == [0, 1]
    for seed, result in zip([1, 2], results):
        alone = Session([lowland], sketch, params=SynthesisParams(patch_size=32, k=2, seed=seed)).run()
        assert np.array_equal(result.heights, alone.heights)
    assert not np.array_equal(results[0].heights, results[1].heights)
    with pytest.raises(ParamsError, match="repeat"):
        run_variations([lowland], sketch, seeds=[1, 1], params=P)


def test_variations_over_examples(lowland, highland):
    results = run_variations([], None, seeds=[3, 3], shape=(96, 96), params=P, workers=1,
                             example_sets=[[lowland], [highland]])
    assert np.median(results[1].heights) - np.median(results[0].heights) > 1000
    with pytest.raises(ParamsError, match="one set per variation"):
        run_variations([], None, seeds=[1, 2], shape=(96, 96), params=P, example_sets=[[lowland]])


def test_label_and_water_pngs(tmp_path):
    rgb = np.zeros((20, 30, 3), np.uint8)
    rgb[:, :15] = (0, 128, 0)
    rgb[:, 15:] = (128, 64, 0)
    rgb[:, 15] = (64, 96, 0)  # an anti-aliased edge column
    Image.fromarray(rgb).save(tmp_path / "styles.png")
    labels = read_label_map(tmp_path / "styles.png", ["#008000", "#804000"])
    assert (labels[:, :15] == 0).all() and (labels[:, 16:] == 1).all()
    rgb[:10, :10] = (255, 0, 255)
    Image.fromarray(rgb).save(tmp_path / "extra.png")
    with pytest.raises(SketchError, match="#ff00ff"):
        read_label_map(tmp_path / "extra.png", ["#008000", "#804000"])
    assert (read_label_map(tmp_path / "extra.png", ["#008000", "#804000"], default=True)[:10, :10] == -1).all()
    water = np.full((20, 30), 255, np.uint8)
    water[5:8] = 0
    Image.fromarray(water).save(tmp_path / "water.png")
    mask = read_mask(tmp_path / "water.png")
    assert mask[5:8].all() and mask.sum() == 3 * 30
    with pytest.raises(SketchError, match="does not exist"):
        read_mask(tmp_path / "nope.png")
