"""Style layout: which examples serve which cells, at what level and scale."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.controls.layout import build_layout
from terrasynth_core.controls.options import Controls, Style

SHAPE = (96, 128)
PATCH = 32


def _terrain(seed: int, lo: float, hi: float) -> np.ndarray:
    """Smooth random heights spanning exactly [lo, hi] metres."""
    g = ndimage.gaussian_filter(np.random.default_rng(seed).normal(size=(120, 120)), 5)
    return (lo + (g - g.min()) / (g.max() - g.min()) * (hi - lo)).astype(np.float32)


def _layout(plain, controls: Controls):
    return build_layout(plain, controls.checked(SHAPE, len(plain)), SHAPE, PATCH)


def test_groups_are_the_plain_examples_then_one_per_style():
    labels = np.full(SHAPE, -1, np.int16)
    labels[:, 40:80] = 0
    labels[:, 80:] = 1
    styles = (Style(_terrain(1, 0, 300), name="low"), Style(_terrain(2, 1000, 2500)))
    lay = _layout([_terrain(3, 200, 400)], Controls(styles=styles, style_map=labels))
    assert lay.members == [[0], [1], [2]]
    assert lay.names == ["default examples", "low", "style 2"]
    np.testing.assert_array_equal(lay.group_map, labels + 1)
    assert lay.group_at(10, 10) == 0 and lay.group_at(10, 50) == 1 and lay.group_at(500, 500) == 2
    # Without plain examples the styles' groups start at 0.
    alone = _layout([], Controls(styles=styles, style_map=np.where(labels < 0, 0, labels).astype(np.int16)))
    assert alone.members == [[0], [1]] and alone.group_map.max() == 1


def test_detail_is_about_the_median_and_the_level_carries_each_base():
    low, high = _terrain(1, 0, 300), _terrain(2, 1000, 2500)
    labels = np.zeros(SHAPE, np.int16)
    labels[:, 64:] = 1
    lay = _layout([], Controls(styles=(Style(low, relief_scale=2.0), Style(high, base=5000.0)), style_map=labels))
    np.testing.assert_allclose(lay.detail[0], (low - np.median(low)) * 2.0, atol=1e-3)
    np.testing.assert_allclose(lay.detail[1], high - np.median(high), atol=1e-3)
    assert lay.relief[0] == pytest.approx(2.0 * lay.examples[0].relief)
    assert lay.level[48, 0] == pytest.approx(float(np.median(low)), abs=0.5)
    assert lay.level[48, -1] == pytest.approx(5000.0, abs=0.5)
    assert lay.remap is None


def test_height_range_scales_the_styles_towards_it():
    field = _terrain(4, 0.0, 1000.0)
    lay = _layout([field], Controls(height_range=(100.0, 600.0)))
    lo, hi, factor, shift = lay.remap
    # The example's predicted heights span 0..1000 m; the range is half of that.
    assert (lo, hi) == (100.0, 600.0)
    assert factor == pytest.approx(0.5) and shift == pytest.approx(100.0)
    np.testing.assert_allclose(lay.detail[0], (field - np.median(field)) * 0.5, atol=1e-3)
    np.testing.assert_allclose(lay.level, 0.5 * np.median(field) + 100.0, atol=1e-3)
    assert lay.relief[0] == pytest.approx(0.5 * lay.examples[0].relief)


def test_anchors_keep_each_detail_level_spread_by_its_bytes(monkeypatch):
    """A new session's layout reuses the level spread of an example detail
    it has seen (the same weights), and measures a changed one again."""
    from terrasynth_core.controls import layout as layout_module
    from terrasynth_core.matching.costs import anchor_weight, level_spread
    from terrasynth_core.memo import Memo

    measured = []

    def counted(detail, patch_size, valid=None):
        measured.append(patch_size)
        return level_spread(detail, patch_size, valid)

    monkeypatch.setattr(layout_module, "_SPREADS", Memo(16))
    monkeypatch.setattr(layout_module, "level_spread", counted)
    rng = np.random.default_rng(5)
    detail = [rng.normal(scale=20.0, size=(90, 80)).astype(np.float32),
              np.add.outer(np.arange(70.0), np.arange(60.0)).astype(np.float32)]
    relief = np.array([150.0, 90.0])
    expected = np.array([anchor_weight(r, level_spread(d, 32)) for d, r in zip(detail, relief)])
    first = layout_module.anchors(detail, relief, 32)
    np.testing.assert_array_equal(first, expected)
    again = layout_module.anchors([d.copy() for d in detail], relief, 32)  # equal bytes, new arrays
    np.testing.assert_array_equal(again, first)
    assert measured == [32, 32]
    changed = [detail[0] * np.float32(2), detail[1]]
    layout_module.anchors(changed, relief, 32)
    layout_module.anchors(detail, relief, 40)
    assert measured == [32, 32, 32, 40, 40]


def test_the_detail_is_made_once_and_kept_in_the_cache(monkeypatch, tmp_path):
    import terrasynth_core.controls.layout as layout_module
    from terrasynth_core.memo import Memo

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(layout_module, "_DETAILS", Memo(8))
    heights = _terrain(4, 100, 900)
    first = _layout([heights], Controls())
    again = _layout([heights], Controls())
    d = first.detail[0]
    expected = ((first.examples[0].heights - np.float32(np.median(first.examples[0].heights))) * np.float32(1.0))
    assert d.dtype == np.float32 and np.array_equal(d, expected.astype(np.float32))
    assert not d.flags.writeable
    assert again.detail[0] is d  # the next session's, not made again
    # Stored: a process that has not made it reads the same bytes back.
    monkeypatch.setattr(layout_module, "_DETAILS", Memo(8))
    fresh = _layout([heights], Controls()).detail[0]
    assert fresh is not d and np.array_equal(fresh, d)
    assert any("layout-detail" in p.name for p in tmp_path.iterdir())
