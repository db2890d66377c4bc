"""Drainage in a tiled run: the whole map's painted valleys made to drain
and its ridges to divide once the tiles are finished, without holding the
map.

A tile cannot drain its valleys alone: a valley's floor must descend all
the way to its outlet, tiles away.  So the step
(:mod:`terrasynth_core.controls.drainage`) runs after the tiles on the
whole map's strokes.  It reads the heights along them from the tiles on
disk (memory-mapped, :class:`TiledSurface`), solves each valley's profile
and each correction on the cells it changes (a band along the strokes),
and the GeoTIFF writer adds the corrections band of rows by band of rows
(:meth:`TiledSurface.corrected`).  The heights are those
:func:`~terrasynth_core.controls.drainage.apply_drainage` gives on the
composed map, to the bit, in memory that grows with the strokes' length,
not the map's area.

The terrain's other closed depressions are then breached as a whole-map
finish breaches them (:func:`breach_tiles`): on the block grid of the
drained map, read band by band, its lowering added as one more
correction.

Unlike a whole-map run's finish, it comes after the tiles' own finishing
(their knee into the examples' range, water and pins): painted water and
its banks are held still (locked; a valley ending in water has its outlet
there); a pin within reach of a corrected stroke moves with it and the run
says so; a floor the step lowers may end a little below the examples'
range.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from ..controls.depressions import Lowering, breach_in_rounds, grid_factor
from ..controls.drainage import Correction, drain
from ..features.graph import FeatureGraph, FeatureMaps, FeatureNode, FeaturePath
from ..features.sketch import SketchMap, sketch_features
from .controls import painted_index, window_nearest
from .plan import TilePlan
from .store import TileStore, compose

__all__ = ["PaintedMask", "TiledSurface", "breach_tiles", "drain_tiles", "map_strokes"]

#: Rows of the map composed at a time when its height span is read.
SPAN_ROWS = 512

#: Most cells the strokes are traced on (:func:`map_strokes`): a larger
#: output is traced on a grid a whole factor coarser, and scaled.
TRACE_CELLS = 4096 * 4096


class TiledSurface:
    """The finished tiles of a run, read cell by cell where the drainage
    step asks (:class:`~terrasynth_core.controls.drainage.Surface`), with
    the corrections it adds.

    Parameters
    ----------
    store : TileStore
        Holding every tile of ``plan``.
    plan : TilePlan
    """

    def __init__(self, store: TileStore, plan: TilePlan):
        self.store, self.plan = store, plan
        self.shape = tuple(plan.shape)
        self.corrections: list[Correction | Lowering] = []

    def __getitem__(self, cells: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        rr, cc = (np.asarray(a, np.int64) for a in cells)
        shape = rr.shape
        rr, cc = rr.ravel(), cc.ravel()
        out = np.zeros(rr.shape, np.float32)
        # Each cell lies in its own tile's box; a tile's region reaches
        # less than a tile into its neighbours', so only the cells of the
        # nine boxes about a tile are looked at for it.
        n_rows, n_cols = len(self.plan.row_edges) - 1, len(self.plan.col_edges) - 1
        box_of = ((np.searchsorted(self.plan.row_edges, rr, side="right") - 1) * n_cols
                  + np.searchsorted(self.plan.col_edges, cc, side="right") - 1)
        order = np.argsort(box_of, kind="stable")
        starts = np.searchsorted(box_of[order], np.arange(n_rows * n_cols + 1))
        for tile in self.plan.tiles:  # in phase order: later phases paint over earlier ones (as compose)
            i, j = tile.key
            near = np.concatenate([order[starts[a * n_cols + c]:starts[a * n_cols + c + 1]]
                                   for a in range(max(i - 1, 0), min(i + 2, n_rows))
                                   for c in range(max(j - 1, 0), min(j + 2, n_cols))])
            a0, a1, b0, b1 = tile.region
            near = near[(rr[near] >= a0) & (rr[near] < a1) & (cc[near] >= b0) & (cc[near] < b1)]
            if len(near):
                made = self.store.load(tile.key, mmap=True)
                out[near] = made[rr[near] - a0, cc[near] - b0]
        for correction in self.corrections:
            correction.apply_at(rr, cc, out)
        return out.reshape(shape)

    def add(self, correction: Correction | Lowering) -> None:
        self.corrections.append(correction)

    def corrected(self, box: tuple[int, int, int, int], heights: np.ndarray) -> np.ndarray:
        """``heights`` (the tiles over ``box``, float32) with the
        corrections applied in turn, in place and returned."""
        for correction in self.corrections:
            correction.apply(box, heights)
        return heights

    def span(self) -> float:
        """The composed map's height span (max - min), metres, read
        :data:`SPAN_ROWS` rows at a time."""
        rows, cols = self.shape
        lowest, highest = np.float32(np.inf), np.float32(-np.inf)
        for r0 in range(0, rows, SPAN_ROWS):
            band = compose(self.store, self.plan, (r0, min(r0 + SPAN_ROWS, rows), 0, cols))
            lowest, highest = min(lowest, band.min()), max(highest, band.max())
        return float(highest - lowest)  # float32, as np.ptp of the whole map


class PaintedMask:
    """A mask as painted, read at output cells by nearest cell (as the
    tiles read it, :func:`~.controls.window_nearest`): a
    :class:`~terrasynth_core.controls.drainage.Mask`."""

    def __init__(self, painted: np.ndarray, shape: tuple[int, int]):
        self.painted = np.asarray(painted, bool)
        self.shape = tuple(shape)

    def at(self, rr: np.ndarray, cc: np.ndarray) -> np.ndarray:
        h, w = self.painted.shape
        return self.painted[painted_index(rr, h, self.shape[0]), painted_index(cc, w, self.shape[1])]

    def window(self, box: tuple[int, int, int, int]) -> np.ndarray:
        return window_nearest(self.painted, self.shape, box)


def map_strokes(sketch: SketchMap, shape: tuple[int, int]) -> FeatureMaps:
    """The sketch's ridge and valley networks in output cells.

    Traced on the sketch scaled to the output, as the tiles trace theirs
    (so the step finds the valleys the tiles built: a stroke painted two
    pixels wide and traced at the painted size would lie half a painted
    pixel off their centreline); an output over :data:`TRACE_CELLS` is
    traced on a grid a whole factor coarser and the lines scaled, cell
    centre to cell centre (off by at most half that factor).
    """
    rows, cols = shape
    f = max(1, math.ceil(math.sqrt(rows * cols / TRACE_CELLS)))
    grid = (-(-rows // f), -(-cols // f))
    maps = sketch_features(sketch.resized(grid))
    if grid == (rows, cols):
        return maps
    sr, sc = rows / grid[0], cols / grid[1]

    def scaled(graph: FeatureGraph) -> FeatureGraph:
        nodes = tuple(FeatureNode(n.id, (n.row + 0.5) * sr - 0.5, (n.col + 0.5) * sc - 0.5, n.type, n.degree)
                      for n in graph.nodes)
        paths = tuple(FeaturePath(p.start, p.end, (np.asarray(p.points, float) + 0.5) * (sr, sc) - 0.5)
                      for p in graph.paths)
        return FeatureGraph(graph.kind, tuple(shape), nodes, paths)

    return FeatureMaps(scaled(maps.ridges), scaled(maps.valleys))


def drain_tiles(store: TileStore, plan: TilePlan, sketch: SketchMap | None, *, patch_size: int, water=None,
                pins=()) -> tuple[TiledSurface, list[str]]:
    """Drain the whole map of a finished tiled run: its painted valleys and
    ridges (when the sketch has strokes), then its closed depressions.

    Parameters
    ----------
    store : TileStore
        Holding every tile of ``plan``.
    plan : TilePlan
    sketch : SketchMap or None
        As painted, any size (scaled to the output).
    patch_size : int
        The run's.
    water : Water, optional
        Painted water (its mask as painted): held still, and an outlet.
    pins : sequence of Pin
        In output cells: those the drainage moves are named in the notes.

    Returns
    -------
    surface : TiledSurface
        The tiles and their corrections, the breaches' lowering last
        (:meth:`TiledSurface.corrected` gives the drained heights over any
        box).
    notes : list of str
        For the run's warnings.
    """
    surface = TiledSurface(store, plan)
    painted = None if water is None or not np.any(water.mask) else PaintedMask(water.mask, plan.shape)
    banks = None
    if painted is not None:
        # The water and its banks (the tiles shaped them over half a patch)
        # are held still; the banks widened at the painted size.
        reach = math.ceil(patch_size / 2 * water.mask.shape[0] / plan.shape[0])
        banks = PaintedMask(ndimage.binary_dilation(painted.painted, iterations=reach), plan.shape)
    ridges = valleys = None
    if sketch is not None and sketch.has_strokes:
        maps = map_strokes(sketch, plan.shape)
        ridges, valleys = maps.ridges, maps.valleys
        drain(surface, maps.valleys, maps.ridges, patch_size=patch_size, span=surface.span(), water=painted,
              locked=banks)
    strokes = len(surface.corrections)
    breach_tiles(surface, ridges, valleys, patch_size=patch_size, water=painted, locked=banks)
    notes = []
    for p in pins:
        at = (np.array([p.row]), np.array([p.col]))
        for corrections, what in ((surface.corrections[:strokes], "the valleys' drainage"),
                                  (surface.corrections[strokes:], "the breaching of closed depressions")):
            moved = sum(float(c.at(*at)[0]) for c in corrections)
            if abs(moved) >= 0.01:
                notes.append(f"the pin at row {p.row}, col {p.col} moved {moved:+.2f} m with {what}, which a tiled "
                             "run applies after the tiles: move the pin, or turn drainage off")
    return surface, notes


def breach_tiles(surface: TiledSurface, ridges: FeatureGraph | None, valleys: FeatureGraph | None = None, *,
                 patch_size: int, water: PaintedMask | None = None, locked: PaintedMask | None = None) -> None:
    """The closed depressions of a drained tiled map breached, as
    :func:`~terrasynth_core.controls.depressions.drain_terrain` breaches a
    whole map's (the same rounds,
    :func:`~terrasynth_core.controls.depressions.breach_in_rounds`), each
    round's lowering added to ``surface``.

    The map is read band by band from the tiles with the corrections so
    far; the block grid is about
    :data:`~terrasynth_core.controls.depressions.MOST_CELLS` cells at most,
    so the memory is bounded whatever the map's size.

    Parameters
    ----------
    surface : TiledSurface
        Its valleys drained.
    ridges : FeatureGraph or None
        The painted ridges in output cells: walls.
    valleys : FeatureGraph or None, optional
        The painted valleys in output cells: their basins drain through
        the walls.
    patch_size : int
    water, locked : PaintedMask, optional
        Painted water (an outlet) and cells held still (its banks).
    """
    breach_in_rounds(surface.shape, grid_factor(patch_size, surface.shape),
                     lambda box: surface.corrected(box, compose(surface.store, surface.plan, box)), surface.add,
                     ridges=ridges, valleys=valleys, water=water, locked=locked)
