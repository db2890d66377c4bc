"""A tiled run's closed depressions breached (terrasynth_core.tiled.drainage.breach_tiles)
as a whole-map finish breaches them (controls.depressions.drain_terrain): the
same heights to the bit, read band by band from the tiles on disk."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.controls import depressions
from terrasynth_core.controls.depressions import drain_terrain, grid_factor
from terrasynth_core.features.graph import FeatureGraph, FeatureNode, FeaturePath
from terrasynth_core.tiled.drainage import PaintedMask, TiledSurface, breach_tiles
from terrasynth_core.tiled.plan import plan_tiles
from terrasynth_core.tiled.store import TileStore, compose

SHAPE = (300, 362)  # (neither a whole number of tiles nor of blocks)


def _bowly_terrain() -> np.ndarray:
    """A slope with 30 round bowls 20-60 m deep and a metre of noise."""
    rng = np.random.default_rng(3)
    yy, xx = np.mgrid[0:SHAPE[0], 0:SHAPE[1]].astype(float)
    h = 600.0 - 1.0 * xx + rng.standard_normal(SHAPE)
    for r, c, depth, sigma in zip(rng.uniform(20, 280, 30), rng.uniform(20, 340, 30), rng.uniform(20, 60, 30),
                                  rng.uniform(5, 12, 30)):
        h -= depth * np.exp(-((yy - r) ** 2 + (xx - c) ** 2) / (2 * sigma**2))
    return h.astype(np.float32)


def _ridge() -> FeatureGraph:
    """A painted ridge across the map (a wall)."""
    points = np.column_stack([np.linspace(150, 160, 200), np.linspace(20, 340, 200)])
    nodes = (FeatureNode(0, 150.0, 20.0, "end", 1), FeatureNode(1, 160.0, 340.0, "end", 1))
    return FeatureGraph("ridge", SHAPE, nodes, (FeaturePath(0, 1, points),))


@pytest.fixture
def store(tmp_path):
    store = TileStore(tmp_path / "t.tiles", "test")
    yield store
    store.close()


def _tiled(heights: np.ndarray, store: TileStore) -> TiledSurface:
    """``heights`` kept as the finished tiles of a 100-cell tile plan."""
    plan = plan_tiles(SHAPE, 100, patch_size=32)
    for tile in plan.tiles:
        a0, a1, b0, b1 = tile.region
        store.save(tile.key, heights[a0:a1, b0:b1])
    assert np.array_equal(compose(store, plan, (0, SHAPE[0], 0, SHAPE[1])), heights)
    return TiledSurface(store, plan)


@pytest.mark.parametrize("patch_size, band_cells, most_cells", [(80, 1 << 22, 2048**2), (48, 40 * 362, 2048**2),
                                                                (32, 30 * 362, 50 * 60)])
def test_tiles_are_breached_as_the_whole_map(store, monkeypatch, patch_size, band_cells, most_cells):
    """Factors 4, 2 and (the coarse grid capped at 3000 cells) 7; the map
    read in one band and in bands of 20 and 4 blocks; painted water at
    another size than the output (an outlet) and its banks (held still),
    and a ridge (a wall)."""
    monkeypatch.setattr(depressions, "BAND_CELLS", band_cells)
    monkeypatch.setattr(depressions, "MOST_CELLS", most_cells)
    heights = _bowly_terrain()
    painted = np.zeros((100, 120), bool)
    painted[70:80, 90:110] = True
    water, banks = PaintedMask(painted, SHAPE), PaintedMask(np.pad(painted[2:-2, 2:-2], 2, constant_values=False)
                                                            | painted, SHAPE)
    surface = _tiled(heights, store)
    breach_tiles(surface, _ridge(), patch_size=patch_size, water=water, locked=banks)
    box = (0, SHAPE[0], 0, SHAPE[1])
    tiled = surface.corrected(box, compose(surface.store, surface.plan, box))
    whole = drain_terrain(heights, factor=grid_factor(patch_size, SHAPE), ridges=_ridge(), water=water.window(box),
                          locked=banks.window(box))
    assert grid_factor(patch_size, SHAPE) == {80: 4, 48: 2, 32: 7}[patch_size]
    assert np.array_equal(tiled, whole)
    assert (tiled < heights - 1.0).sum() > 500  # (the breaches lowered something)
    # The corrections read at cells give the same lowering.
    lowering = surface.corrections[-1]
    rr, cc = np.nonzero(lowering.over(box) < 0)
    assert np.array_equal(lowering.at(rr[::7], cc[::7]), lowering.over(box)[rr[::7], cc[::7]])


def test_a_tiled_map_without_strokes_is_breached_and_reads_as_written(store):
    """No sketch: the map is still breached (as a whole-map run's finish
    does); cells read one by one give the written heights; a pin the
    breach lowers is named."""
    from terrasynth_core.controls.pins import Pin
    from terrasynth_core.tiled.drainage import drain_tiles

    heights = _bowly_terrain()
    surface = _tiled(heights, store)
    whole = drain_terrain(heights, factor=grid_factor(80, SHAPE))
    lowered = np.argwhere(whole < heights - 5.0)[0]
    drained, notes = drain_tiles(store, surface.plan, None, patch_size=80,
                                 pins=(Pin(int(lowered[0]), int(lowered[1]), 0.0),))
    box = (0, SHAPE[0], 0, SHAPE[1])
    tiled = drained.corrected(box, compose(store, surface.plan, box))
    assert np.array_equal(tiled, whole) and (tiled < heights - 1.0).sum() > 500
    rr, cc = np.nonzero(tiled < heights)
    assert np.array_equal(drained[rr, cc], tiled[rr, cc])
    assert len(notes) == 1 and "moved" in notes[0] and "breaching of closed depressions" in notes[0]


def _ring_and_valley(heights: np.ndarray) -> tuple[np.ndarray, FeatureGraph, FeatureGraph]:
    """``heights`` with a ring of high ground about a sunken basin (radius
    60 about (150, 180)), the ring painted as a ridge and a valley painted
    down the basin's middle."""
    yy, xx = np.mgrid[0:SHAPE[0], 0:SHAPE[1]].astype(float)
    d = np.hypot(yy - 150, xx - 180)
    h = heights + 120.0 * np.exp(-((d - 60.0) ** 2) / 60.0) - 80.0 * (d < 50) * (1 - d / 50)
    angle = np.linspace(0, 2 * np.pi, 300)
    ring = np.column_stack([150 + 60 * np.sin(angle), 180 + 60 * np.cos(angle)])
    line = np.column_stack([np.full(40, 150.0), np.linspace(160, 200, 40)])
    ridges = FeatureGraph("ridge", SHAPE, (FeatureNode(0, *ring[0], "end", 1), FeatureNode(1, *ring[-1], "end", 1)),
                          (FeaturePath(0, 1, ring),))
    valleys = FeatureGraph("valley", SHAPE, (FeatureNode(0, *line[0], "end", 1), FeatureNode(1, *line[-1], "end", 1)),
                           (FeaturePath(0, 1, line),))
    return h.astype(np.float32), ridges, valleys


@pytest.mark.parametrize("patch_size", [80, 48])
def test_a_painted_valley_in_a_ring_opens_it_in_tiles_as_in_the_whole_map(store, patch_size):
    """The ring's basin holds a painted valley: the tiled breach cuts the
    same gap through the ring as the whole map's, to the bit."""
    heights, ridges, valleys = _ring_and_valley(_bowly_terrain())
    surface = _tiled(heights, store)
    breach_tiles(surface, ridges, valleys, patch_size=patch_size)
    box = (0, SHAPE[0], 0, SHAPE[1])
    tiled = surface.corrected(box, compose(surface.store, surface.plan, box))
    whole = drain_terrain(heights, factor=grid_factor(patch_size, SHAPE), ridges=ridges, valleys=valleys)
    assert np.array_equal(tiled, whole)
    closed = drain_terrain(heights, factor=grid_factor(patch_size, SHAPE), ridges=ridges)
    yy, xx = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
    inside = np.hypot(yy - 150, xx - 180) < 40
    assert (whole[inside] < closed[inside] - 10.0).any()  # (the valley's basin drained, not only kept)
