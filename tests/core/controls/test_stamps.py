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
