"""The tile grid of a tiled run: where each tile lies, in which phase it is
made, which finished neighbours constrain it, and its seed.

Tiles are made in the four phases of a checkerboard of 2 x 2 blocks: phase
``2 * (row % 2) + (col % 2)``.  A tile's *crop* is the tile grown by
``context`` cells on each side whose neighbour belongs to an earlier phase
(and is therefore finished when the tile starts): phase 0 tiles stand
alone, phase 1 tiles see their left and right neighbours, phase 2 tiles
the ones above and below, phase 3 tiles all eight.  Every tile border is so
synthesized once, by the later of its two tiles, against the finished
terrain of the earlier one, as a local re-synthesis merges new patches
with kept terrain (graph cut and seam solve).  The later tile may replace
a *band* of the earlier one's cells along the border, so its graph cuts
choose where the two meet (the tile's *region*: its box and those bands);
the output takes each cell from the latest phase whose region holds it.  What a tile sees depends
only on the plan, never on which tile finished first: the run gives the
same bytes on any number of workers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParamsError

__all__ = ["CONTEXT_PATCHES", "MIN_TILE_PATCHES", "Tile", "TilePlan", "plan_tiles"]

#: Finished terrain a tile sees beyond each border it shares with an earlier
#: phase, in patch sizes: a fill window overlapping the border needs a
#: patch of kept terrain to be matched against.  (The level field is
#: global, so unlike a crop re-synthesis no context is needed for it.)
CONTEXT_PATCHES = 1.0

#: How far a tile's seams may reach into a finished neighbour, in patch
#: sizes: the graph cut chooses where within this band the new terrain
#: meets the old (the finished terrain is kept beyond it).  Without it the
#: seam is forced onto the tile border, where old and new meet with a
#: crease however well they are matched.
BAND_PATCHES = 0.5

#: Smallest tile side, in patch sizes: a tile holds a few patches, and no
#: tile (not even a last, thinner one) is narrower than the context and
#: band that its two neighbours reach into it from either side.
MIN_TILE_PATCHES = 3

Box = tuple[int, int, int, int]


@dataclass(frozen=True)
class Tile:
    """One tile of a :class:`TilePlan`.

    Parameters
    ----------
    row, col : int
        Its place in the tile grid (row 0 at the top).
    box : (r0, r1, c0, c1)
        Its cells in the output, half-open.
    crop : (r0, r1, c0, c1)
        The window its session runs on: ``box`` and the finished context
        around it.
    region : (r0, r1, c0, c1)
        The cells it makes: ``box`` and a band of the finished neighbours
        where its seams may run (it replaces them there).
    phase : int
        0 to 3; a tile starts when every tile it ``needs`` is finished.
    needs : tuple of (row, col)
        The earlier-phase tiles the crop reaches into.
    seed : int
        Its synthesis seed, from the run's seed and ``(row, col)``.
    """

    row: int
    col: int
    box: Box
    crop: Box
    region: Box
    phase: int
    needs: tuple[tuple[int, int], ...]
    seed: int

    @property
    def key(self) -> tuple[int, int]:
        return (self.row, self.col)

    @property
    def shape(self) -> tuple[int, int]:
        r0, r1, c0, c1 = self.box
        return (r1 - r0, c1 - c0)

    @property
    def inner(self) -> tuple[slice, slice]:
        """The tile's own cells within its crop."""
        return _within(self.box, self.crop)

    @property
    def made(self) -> tuple[slice, slice]:
        """The cells it makes (``region``) within its crop."""
        return _within(self.region, self.crop)


@dataclass(frozen=True)
class TilePlan:
    """The tiles of an output, in the order they may be submitted.

    Parameters
    ----------
    shape : (rows, cols)
        The whole output, cells.
    tile : int
        The nominal tile side, cells.
    context : int
        Cells of finished terrain a tile sees across a border.
    band : int
        Cells of it a tile may replace (where its seams run).
    row_edges, col_edges : tuple of int
        The tile grid's lines, from 0 to ``rows`` (``cols``).
    tiles : tuple of Tile
        Phase by phase, row-major within a phase.
    """

    shape: tuple[int, int]
    tile: int
    context: int
    band: int
    row_edges: tuple[int, ...]
    col_edges: tuple[int, ...]
    tiles: tuple[Tile, ...]

    @property
    def grid(self) -> tuple[int, int]:
        """Tiles down and across."""
        return (len(self.row_edges) - 1, len(self.col_edges) - 1)

    def __len__(self) -> int:
        return len(self.tiles)

    def by_key(self) -> dict[tuple[int, int], Tile]:
        return {t.key: t for t in self.tiles}


def tile_edges(size: int, tile: int) -> tuple[int, ...]:
    """Grid lines along one side: every ``tile`` cells, the last tile taking
    the remainder, merged into the one before when less than half a tile
    (so no tile is thinner than half a tile, and none wider than 1.5)."""
    edges = list(range(0, size, tile)) + [size]
    if len(edges) > 2 and edges[-1] - edges[-2] < tile / 2:
        del edges[-2]
    return tuple(edges)


def tile_seed(seed: int, row: int, col: int) -> int:
    """A tile's synthesis seed: a hash of the run's seed and the tile's place
    (so neighbours draw unrelated numbers, and no tile's draws depend on
    another's)."""
    return int(np.random.SeedSequence([seed, row, col]).generate_state(1)[0])


def plan_tiles(shape: tuple[int, int], tile: int, *, patch_size: int, seed: int = 0,
               context_patches: float = CONTEXT_PATCHES, band_patches: float = BAND_PATCHES) -> TilePlan:
    """The tile plan of an output.

    Parameters
    ----------
    shape : (rows, cols)
        Output cells.
    tile : int
        Tile side, cells; at least :data:`MIN_TILE_PATCHES` patches.
    patch_size : int
        The run's patch side, cells.
    seed : int, default 0
        The run's seed.
    context_patches : float, default :data:`CONTEXT_PATCHES`
    band_patches : float, default :data:`BAND_PATCHES`
        At most ``context_patches``.

    Returns
    -------
    TilePlan

    Raises
    ------
    ParamsError
        A tile smaller than :data:`MIN_TILE_PATCHES` patches, or larger
        than the output.
    """
    rows, cols = (int(v) for v in shape)
    if isinstance(tile, bool) or not isinstance(tile, (int, np.integer)) or tile < MIN_TILE_PATCHES * patch_size:
        raise ParamsError(f"tile size {tile!r}: expected a whole number of at least {MIN_TILE_PATCHES * patch_size} "
                          f"cells ({MIN_TILE_PATCHES} patches of {patch_size})")
    tile = int(tile)
    if tile > max(rows, cols):
        raise ParamsError(f"tile size {tile} is larger than the output {rows}x{cols}: give a smaller --tile, or "
                          "run without tiles")
    context = int(math.ceil(context_patches * patch_size))
    band = min(int(math.ceil(band_patches * patch_size)), context)
    r_edges, c_edges = tile_edges(rows, tile), tile_edges(cols, tile)
    n_r, n_c = len(r_edges) - 1, len(c_edges) - 1

    def phase(i: int, j: int) -> int:
        return 2 * (i % 2) + (j % 2)

    boxes = {(i, j): (r_edges[i], r_edges[i + 1], c_edges[j], c_edges[j + 1])
             for i in range(n_r) for j in range(n_c)}
    grown = {}
    for (i, j), (r0, r1, c0, c1) in boxes.items():
        p = phase(i, j)
        # Grow towards finished (earlier-phase) sides only.
        up = i > 0 and phase(i - 1, j) < p
        down = i + 1 < n_r and phase(i + 1, j) < p
        left = j > 0 and phase(i, j - 1) < p
        right = j + 1 < n_c and phase(i, j + 1) < p
        grown[i, j] = tuple((r0 - d * up, r1 + d * down, c0 - d * left, c1 + d * right) for d in (context, band))
    tiles = []
    for (i, j), box in boxes.items():
        p = phase(i, j)
        crop, region = grown[i, j]
        # Every earlier tile whose made cells reach into the crop (a
        # diagonal neighbour's band may): what the tile sees is then fixed
        # by the plan, whatever finished first.
        needs = tuple((a, b) for a in range(max(i - 1, 0), min(i + 2, n_r)) for b in range(max(j - 1, 0), min(j + 2, n_c))
                      if phase(a, b) < p and _overlaps(crop, grown[a, b][1]))
        tiles.append(Tile(i, j, box, crop, region, p, needs, tile_seed(seed, i, j)))
    tiles.sort(key=lambda t: (t.phase, t.row, t.col))
    return TilePlan((rows, cols), tile, context, band, r_edges, c_edges, tuple(tiles))


def _overlaps(a: Box, b: Box) -> bool:
    return a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]


def _within(inner: Box, outer: Box) -> tuple[slice, slice]:
    r0, r1, c0, c1 = inner
    return slice(r0 - outer[0], r1 - outer[0]), slice(c0 - outer[2], c1 - outer[2])
