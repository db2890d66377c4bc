"""The sketch layers without Qt: brushes, strokes, undo and redo."""

import numpy as np
import pytest

from terrasynth_core.features import SketchMap
from terrasynth_app.model import Sketch, capsule_coverage

# -- brushes ------------------------------------------------------------------------------
def test_hard_brush_covers_a_disc_and_clips_to_the_grid():
    bbox, cov = capsule_coverage((20, 20), (1.0, 1.0), (1.0, 1.0), 3.0, 1.0)
    r0, r1, c0, c1 = bbox
    assert (r0, c0) == (0, 0) and cov.shape == (r1 - r0, c1 - c0)
    assert cov[1, 1] == 255  # the centre
    assert cov[1, 3] == 255  # 2 cells away, inside the radius
    assert cov[1, 4] == 128  # on the rim: half intensity, the stroke threshold
    assert cov[1, 5] == 0
    rr, cc = np.nonzero(cov >= 128)
    assert np.hypot(rr + r0 - 1, cc + c0 - 1).max() <= 3.0


def test_soft_brush_fades_towards_its_rim():
    _, hard = capsule_coverage((40, 40), (20.0, 20.0), (20.0, 20.0), 8.0, 1.0)
    _, soft = capsule_coverage((40, 40), (20.0, 20.0), (20.0, 20.0), 8.0, 0.0)
    assert (soft == 255).sum() < (hard == 255).sum()
    # Half intensity at the radius for any hardness: the same stroked cells.
    pad = (soft.shape[0] - hard.shape[0]) // 2
    np.testing.assert_array_equal(soft[pad:-pad, pad:-pad] >= 128, hard >= 128)
    row = soft[soft.shape[0] // 2]
    centre = len(row) // 2
    assert np.all(np.diff(row[centre:].astype(int)) <= 0)  # monotone fall-off


def test_segment_coverage_is_a_capsule():
    bbox, cov = capsule_coverage((50, 50), (10.0, 5.0), (10.0, 40.0), 2.0, 1.0)
    r0, r1, c0, c1 = bbox
    assert (r0, r1, c0, c1) == (7, 14, 2, 44)
    assert cov[10 - r0, 5 - c0:41 - c0].min() == 255  # the whole segment is painted
    assert cov[12 - r0, 5 - c0:41 - c0].max() == 128  # half intensity a radius off the line
    assert cov[13 - r0].max() == 0


def test_brush_outside_the_grid_paints_nothing():
    bbox, cov = capsule_coverage((10, 10), (-20.0, -20.0), (-15.0, -15.0), 2.0, 1.0)
    assert bbox is None and cov.size == 0


# -- sketch and undo -------------------------------------------------------------------------
def test_one_stroke_is_one_undo_step():
    sketch = Sketch.blank((64, 64))
    events = []
    sketch.changed.connect(events.append)
    sketch.begin_stroke("ridge", 10, 10, radius=3, hardness=1.0)
    for c in range(11, 50, 3):
        sketch.stroke_to(10, c)
    sketch.end_stroke()
    painted = sketch.ridge.copy()
    assert painted[10, 10:50].min() == 255
    assert len(events) > 5 and all(bbox is not None for bbox in events)
    assert sketch.can_undo and not sketch.can_redo
    assert sketch.undo()
    assert not sketch.ridge.any()
    assert not sketch.can_undo and sketch.can_redo
    assert sketch.redo()
    np.testing.assert_array_equal(sketch.ridge, painted)


def test_a_new_stroke_drops_the_redo_steps():
    sketch = Sketch.blank((32, 32))
    sketch.draw_polyline([(5, 5), (5, 25)], "ridge", radius=2)
    sketch.draw_polyline([(20, 5), (20, 25)], "valley", radius=2)
    sketch.undo()
    sketch.draw_polyline([(28, 5), (28, 25)], "ridge", radius=2)
    assert not sketch.can_redo
    assert sketch.valley.max() == 0 and sketch.ridge[28, 15] == 255
    sketch.undo()
    sketch.undo()
    assert not sketch.ridge.any() and not sketch.can_undo


def test_painting_one_kind_over_the_other_replaces_it_and_the_eraser_clears_both():
    sketch = Sketch.blank((40, 40))
    sketch.draw_polyline([(20, 0), (20, 39)], "valley", radius=3, hardness=1.0)
    sketch.draw_polyline([(0, 20), (39, 20)], "ridge", radius=3, hardness=1.0)
    assert sketch.ridge[20, 20] == 255 and sketch.valley[20, 20] == 0
    assert sketch.valley[20, 5] == 255
    sketch.draw_polyline([(20, 0), (20, 39)], "erase", radius=5, hardness=1.0)
    assert sketch.valley.max() == 0 and sketch.ridge[20, 20] == 0 and sketch.ridge[5, 20] == 255
    assert sketch.history.can_undo
    sketch.undo()
    assert sketch.ridge[20, 20] == 255 and sketch.valley[20, 5] == 255


def test_a_stroke_that_changes_nothing_is_not_recorded():
    sketch = Sketch.blank((20, 20))
    sketch.draw_polyline([(5, 5), (5, 15)], "erase", radius=2)
    assert not sketch.can_undo


def test_sketch_map_thresholds_at_half_intensity_and_keeps_kinds_exclusive():
    ridge = np.zeros((8, 8), np.uint8)
    valley = np.zeros((8, 8), np.uint8)
    ridge[1, 1], ridge[2, 2] = 127, 128
    ridge[3, 3], valley[3, 3] = 200, 200  # a tie: the ridge wins
    valley[4, 4] = 255
    sm = Sketch(ridge, valley).to_sketch_map()
    assert isinstance(sm, SketchMap)
    assert np.argwhere(sm.ridge_mask).tolist() == [[2, 2], [3, 3]]
    assert np.argwhere(sm.valley_mask).tolist() == [[4, 4]]
    back = Sketch.from_sketch_map(sm)
    assert back.ridge[2, 2] == 255 and back.valley[4, 4] == 255 and back.ridge[1, 1] == 0


def test_replacing_with_another_shape_is_undoable():
    sketch = Sketch.blank((30, 40))
    sketch.draw_polyline([(5, 5), (5, 30)], "ridge")
    before = sketch.ridge.copy()
    shapes = []
    sketch.changed.connect(lambda bbox: shapes.append((bbox, sketch.shape)))
    sketch.replace(np.zeros((50, 20), np.uint8), np.zeros((50, 20), np.uint8))
    assert sketch.shape == (50, 20) and shapes[-1] == (None, (50, 20))
    sketch.undo()
    assert sketch.shape == (30, 40)
    np.testing.assert_array_equal(sketch.ridge, before)
    sketch.clear()
    assert not sketch.has_strokes
    sketch.undo()
    assert sketch.has_strokes


def test_rgb_is_white_red_and_blue_like_a_sketch_png():
    sketch = Sketch.blank((10, 10))
    sketch.draw_polyline([(2, 0), (2, 9)], "ridge", radius=0.5, hardness=1.0)
    sketch.draw_polyline([(7, 0), (7, 9)], "valley", radius=0.5, hardness=1.0)
    rgb = sketch.to_rgb()
    assert rgb.dtype == np.uint8 and rgb.shape == (10, 10, 3)
    assert rgb[2, 5].tolist() == [255, 0, 0]
    assert rgb[7, 5].tolist() == [0, 0, 255]
    assert rgb[0, 0].tolist() == [255, 255, 255]
    np.testing.assert_array_equal(sketch.to_rgb((1, 3, 2, 6)), rgb[1:3, 2:6])


def test_bad_layers_and_tools_are_rejected():
    with pytest.raises(ValueError, match="same shape"):
        Sketch(np.zeros((5, 5), np.uint8), np.zeros((5, 6), np.uint8))
    with pytest.raises(ValueError, match="tool"):
        Sketch.blank((5, 5)).begin_stroke("lava", 1, 1)


def test_history_drops_oldest_steps_beyond_its_memory_budget():
    sketch = Sketch.blank((100, 100))
    sketch.history._max_bytes = 3 * 4 * 100 * 100  # room for about three full-size steps
    for i in range(6):
        sketch.draw_polyline([(i * 10 + 5, 0), (i * 10 + 5, 99)], "ridge", radius=2)
        sketch.clear()
    undone = 0
    while sketch.undo():
        undone += 1
    assert 0 < undone < 12
    assert sketch.has_strokes or undone % 2 == 0
