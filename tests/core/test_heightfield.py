"""The largest valid rectangle: where an example with nodata is cropped."""

import numpy as np

from terrasynth_core.heightfield import largest_valid_rectangle


def test_largest_valid_rectangle_is_the_largest_all_valid_one():
    rng = np.random.default_rng(4)
    for _ in range(30):
        valid = rng.random((7, 9)) < 0.75
        if not valid.any():
            continue
        r0, r1, c0, c1 = largest_valid_rectangle(valid)
        assert valid[r0:r1, c0:c1].all()
        best = max((b - a) * (d - c) for a in range(7) for b in range(a + 1, 8) for c in range(9)
                   for d in range(c + 1, 10) if valid[a:b, c:d].all())
        assert (r1 - r0) * (c1 - c0) == best
    # A grid without nodata is its own rectangle (at once: no scan).
    assert largest_valid_rectangle(np.ones((1201, 1201), bool)) == (0, 1201, 0, 1201)


def test_ties_go_to_the_first_row_then_the_leftmost_end_then_the_tallest():
    """Of equal areas, the rectangle the histogram-stack scan this replaced
    found first (so an example with nodata keeps its crop)."""
    valid = np.array([[1, 1, 0, 1, 1],
                      [1, 1, 0, 1, 1],
                      [0, 0, 0, 0, 0],
                      [1, 1, 1, 1, 0]], bool)
    assert largest_valid_rectangle(valid) == (0, 2, 0, 2)
    valid = np.array([[0, 1, 0],
                      [1, 1, 1],
                      [0, 1, 0]], bool)
    assert largest_valid_rectangle(valid) == (1, 2, 0, 3)  # complete at row 1, the column only at row 2


def _field(valid):
    from terrasynth_core.heightfield import HeightField

    h = np.where(valid, np.add.outer(np.arange(valid.shape[0]), np.arange(valid.shape[1])), np.nan)
    return HeightField(h.astype(np.float32))


def test_trim_nodata_crops_a_ragged_edge_to_the_largest_rectangle():
    """A ragged margin (the crop keeps >= 90 % of the valid cells) is cropped away."""
    valid = np.ones((100, 80), bool)
    valid[:3, :40] = False  # a ragged corner: 120 of 8000 cells
    valid[-1, 50:] = False
    field = _field(valid).trim_nodata()
    assert field.nodata_count == 0
    assert field.shape == (96, 80)  # rows 3..98: the rectangle spans the width


def test_trim_nodata_keeps_a_basin_clip_whole_with_its_voids():
    """A basin clip (the largest rectangle holds half the valid cells) keeps
    its bounding box, the nodata inside still NaN; the all-nodata margin goes."""
    rows, cols = np.mgrid[:120, :100]
    valid = (rows - 60) ** 2 / 50**2 + (cols - 45) ** 2 / 40**2 <= 1  # an ellipse
    field = _field(valid).trim_nodata()
    assert field.shape == (101, 81)
    assert 0 < field.nodata_count < field.heights.size / 3
    assert (~field.nodata).sum() == valid.sum()  # no valid cell lost


def test_trim_nodata_keeps_a_void_inside_a_tile():
    valid = np.ones((200, 200), bool)
    valid[95:105, :] = False  # a void stripe across the tile: a crop would keep half
    field = _field(valid).trim_nodata()
    assert field.shape == (200, 200) and field.nodata_count == 2000
    whole = _field(np.ones((5, 5), bool))
    assert whole.trim_nodata() is whole
