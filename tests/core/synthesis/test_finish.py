"""The finished heights stay in the examples' range: a soft knee eases
what patches stacked past it back inside, leaving the rest alone."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.examples import builtin_example
from terrasynth_core.features import read_sketch
from terrasynth_core.synthesis import Controls, Pin, Session, SynthesisParams
from terrasynth_core.synthesis.finish import RANGE_KNEE, within_examples_range


def test_the_knee_eases_heights_into_the_range_and_keeps_their_order():
    h = np.linspace(-300.0, 1300.0, 16001).astype(np.float32)
    eased = within_examples_range(h, 0.0, 1000.0)
    assert eased.min() >= 0.0 and eased.max() <= 1000.0
    # Strictly increasing up to three knees out (float32 cannot tell the
    # heights apart much further out): no new pit or peak.
    near = (h > -90.0) & (h < 1090.0)
    assert np.all(np.diff(eased[near].astype(np.float64)) > 0)
    knee = RANGE_KNEE * 1000.0
    inside = (h >= knee) & (h <= 1000.0 - knee)
    assert np.array_equal(eased[inside], h[inside])
    # Slope 1 where the knee starts: no crease along that contour.
    slope = np.diff(eased.astype(np.float64)) / np.diff(h.astype(np.float64))
    start = np.searchsorted(h, 1000.0 - knee)
    assert slope[start - 2:start + 2] == pytest.approx(1.0, abs=1e-2)
    # Heights that fit are returned as they are.
    fits = np.full((4, 4), 500.0, np.float32)
    assert within_examples_range(fits, 0.0, 1000.0) is fits


def test_a_run_stays_within_its_example_but_a_pin_may_ask_for_more(sketch_dir):
    field = builtin_example("white-mountains").load()
    crop = field.with_heights(field.heights[300:556, 300:556].copy())
    sketch = read_sketch(sketch_dir / "s_valley_1000.png").resized((160, 160))
    params = SynthesisParams(patch_size=32, k=2, seed=2)
    session = Session([crop], sketch, params=params)
    lo, hi = session.layout.height_range()
    heights = session.run().heights
    assert heights.min() >= lo and heights.max() <= hi
    high = hi + 300.0
    pinned = Session([crop], sketch, params=params, controls=Controls(pins=(Pin(80, 80, high),))).run().heights
    assert pinned[80, 80] == pytest.approx(high, abs=0.5)
