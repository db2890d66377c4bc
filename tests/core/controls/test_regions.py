"""Style regions on real DEMs: each takes its own example and level, they
meet without a cliff; relief scale, height range and local re-synthesis."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.synthesis import Controls, Pin, Session, Style, SynthesisParams, Water


P = SynthesisParams(patch_size=32, k=2, seed=5)
SHAPE = (160, 240)


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


def test_relief_scale_and_height_range(lowland):
    flat = Session([], None, shape=SHAPE, params=P,
                   controls=Controls(styles=(Style(lowland, relief_scale=0.25),))).run().heights
    full = Session([], None, shape=SHAPE, params=P, controls=Controls(styles=(Style(lowland),))).run().heights
    assert np.std(flat) < 0.5 * np.std(full)
    ranged = Session([lowland], None, shape=SHAPE, params=P,
                     controls=Controls(height_range=(-100.0, 900.0))).run().heights
    assert ranged.min() == pytest.approx(-100.0, abs=0.01) and ranged.max() == pytest.approx(900.0, abs=0.01)


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


def test_height_range_holds_after_the_drainage(lowland, sketch_dir):
    """The drainage cuts floors and breaches rims after the range is
    applied; the result is still exactly on the range."""
    from terrasynth_core.features import read_sketch

    sketch = read_sketch(sketch_dir / "ring_cross_512.png").resized(SHAPE)
    ranged = Session([lowland], sketch, shape=SHAPE, params=P,
                     controls=Controls(height_range=(0.0, 500.0))).run().heights
    assert ranged.min() == pytest.approx(0.0, abs=0.01) and ranged.max() == pytest.approx(500.0, abs=0.01)
