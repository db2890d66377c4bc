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
