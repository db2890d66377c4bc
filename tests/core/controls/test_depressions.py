"""Closed depressions breached (terrasynth_core.controls.depressions).

Depressions are found here with a flood of our own (a Priority-Flood fill in
plain Python, not the module's morphological reconstruction), so the module
is checked against an independent answer.
"""

from __future__ import annotations

import heapq

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.controls import depressions
from terrasynth_core.controls.depressions import (WALL_WIDTH, block_pool, breach_depressions, breach_round,
                                                  coarse_grid, drain_terrain, grid_factor, stroke_blocks)
from terrasynth_core.controls.drainage import ArrayMask
from terrasynth_core.features.graph import FeatureGraph, FeatureNode, FeaturePath
from terrasynth_core.features.network import graph_mask

N = 96


def _filled(h: np.ndarray, outlets: np.ndarray | None = None) -> np.ndarray:
    """Priority-Flood (Barnes et al. 2014): every cell raised to the lowest
    level at which its water reaches the border or an outlet."""
    rows, cols = h.shape
    out = h.astype(np.float64).copy()
    done = np.zeros(h.shape, bool)
    heap = []
    for r in range(rows):
        for c in range(cols):
            if r in (0, rows - 1) or c in (0, cols - 1) or (outlets is not None and outlets[r, c]):
                heapq.heappush(heap, (out[r, c], r, c))
                done[r, c] = True
    while heap:
        z, r, c = heapq.heappop(heap)
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                y, x = r + dr, c + dc
                if 0 <= y < rows and 0 <= x < cols and not done[y, x]:
                    done[y, x] = True
                    out[y, x] = max(out[y, x], z)
                    heapq.heappush(heap, (out[y, x], y, x))
    return out


def _deepest(h, outlets=None) -> float:
    """Depth of the deepest closed depression, metres."""
    return float((_filled(h, outlets) - h).max())


def _slope_with_bowls(seed: int = 0) -> np.ndarray:
    """A slope falling to the east (3 m a cell, 30 cm of noise) with three
    round bowls 40-60 m deep sunk in it (closed 15-20 m deep on their
    downhill side)."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:N, 0:N].astype(float)
    h = 400.0 - 3.0 * xx + 0.3 * rng.standard_normal((N, N))
    for r, c, depth in ((30, 30, 60.0), (60, 50, 40.0), (70, 20, 50.0)):
        h -= depth * np.exp(-((yy - r) ** 2 + (xx - c) ** 2) / (2 * 6.0**2))
    return h.astype(np.float32)


def test_every_depression_is_breached_and_only_lowered():
    h = _slope_with_bowls()
    relief = np.percentile(h, 99.5) - np.percentile(h, 0.5)
    assert _deepest(h) > 15.0  # (the bowls are closed to begin with)
    done = breach_depressions(h)
    assert done.breached >= 3 and done.left == 0
    assert _deepest(done.heights) <= 0.005 * relief + 1e-3
    assert (done.heights <= h).all()
    # The breaches are local: most of the slope keeps its bytes.
    assert np.mean(done.heights == h) > 0.6


def test_a_ring_of_walls_keeps_its_basin():
    """A basin enclosed by a painted ridge stays closed: no breach crosses a wall."""
    yy, xx = np.mgrid[0:N, 0:N].astype(float)
    d = np.hypot(yy - N / 2, xx - N / 2)
    h = (100.0 + 0.5 * d + 80.0 * np.exp(-((d - 30.0) ** 2) / 20.0)).astype(np.float32)
    h[d < 10] -= 30.0
    walls = np.abs(d - 30.0) < 2.0
    done = breach_depressions(h, walls=walls)
    assert done.left >= 1
    assert np.array_equal(done.heights[d < 28], h[d < 28])  # the basin inside, untouched
    opened = breach_depressions(h)  # without the wall it is opened
    assert opened.breached >= 1 and _deepest(opened.heights) < 1.0
    # A painted valley in the basin must drain: the basin opens through the wall.
    valley = (np.abs(yy - N / 2) < 1) & (d < 20)
    drained = breach_depressions(h, walls=walls, drains=valley)
    assert drained.breached >= 1 and drained.left == 0 and _deepest(drained.heights) < 1.0
    assert (drained.heights <= h).all()
    crossed = walls & (drained.heights < h - 1.0)
    assert ndimage.label(crossed, structure=np.ones((3, 3)))[1] == 1  # one gap, not the wall torn down
    assert crossed.sum() < 0.25 * walls.sum()
    # ... but not through a locked cell.
    held = breach_depressions(h, walls=walls, drains=valley, locked=walls)
    assert held.left >= 1 and np.array_equal(held.heights[d < 28], h[d < 28])
    # Where locked cells, not the walls, close the basin in (painted water
    # inside the ring, held still with its banks, as a tiled run holds
    # them), it is left as before: no gap through the ring.
    lake = np.hypot(yy - N / 2, xx - (N / 2 - 18)) < 4
    banks = ndimage.binary_dilation(lake, iterations=3)
    fenced = breach_depressions(h, walls=walls, drains=valley, locked=banks, outlets=lake)
    assert fenced.left >= 1 and np.array_equal(fenced.heights[np.abs(d - 30.0) < 4], h[np.abs(d - 30.0) < 4])
    # A pit on the wall itself counts as left when its gap cannot be cut.
    on_wall = h.copy()
    on_wall[int(N / 2), int(N / 2 + 30)] -= 200.0
    cell = np.zeros(h.shape, bool)
    cell[int(N / 2), int(N / 2 + 30)] = True
    ringed = breach_depressions(on_wall, walls=walls, drains=cell, locked=ndimage.binary_dilation(cell, iterations=3) & ~cell)
    assert ringed.left >= 1


def test_a_gap_is_narrower_than_a_breach(monkeypatch):
    """The gap's walls take the GAP_SLOPE percentile of the slopes: fewer
    wall cells cut than with the other breaches' 90th."""
    yy, xx = np.mgrid[0:N, 0:N].astype(float)
    d = np.hypot(yy - N / 2, xx - N / 2)
    rng = np.random.default_rng(0)
    h = (100.0 + 0.5 * d + 80.0 * np.exp(-((d - 30.0) ** 2) / 20.0) + 3.0 * rng.standard_normal((N, N))).astype(np.float32)
    h[d < 10] -= 30.0
    walls, valley = np.abs(d - 30.0) < 2.0, (np.abs(yy - N / 2) < 1) & (d < 20)
    crossed = {}
    for percentile in (90.0, depressions.GAP_SLOPE):
        monkeypatch.setattr(depressions, "GAP_SLOPE", percentile)
        done = breach_depressions(h, walls=walls, drains=valley)
        assert done.breached >= 1
        crossed[percentile] = int((walls & (done.heights < h - 1.0)).sum())
    assert 0 < crossed[depressions.GAP_SLOPE] < crossed[90.0]


def test_locked_cells_keep_their_bytes():
    h = _slope_with_bowls()
    locked = np.zeros(h.shape, bool)
    locked[:, 36:40] = True  # a band east of the first bowl, across its way out
    done = breach_depressions(h, locked=locked)
    assert np.array_equal(done.heights[locked], h[locked])


def test_water_is_an_outlet():
    """A bowl holding painted water drains into it: nothing to breach there."""
    h = _slope_with_bowls()
    water = np.zeros(h.shape, bool)
    water[26:36, 26:38] = True
    done = breach_depressions(h, outlets=water)
    untouched = np.hypot(*np.mgrid[-30:N - 30, -32:N - 32]) < 10
    assert np.array_equal(done.heights[untouched], h[untouched])
    assert _deepest(done.heights, water) < 1.0
    assert _deepest(done.heights) > 15.0  # (without the water, that bowl is closed)


@pytest.mark.parametrize("factor", [1, 2, 4])
def test_drain_terrain_on_a_coarser_grid(factor):
    h = _slope_with_bowls(1)
    out = drain_terrain(h, factor=factor)
    assert out.dtype == np.float32 and out.shape == h.shape
    assert (out <= h).all()
    # The bowls are opened.  A grid f times coarser sees a rim as its block
    # means, lower than its crest: on bowls this small (a 6-cell sigma, 1.5
    # cells of the grid at f = 4) a fifth of the depth is left there.
    assert _deepest(out) < (0.05 if factor == 1 else 0.25) * _deepest(h)


def test_drain_terrain_keeps_locked_cells_and_flat_ground():
    h = _slope_with_bowls(2)
    locked = np.zeros(h.shape, bool)
    locked[50:, :] = True
    out = drain_terrain(h, factor=4, locked=locked)
    assert np.array_equal(out[locked], h[locked])
    flat = np.full((40, 40), 7.0, np.float32)
    assert drain_terrain(flat, factor=4) is flat


def test_drain_terrain_opens_a_ring_of_painted_ridges_only_about_painted_valleys():
    """The ring-and-cross case on a block grid: the ring's basin stays
    closed as drawn, but with a painted valley in it the valley drains
    through one gap in the ring (the depressions' fill sees no basin)."""
    n = 128
    yy, xx = np.mgrid[0:n, 0:n].astype(float)
    d = np.hypot(yy - n / 2, xx - n / 2)
    h = (100.0 + 0.3 * d + 60.0 * np.exp(-((d - 45.0) ** 2) / 40.0) - 40.0 * (d < 30) * (1 - d / 30)).astype(np.float32)
    angle = np.linspace(0, 2 * np.pi, 200)
    ring = np.stack([n / 2 + 45 * np.sin(angle), n / 2 + 45 * np.cos(angle)], axis=1)
    ridges = FeatureGraph("ridge", (n, n), (FeatureNode(0, *ring[0], "end", 1), FeatureNode(1, *ring[-1], "end", 1)),
                          (FeaturePath(0, 1, ring),))
    line = np.stack([np.full(30, n / 2), np.linspace(n / 2 - 15, n / 2 + 15, 30)], axis=1)
    valleys = FeatureGraph("valley", (n, n), (FeatureNode(0, *line[0], "end", 1), FeatureNode(1, *line[-1], "end", 1)),
                           (FeaturePath(0, 1, line),))
    inside = d < 40
    closed = drain_terrain(h, factor=2, ridges=ridges)
    assert np.array_equal(closed[inside], h[inside]) and _deepest(closed) > 30.0
    opened = drain_terrain(h, factor=2, ridges=ridges, valleys=valleys)
    assert (opened <= h).all() and _deepest(opened) < 0.25 * _deepest(h)
    # Without walls the same valley needs no gap: the valleys change nothing.
    assert np.array_equal(drain_terrain(h, factor=2, valleys=valleys), drain_terrain(h, factor=2))


def test_grid_factor():
    assert grid_factor(80) == 4 and grid_factor(48) == 2 and grid_factor(16) == 1
    # A world-size map's grid stays within MOST_CELLS.
    assert grid_factor(80, (8192, 8192)) == 4 and grid_factor(80, (16384, 16384)) == 8
    assert grid_factor(16, (5000, 3000)) == 2


@pytest.mark.parametrize("factor", [1, 3, 4])
def test_stroke_blocks_are_the_blocks_of_the_wide_lines(factor):
    """From the lines' cells alone, the blocks the whole map's 3-cell-wide
    mask meets, the map's edges included."""
    shape = (97, 131)
    rng = np.random.default_rng(factor)
    nodes, paths = [], []
    for i in range(4):
        points = np.cumsum(rng.normal(0, 4, (40, 2)), axis=0) + rng.uniform(-5, 135, 2)  # (some leave the map)
        nodes += [FeatureNode(2 * i, *points[0], "end", 1), FeatureNode(2 * i + 1, *points[-1], "end", 1)]
        paths.append(FeaturePath(2 * i, 2 * i + 1, points))
    ridges = FeatureGraph("ridge", shape, tuple(nodes), tuple(paths))
    grid = coarse_grid(shape, factor)
    expected = block_pool(graph_mask(ridges, width=WALL_WIDTH), factor, grid, np.any)
    assert expected.any() and np.array_equal(stroke_blocks(ridges, factor, grid), expected)
    assert stroke_blocks(FeatureGraph("ridge", shape, (), ()), factor, grid) is None


def test_a_lowering_over_a_box_is_the_whole_maps():
    """A breach round's cubic lowering, made once, read over boxes and at
    cells, gives the whole map's values to the bit: scipy's cubic zoom of
    the block grid's change, to round-off."""
    h = _slope_with_bowls(4)
    grid = coarse_grid(h.shape, 3)
    coarse = block_pool(h.astype(np.float64), 3, grid, np.mean)
    lowering = breach_round(coarse, 3, walls=None, water=None, held=None, locked=None)
    whole = lowering.over((0, N, 0, N))
    assert (whole < -1.0).sum() > 100 and (whole <= 0).all()
    assert np.array_equal(lowering.over((17, 61, 5, N)), whole[17:61, 5:])
    rr, cc = np.nonzero(whole < 0)
    assert np.array_equal(lowering.at(rr, cc), whole[rr, cc])
    change = breach_depressions(coarse).heights.astype(np.float64) - coarse
    zoomed = ndimage.zoom(change, 3, order=3, mode="nearest", grid_mode=True)[:N, :N]
    assert np.allclose(whole, np.minimum(zoomed + lowering.tol, 0.0), rtol=0, atol=1e-9)


def test_bands_give_the_whole_maps_blocks_and_lowering(monkeypatch):
    """Pooled and lowered a band of rows at a time (a large map is never
    held in float64), the same values as the whole map at once."""

    h = _slope_with_bowls(5)[:, :91]  # (not a whole number of blocks)
    water = np.zeros(h.shape, bool)
    water[40:44, 80:] = True
    whole = drain_terrain(h, factor=3, water=water)
    heights = lambda box: h[box[0]:box[1], box[2]:box[3]].astype(np.float64)  # noqa: E731
    means = depressions.pooled_bands(heights, h.shape, 3, np.mean)
    monkeypatch.setattr(depressions, "BAND_CELLS", 7 * 91)  # (bands of two blocks, of 7 rows lowered)
    assert np.array_equal(depressions.pooled_bands(heights, h.shape, 3, np.mean), means)
    assert np.array_equal(means, block_pool(h.astype(np.float64), 3, coarse_grid(h.shape, 3), np.mean))
    assert np.array_equal(depressions.pooled_bands(ArrayMask(water).window, h.shape, 3, np.any),
                          block_pool(water, 3, coarse_grid(h.shape, 3), np.any))
    assert depressions.pooled_bands(ArrayMask(np.zeros(h.shape, bool)).window, h.shape, 3, np.any) is None
    assert np.array_equal(drain_terrain(h, factor=3, water=water), whole)


@pytest.mark.parametrize("terrain", ["bowls", "gentle", "flat"])
def test_a_gorge_widened_cell_by_cell_or_in_batches_is_the_same(monkeypatch, terrain):
    """The two ways of widening a cut (batches of small squares, or one
    channel cell at a time on wide ones) give the same bytes, on gentle
    and on flat ground too, where a cut's reach has no bound (a flat map's
    steep slope is 0: the squares span the map)."""

    yy, xx = np.mgrid[0:120, 0:120].astype(float)
    if terrain == "bowls":
        h = _slope_with_bowls(6).astype(np.float64)
    elif terrain == "gentle":
        h = 0.05 * xx - 8.0 * np.exp(-((yy - 60) ** 2 + (xx - 70) ** 2) / (2 * 3.0**2))
    else:
        h = np.zeros((120, 120))
        h[10:30, 10:30] = 100.0
        h[60:63, 60:63] = -20.0
    monkeypatch.setattr(depressions, "_BATCH_REACH", 10**9)
    batched = breach_depressions(h)
    monkeypatch.setattr(depressions, "_BATCH_REACH", 0)
    looped = breach_depressions(h)
    assert batched.breached >= 1 and np.array_equal(batched.heights, looped.heights)
    assert _deepest(batched.heights) < 0.05 * _deepest(h)
