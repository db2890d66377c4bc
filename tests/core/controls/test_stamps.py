"""Stamps: rendered rotated and scaled, placed first and kept."""

from __future__ import annotations

import numpy as np

from terrasynth_core.controls.stamps import render_stamp
from terrasynth_core.synthesis import Controls, Session, Stamp, SynthesisParams


P = SynthesisParams(patch_size=32, k=2, seed=5)
SHAPE = (160, 240)


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


def test_a_basin_clip_stamps_the_basin():
    """A stamp whose DEM is a basin clip (the Himalaya's: its largest valid
    rectangle holds half the basin) is the whole basin, its surroundings
    left to the terrain, as the app's outline of the DEM's shape shows."""
    from terrasynth_core.examples import builtin_example

    basin = builtin_example("himalaya").load()
    assert basin.nodata_count > 0
    r = render_stamp(Stamp(basin, (400, 400), scale=1.0), (800, 800), 48)
    rows, cols = r.bbox[1] - r.bbox[0], r.bbox[3] - r.bbox[2]
    assert abs(rows - basin.shape[0]) <= 3 and abs(cols - basin.shape[1]) <= 3
    share = r.valid.mean()
    assert abs(share - (~basin.nodata).mean()) < 0.02  # the basin's share of its grid, not the rectangle
    assert np.isfinite(r.detail).all() and (r.detail[~r.valid] == 0).all()
