"""Feature pools kept between sessions (terrasynth_core/synthesis/feature_patches.py)."""

from __future__ import annotations

import numpy as np

from terrasynth_core.features.sketch import read_sketch
from terrasynth_core.synthesis import Session, SynthesisParams
from terrasynth_core.memo import Memo
from terrasynth_core.synthesis import feature_patches

P = SynthesisParams(patch_size=32, k=2, seed=3, landform=False)


def test_feature_pools_are_kept_for_the_same_examples_and_made_again_for_others(white_mountains, sketch_dir,
                                                                             monkeypatch):
    """A new session (a new run, a live stroke) reuses the pools an earlier
    one made from the same examples, with the same result; a changed
    example, patch size or mirror option gets its own."""
    made = []
    make = feature_patches.feature_pools

    def counted(layout, radius, *, mirror):
        made.append((radius, mirror))
        return make(layout, radius, mirror=mirror)

    monkeypatch.setattr(feature_patches, "feature_pools", counted)
    monkeypatch.setattr(feature_patches, "_POOLS", Memo(4))
    sketch = read_sketch(sketch_dir / "y_junction_512.png").resized((160, 160))
    first = Session([white_mountains], sketch, params=P).run()
    assert len(made) == 1
    again = Session([white_mountains], sketch, params=P).run()  # a new session, the same inputs
    assert len(made) == 1
    np.testing.assert_array_equal(first.heights, again.heights)
    # Made afresh (the memo emptied), the pools give the same terrain.
    monkeypatch.setattr(feature_patches, "_POOLS", Memo(4))
    np.testing.assert_array_equal(Session([white_mountains], sketch, params=P).run().heights, first.heights)
    assert len(made) == 2
    # Other inputs, other pools: a steeper example, another radius, no mirrors.
    steeper = white_mountains.with_heights(white_mountains.heights * np.float32(2))
    layout = Session([white_mountains], sketch, params=P).layout
    pools = feature_patches.memo_feature_pools(layout, 16.0, mirror=True)
    assert len(made) == 2 and feature_patches.memo_feature_pools(layout, 16.0, mirror=True) is pools
    feature_patches.memo_feature_pools(Session([steeper], sketch, params=P).layout, 16.0, mirror=True)
    feature_patches.memo_feature_pools(layout, 20.0, mirror=True)
    feature_patches.memo_feature_pools(layout, 16.0, mirror=False)
    assert made[2:] == [(16.0, True), (20.0, True), (16.0, False)]
