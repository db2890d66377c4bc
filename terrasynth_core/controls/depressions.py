"""Closed depressions breached: the terrain drains to the map's border.

Pieced from patches, a synthesized terrain holds closed depressions that
real terrain of its kind does not: basins with no outlet, whose water would
pool into a lake.  Measured with RichDEM on 30 runs (five built-ins, three
sketches, two seeds), 3 to 15 % of the output's cells lay in depressions
deeper than 1 % of its relief, against 0 to 2.4 % in the examples; most of
the area in a few basins a tenth to a quarter of the relief deep (the
landform pass's coarse terrain and the patches' own relief leave them
alike), the rest patch-sized pits.  The finish stage breaches them on the
finished terrain (:func:`drain_terrain`, on a grid of 20 cells a patch).

:func:`breach_depressions` opens them the way water would (least-cost
breaching, Lindsay 2016): for each depression, from its lowest cell, the
path that needs the least total cut to reach a cell lower than it (or the
map's border) is found (:class:`skimage.graph.MCP_Geometric` on the height
above the depression's floor) and cut so that it descends all the way.
The cut is then widened into a gorge whose walls are no steeper than the
terrain's steep slopes, as a smooth offset, so the ground keeps its own
detail, and never below the channel, so the walls drain into it.  Filling
(raising the depression to its spill level, Priority-Flood) would leave
flat lakes of land: a closed basin on dry land reads as a crater, a flat
as an artefact.

Painted ridges are walls: no breach crosses them, so a ring of ridges the
artist drew stays closed (its basin is the drawing's), unless a painted
valley lies in the basin.  Painted valleys drain, so their basin opens
through the walls where there is least to cut: a ring of ridges with a
cross of valleys inside, on Big Tujunga, the Himalaya and St. Helens, had
lain lower than everything outside it, its whole interior a lake 20-24 %
of the map (the valleys' own breach, :mod:`.drainage`, finds nothing lower
within its reach there).  Locked cells never change.

References
----------
Lindsay, J. B. (2016). Efficient hybrid breaching-filling sink removal
methods for flow path enforcement in digital elevation models.
Hydrological Processes 30(6).
Barnes, R., Lehman, C., Mulla, D. (2014). Priority-flood: An optimal
depression-filling and watershed-labeling algorithm for digital elevation
models. Computers & Geosciences 62 (the fill that finds the depressions:
:func:`skimage.morphology.reconstruction` by erosion is the same flood).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage, sparse

from ..features.graph import FeatureGraph
from ..features.network import graph_cells
# (Channels fall as the valleys' floors do: the drainage step's least slope.)
from .drainage import MIN_SLOPE, ArrayMask, Mask, least_cut_path, spill_levels
from .water import smoothstep

#: Least depth of a depression that is breached, as a share of the
#: terrain's relief (its 0.5th to 99.5th height percentile): shallower pits
#: do not show.  Half of it left the same share of cells in depressions
#: deeper than 1 % (18 runs) and took 1.5-1.7 times as long.
MIN_DEPTH = 0.01

#: The search window about a depression grows from this margin (cells) by
#: doubling, up to :data:`MAX_MARGIN`; a depression with no way out within
#: it is left.
FIRST_MARGIN = 8
MAX_MARGIN = 256

#: Cells a patch spans on the grid a finished terrain is breached on
#: (:func:`drain_terrain`): its depressions are patch-sized.
CELLS_PER_PATCH = 20

#: Most cells of the coarse grid (a larger map is breached on a coarser
#: one, :func:`grid_factor`): its memory and time stay bounded (a round
#: on a grid this size: about 14 s and 0.5 GB).
MOST_CELLS = 2048 * 2048

#: Most (channel cell, neighbour) pairs a breach's gorge is widened over
#: at once (:func:`_widen`), and the widest reach (cells) widened so.
_CUT_CELLS = 1 << 18
_BATCH_REACH = 16

#: Most cells of a band of rows read, pooled or lowered at a time
#: (:func:`pooled_bands`, :meth:`Lowering.apply`).
BAND_CELLS = 1 << 22

#: Edge padding of the block grid before its spline filter, as
#: :func:`scipy.ndimage.zoom` pads for ``mode="nearest"``.
_SPLINE_PAD = 12

#: Width (cells) a painted ridge is drawn at as a wall.
WALL_WIDTH = 3

#: Percentile of the terrain's slopes that the walls of a gap cut through a
#: painted ridge (a basin of painted valleys opening) take, along its whole
#: path (the outflow beyond the ridge is a canyon too); other breaches'
#: walls take the 90th.  A gap as wide as a breach's on the 90th percentile
#: took 6-14 % of a ring's cells below the median height (Big Tujunga, the
#: Himalaya, St. Helens, four seeds each); at the 99.5th, 3-11 %.
GAP_SLOPE = 99.5

#: Rounds of :func:`drain_terrain`.
ROUNDS = 2

#: Narrowest half-width of a widened cut, cells.
MIN_HALF_WIDTH = 2.0

#: Least rise of a cut's walls above the channel, as a share of the steep
#: slope per cell of distance from it.
WALL_RISE = 0.1


class Breached(NamedTuple):
    """What :func:`breach_depressions` did."""

    heights: np.ndarray
    breached: int
    left: int


def breach_depressions(heights: np.ndarray, *, walls: np.ndarray | None = None,
                       locked: np.ndarray | None = None, outlets: np.ndarray | None = None,
                       drains: np.ndarray | None = None, min_depth: float = MIN_DEPTH) -> Breached:
    """Breach every closed depression deeper than ``min_depth`` of the relief.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres; not modified.
    walls : ndarray of bool, shape (rows, cols), optional
        Cells no breach may cross (painted ridges), but for a gap out of a
        depression that must drain (``drains``).
    locked : ndarray of bool, shape (rows, cols), optional
        Cells that must not change; no breach crosses them either.
    outlets : ndarray of bool, shape (rows, cols), optional
        Where water leaves besides the map's border (painted water).
    drains : ndarray of bool, shape (rows, cols), optional
        Cells that must drain (painted valleys; ignored without
        ``walls``).  A depression whose flooded cells hold one, and that
        the walls (not the locked cells) close in, is breached across
        them: the path of least cut that crosses no locked cell, its walls
        at the :data:`GAP_SLOPE` percentile of the slopes.  (A valley
        that ends above the depression's spill level does not count.)
    min_depth : float
        Shallowest depression breached, as a share of the relief.

    Returns
    -------
    Breached
        ``heights`` (float32, shape (rows, cols): lowered only, along the
        breaches and their walls; every other cell keeps its bytes), the
        number of depressions breached and of those left (no way out within
        :data:`MAX_MARGIN` cells, or only across a wall for a depression
        that need not drain).
    """
    h = np.array(heights, dtype=np.float64)
    rows, cols = h.shape
    if h.size == 0 or min(rows, cols) < 3:
        return Breached(h.astype(np.float32), 0, 0)
    relief = float(np.percentile(h, 99.5) - np.percentile(h, 0.5))
    if not np.isfinite(relief) or relief <= 0:
        return Breached(h.astype(np.float32), 0, 0)
    blocked = np.zeros(h.shape, bool)
    for mask in (walls, locked):
        if mask is not None:
            blocked |= mask
    frozen = locked if locked is not None and locked.any() else None
    eps = MIN_SLOPE * float(np.ptp(h))
    slopes = np.hypot(*np.gradient(h))
    steep, gap = (float(v) for v in np.percentile(slopes, [90, GAP_SLOPE]))
    if outlets is not None and not outlets.any():
        outlets = None
    lakes, pits = _depressions(h, min_depth * relief, outlets)
    objects = ndimage.find_objects(lakes)
    draining = set() if drains is None or walls is None else set(np.unique(lakes[drains]).tolist())
    # What a gap may not cross: only the locked cells.
    held = None if not draining else locked if locked is not None else np.zeros(h.shape, bool)
    step = 1e-3 * relief
    breached = left = 0
    # Lowest first: a higher depression's way out may run through a lower
    # one, which is open by then.
    for k in sorted(pits, key=lambda k: h[pits[k]]):
        pit, box = pits[k], objects[k - 1]
        path = None if blocked[pit] else _way_out(h, box, pit, blocked, outlets, step)
        # Walled in (or a wall's own pit): painted valleys drain, through a
        # gap; but where locked cells close the basin in (a re-synthesis's,
        # painted water's banks), it is left as before.
        gap_asked = (path is None and k in draining and not held[pit]
                     and (frozen is None or walls[pit] or _way_out(h, box, pit, walls, outlets, step) is None))
        if gap_asked:
            path = _way_out(h, box, pit, held, outlets, step)
        if path is None:
            left += int(not blocked[pit] or gap_asked)  # (else a locked cell's or a wall's own: not ours)
            continue
        _cut(h, path, eps, gap if gap_asked else steep, frozen)
        breached += 1
    return Breached(h.astype(np.float32), breached, left)


def _depressions(h: np.ndarray, min_depth: float, outlets: np.ndarray | None) -> tuple[np.ndarray, dict]:
    """The closed depressions of ``h`` deeper than ``min_depth`` metres,
    water leaving at the border and at ``outlets``.

    Returns
    -------
    lakes : ndarray of int32, shape (rows, cols)
        Labels of every depression (0: drained ground), 8-connected.
    pits : dict label -> (row, col)
        Lowest cell of each depression kept.
    """
    exits = np.zeros(h.shape, bool)
    exits[[0, -1], :] = True
    exits[:, [0, -1]] = True
    if outlets is not None:
        exits |= outlets
    filled = spill_levels(h, exits)
    lakes, n = ndimage.label(filled > h, structure=np.ones((3, 3), bool))
    if n == 0:
        return lakes, {}
    index = np.arange(1, n + 1)
    spill = np.asarray(ndimage.maximum(filled, lakes, index))
    floor = np.asarray(ndimage.minimum(h, lakes, index))
    deep = np.flatnonzero(spill - floor > min_depth)
    where = ndimage.minimum_position(h, lakes, index[deep])
    return lakes, {int(k + 1): w for k, w in zip(deep, where)}


def _way_out(h: np.ndarray, box: tuple[slice, slice], pit: tuple[int, int],
             blocked: np.ndarray, outlets: np.ndarray | None, step: float) -> np.ndarray | None:
    """The path from ``pit`` to the nearest cell lower than it (or the
    map's border, or an outlet) that needs the least total cut
    (:func:`~terrasynth_core.controls.drainage.least_cut_path`, ``step``
    metres a cell), searched in a window about the depression's ``box``
    that grows until it holds one.

    Returns
    -------
    ndarray of int, shape (n, 2), or None
        Cells (row, col) from the pit outward; None when there is no way
        out within :data:`MAX_MARGIN` cells.
    """
    rows, cols = h.shape
    floor = float(h[pit])
    margin = FIRST_MARGIN
    while margin <= MAX_MARGIN:
        a0, a1 = max(box[0].start - margin, 0), min(box[0].stop + margin, rows)
        b0, b1 = max(box[1].start - margin, 0), min(box[1].stop + margin, cols)
        window = h[a0:a1, b0:b1]
        free = ~blocked[a0:a1, b0:b1]
        ends = window < floor
        if outlets is not None:
            ends |= outlets[a0:a1, b0:b1]
        ends[0, :] |= a0 == 0
        ends[-1, :] |= a1 == rows
        ends[:, 0] |= b0 == 0
        ends[:, -1] |= b1 == cols
        ends &= free
        whole = a0 == 0 and b0 == 0 and a1 == rows and b1 == cols
        if ends.any():
            steps = least_cut_path(window, (pit[0] - a0, pit[1] - b0), floor, ends, step, passable=free,
                                   free_start=True)
            if steps is not None:
                return steps + (a0, b0)
        if whole:
            return None
        margin *= 2
    return None


def _cut(h: np.ndarray, path: np.ndarray, eps: float, steep: float, frozen: np.ndarray | None) -> None:
    """Cut ``path`` into ``h`` (in place) so that it descends from its first
    cell by at least ``eps`` a cell, widened into a gorge with walls no
    steeper than ``steep`` (metres a cell) and at least
    :data:`MIN_HALF_WIDTH` cells wide on either side."""
    rows, cols = h.shape
    rr, cc = path[:, 0], path[:, 1]
    s = np.arange(len(path)) * eps
    channel = np.minimum(h[rr, cc], float(h[rr[0], cc[0]]) - s)
    cut = h[rr, cc] - channel
    if not (cut > 0).any():
        return
    # Each cell near the channel is lowered by the largest of the channel
    # cells' cuts, each easing by a smoothstep of the distance to its cell
    # over twice that cut over the steep slope (the step's steepest slope is
    # 1.5 cut / width: three quarters of the steep slope); the largest, so
    # the lowering is continuous however the cut varies along the channel.
    # Never below the channel: a cell is lowered at most to the height of
    # the nearest channel cell plus a gentle rise, so the walls drain into
    # it instead of pitting beside it (a cell beside a deep cut through a
    # rim may lie far lower than the rim).
    half = np.maximum(MIN_HALF_WIDTH, 2.0 * cut / max(steep, 1e-9))
    reach = int(np.ceil(half.max())) + 1
    a0, a1 = max(int(rr.min()) - reach, 0), min(int(rr.max()) + reach + 1, rows)
    b0, b1 = max(int(cc.min()) - reach, 0), min(int(cc.max()) + reach + 1, cols)
    lower = np.zeros((a1 - a0, b1 - b0))
    above = np.full(lower.shape, np.inf)
    r = np.minimum(np.ceil(half), max(a1 - a0, b1 - b0)).astype(np.int64)  # (unbounded on flat ground)
    if int(r.max()) <= _BATCH_REACH:
        # Small squares (nearly every breach): many channel cells at once.
        step = max(1, _CUT_CELLS // (2 * int(r.max()) + 1) ** 2)
        for j in range(0, len(path), step):
            part = slice(j, j + step)
            _widen(lower, above, (a0, a1, b0, b1), rr[part], cc[part], r[part], cut[part], half[part],
                   channel[part], WALL_RISE * steep)
    else:
        # Wide squares (gentle ground): one channel cell at a time, on
        # slices (scattering them would cost more than the loop saves).
        for i in range(len(path)):
            y0, y1 = max(rr[i] - r[i], a0), min(rr[i] + r[i] + 1, a1)
            x0, x1 = max(cc[i] - r[i], b0), min(cc[i] + r[i] + 1, b1)
            d = np.hypot(*np.ogrid[y0 - rr[i]:y1 - rr[i], x0 - cc[i]:x1 - cc[i]])
            box = (slice(y0 - a0, y1 - a0), slice(x0 - b0, x1 - b0))
            drop, floor = _gorge(d, cut[i], half[i], channel[i], WALL_RISE * steep)
            if cut[i] > 0:
                np.maximum(lower[box], drop, out=lower[box])
            np.minimum(above[box], floor, out=above[box])
    window = h[a0:a1, b0:b1]
    walls = np.where(lower > 0, np.maximum(window - lower, np.minimum(above, window)), window)
    if frozen is not None:
        walls = np.where(frozen[a0:a1, b0:b1], window, walls)
    h[a0:a1, b0:b1] = walls
    # The channel itself, last: descending all the way (a wall's lowering
    # of another breach may have reached below it).
    here = np.minimum(h[rr, cc], channel)
    h[rr, cc] = np.minimum.accumulate(here + s) - s


def _widen(lower: np.ndarray, above: np.ndarray, window: tuple[int, int, int, int], rr: np.ndarray,
           cc: np.ndarray, r: np.ndarray, cut: np.ndarray, half: np.ndarray, channel: np.ndarray,
           rise: float) -> None:
    """:func:`_cut`'s gorge for channel cells ``(rr, cc)`` (reach ``r``
    cells, cut ``cut``, half-width ``half``, channel height ``channel``),
    in place on ``lower`` (largest lowering) and ``above`` (lowest wall
    height, ``rise`` metres a cell from the channel) over ``window``: each
    cell's square of reach as offsets from it (the widest square of all,
    cut to the window; the cells beyond a cell's own square left out),
    scattered by their largest and smallest."""
    a0, a1, b0, b1 = window
    top, bottom = max(-int(r.max()), a0 - int(rr.max())), min(int(r.max()), a1 - 1 - int(rr.min()))
    left, right = max(-int(r.max()), b0 - int(cc.max())), min(int(r.max()), b1 - 1 - int(cc.min()))
    dy, dx = (a.ravel() for a in np.mgrid[top:bottom + 1, left:right + 1])
    y, x = rr[:, None] + dy, cc[:, None] + dx
    near = ((np.abs(dy) <= r[:, None]) & (np.abs(dx) <= r[:, None])
            & (y >= a0) & (y < a1) & (x >= b0) & (x < b1))
    i, k = np.nonzero(near)
    d = np.hypot(dy[k].astype(np.float64), dx[k].astype(np.float64))
    cells = (y[i, k] - a0, x[i, k] - b0)
    drop, floor = _gorge(d, cut[i], half[i], channel[i], rise)
    deep = cut[i] > 0
    np.maximum.at(lower, (cells[0][deep], cells[1][deep]), drop[deep])
    np.minimum.at(above, cells, floor)


def _gorge(d, cut, half, channel, rise) -> tuple[np.ndarray, np.ndarray]:
    """At distance ``d`` (cells) from a channel cell cut ``cut`` metres
    deep: the lowering (the cut easing to 0 over the half-width ``half``)
    and the lowest the wall may go (the channel's height ``channel`` plus
    ``rise`` metres a cell)."""
    return cut * smoothstep(1.0 - d / half), channel + rise * d


def grid_factor(patch_size: int, shape: tuple[int, int] = (0, 0)) -> int:
    """The down-sampling :func:`drain_terrain` is run at for ``patch_size``
    on a map of ``shape`` cells: :data:`CELLS_PER_PATCH` cells a patch, or
    coarser on a map that would need more than :data:`MOST_CELLS` blocks
    (then about that many: the factor is rounded up, the blocks to whole
    ones)."""
    rows, cols = shape
    return max(1, int(patch_size) // CELLS_PER_PATCH, math.ceil(math.sqrt(rows * cols / MOST_CELLS)))


def coarse_grid(shape: tuple[int, int], factor: int) -> tuple[int, int]:
    """The block grid of ``shape`` at ``factor`` (a last, partial block
    counts whole)."""
    return -(-shape[0] // factor), -(-shape[1] // factor)


def block_pool(a: np.ndarray, factor: int, grid: tuple[int, int], how) -> np.ndarray:
    """``how`` (``np.mean``, ``np.any``) of each ``factor`` x ``factor``
    block of ``a``, its last rows and columns repeated to fill ``grid``
    whole blocks.

    Parameters
    ----------
    a : ndarray, shape (rows, cols)
        At most ``grid`` blocks.
    factor : int
    grid : (int, int)
    how : callable
        A numpy reduction taking ``axis``.

    Returns
    -------
    ndarray, shape ``grid``
    """
    pad = ((0, grid[0] * factor - a.shape[0]), (0, grid[1] * factor - a.shape[1]))
    return how(np.pad(a, pad, mode="edge").reshape(grid[0], factor, grid[1], factor), axis=(1, 3))


def pooled_bands(read, shape: tuple[int, int], factor: int, how) -> np.ndarray | None:
    """:func:`block_pool` of a map read band by band of whole blocks (about
    :data:`BAND_CELLS` cells a band, one row of blocks at least), so a
    large map is never held in float64: the same values as pooling it
    whole.

    Parameters
    ----------
    read : callable
        ``read((r0, r1, c0, c1))`` gives the map over a box of whole rows.
    shape : (rows, cols)
    factor : int
    how : callable
        ``np.mean`` or ``np.any``.

    Returns
    -------
    ndarray, shape ``coarse_grid(shape, factor)``, or None
        None for a boolean map that meets no block.
    """
    rows, cols = shape
    grid = coarse_grid(shape, factor)
    step = factor * max(1, BAND_CELLS // (factor * factor * max(grid[1], 1)))
    out = None
    for r0 in range(0, rows, step):
        r1 = min(r0 + step, rows)
        g0 = r0 // factor
        band = block_pool(read((r0, r1, 0, cols)), factor, (-(-r1 // factor) - g0, grid[1]), how)
        if out is None:
            out = np.empty(grid, band.dtype)
        out[g0:g0 + len(band)] = band
    return None if out.dtype == bool and not out.any() else out


def stroke_blocks(strokes: FeatureGraph | None, factor: int, grid: tuple[int, int],
                  width: int = WALL_WIDTH) -> np.ndarray | None:
    """The blocks of the coarse grid a painted stroke (drawn ``width``
    cells wide on the output's cells) meets: the breach's walls (ridges,
    :data:`WALL_WIDTH` wide) or the cells that must drain (valleys).

    Parameters
    ----------
    strokes : FeatureGraph or None
        In the output's cells.
    factor : int
    grid : (int, int)
        The block grid (:func:`coarse_grid`).
    width : int
        Cells, odd.

    Returns
    -------
    ndarray of bool, shape ``grid``, or None
        None without strokes.  The blocks ``block_pool(graph_mask(strokes,
        width=width), factor, grid, np.any)`` gives, from the lines' cells
        alone (a world-size map's mask would not fit).
    """
    cells = np.zeros((0, 2), np.int64) if strokes is None else graph_cells(strokes)
    if not len(cells):
        return None
    rows, cols = strokes.shape
    reach = width // 2
    # graph_mask's widening: ``reach`` steps to the four neighbours.
    near = [(dr, dc) for dr in range(-reach, reach + 1) for dc in range(-reach, reach + 1)
            if abs(dr) + abs(dc) <= reach]
    cells = np.concatenate([cells + d for d in near])
    cells = cells[(cells[:, 0] >= 0) & (cells[:, 0] < rows) & (cells[:, 1] >= 0) & (cells[:, 1] < cols)]
    blocks = np.zeros(grid, bool)
    blocks[cells[:, 0] // factor, cells[:, 1] // factor] = True
    return blocks


def drain_terrain(heights: np.ndarray, *, factor: int, ridges: FeatureGraph | None = None,
                  valleys: FeatureGraph | None = None, water: np.ndarray | None = None,
                  locked: np.ndarray | None = None) -> np.ndarray:
    """:func:`breach_depressions` on a grid ``factor`` times coarser,
    brought back as a smooth lowering.

    The depressions a finished terrain holds are patch-sized (50-100 cells
    across, up to a fifth of the relief deep): a grid four times coarser
    still holds them, and is breached in a fifth of the full grid's time
    (0.5 s against about 2.5 s at 1000x1000).  The change is brought up
    cubically and only lowers; cells within a coarse cell of a locked cell
    do not change.  A second round opens what the first left, seen anew on
    the lowered terrain's block means (White Mountains S-valley 1000x1000:
    13.4 % of cells in depressions deeper than 1 % of the relief, 2.7 %
    after one round, 0.7 % after two, 0.6 % after three).  A tiled run
    takes the same rounds over its finished tiles
    (:func:`terrasynth_core.tiled.drainage.breach_tiles`).

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Metres; not modified.
    factor : int
        The coarse grid's down-sampling (block means; 1: the full grid).
    ridges, valleys : FeatureGraph, optional
        The painted ridges and valleys, in the output's cells: walls, and
        what must drain through them (:func:`stroke_blocks`).
    water, locked : ndarray of bool, shape (rows, cols), optional
        Painted water (an outlet) and cells that must not change, as
        :func:`breach_depressions` takes them.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        Every cell not lowered keeps its bytes.
    """
    rows, cols = heights.shape
    out = heights

    def add(lowering: Lowering) -> None:
        nonlocal out
        if out is heights:
            out = heights.copy()  # (once: ``heights`` is the caller's)
        lowering.apply((0, rows, 0, cols), out)

    breach_in_rounds((rows, cols), factor, lambda box: out[box[0]:box[1], box[2]:box[3]], add, ridges=ridges,
                     valleys=valleys, water=None if water is None else ArrayMask(water),
                     locked=None if locked is None else ArrayMask(locked))
    return out


def breach_in_rounds(shape: tuple[int, int], factor: int, read, add, *, ridges: FeatureGraph | None,
                     valleys: FeatureGraph | None, water: Mask | None, locked: Mask | None) -> None:
    """:data:`ROUNDS` rounds of :func:`breach_round` on a map read band by
    band: the whole map's (:func:`drain_terrain`) or a tiled run's
    (:func:`terrasynth_core.tiled.drainage.breach_tiles`).

    Parameters
    ----------
    shape : (rows, cols)
        The output's cells.
    factor : int
        The block grid's down-sampling.
    read : callable
        ``read((r0, r1, 0, cols))``: the heights over a band of whole rows
        with every lowering added so far, float32.
    add : callable
        ``add(lowering)`` adds a round's :class:`Lowering` to what later
        reads give.
    ridges : FeatureGraph or None
        Painted ridges in output cells: walls.
    valleys : FeatureGraph or None
        Painted valleys in output cells: their depressions open through
        the walls.
    water, locked : Mask or None
        Painted water (an outlet) and cells that must not change.
    """
    f = max(1, int(factor))
    grid = coarse_grid(shape, f)
    if min(grid) < 3:
        return
    walls = stroke_blocks(ridges, f, grid)
    drains = None if walls is None else stroke_blocks(valleys, f, grid, width=1)
    water_blocks, held = (None if m is None else pooled_bands(m.window, shape, f, np.any) for m in (water, locked))
    if held is not None:
        # A block beside a locked one would bring a lowering into it.
        held = ndimage.binary_dilation(held, np.ones((3, 3), bool))
    for _ in range(ROUNDS):
        means = pooled_bands(lambda box: read(box).astype(np.float64), shape, f, np.mean)
        lowering = breach_round(means, f, walls=walls, water=water_blocks, held=held, locked=locked, drains=drains)
        if lowering is None:
            break
        add(lowering)


def breach_round(coarse: np.ndarray, factor: int, *, walls: np.ndarray | None,
                 water: np.ndarray | None, held: np.ndarray | None, locked: Mask | None,
                 drains: np.ndarray | None = None) -> "Lowering | None":
    """One round of :func:`drain_terrain`: the depressions of the block
    means ``coarse`` breached, as a :class:`Lowering` of the output's cells.

    Parameters
    ----------
    coarse : ndarray of float64, shape (g_rows, g_cols)
        The terrain's block means (:func:`block_pool`), metres.
    factor : int
    walls, water : ndarray of bool, shape (g_rows, g_cols), or None
        The blocks painted ridges and painted water meet.
    held : ndarray of bool, shape (g_rows, g_cols), or None
        Blocks that must not change (those locked cells meet, and their
        neighbours).
    locked : Mask or None
        The output's locked cells.
    drains : ndarray of bool, shape (g_rows, g_cols), optional
        The blocks painted valleys meet: their depressions open through
        the walls (:func:`breach_depressions`).

    Returns
    -------
    Lowering or None
        None when no depression was breached.
    """
    done = breach_depressions(coarse, walls=walls, outlets=water, locked=held, drains=drains)
    if done.breached == 0:
        return None
    # Shifted by a ten-thousandth of the relief, where the cubic's ringing
    # far from a breach asks for less (not cut off: no step where the
    # lowering starts).
    return Lowering(done.heights.astype(np.float64) - coarse, factor, 1e-4 * float(np.ptp(coarse)), locked)


class Lowering:
    """A breach round's change on the block grid, brought to the output's
    cells by cubic interpolation at their centres, over any box: only
    lowering, by at least ``tol`` less than asked, nowhere on locked cells.

    The cubic spline's coefficients are made once for the whole block grid
    (as :func:`scipy.ndimage.zoom` makes them, its edge padded by
    :data:`_SPLINE_PAD`), so a box's values are the whole map's to the bit.
    They are evaluated one axis after the other, each fine row and column
    four weights (a thin sparse matrix): the values of zoom's cubic
    interpolation (to 1e-12 of the change) at a tenth of its time.

    Parameters
    ----------
    change : ndarray of float64, shape (g_rows, g_cols)
        Metres, at most 0 where the breach lowered.
    factor : int
    tol : float
        Metres.
    locked : Mask or None
    """

    def __init__(self, change: np.ndarray, factor: int, tol: float, locked: Mask | None):
        self.factor, self.tol, self.locked = factor, tol, locked
        self.coeffs = change if factor == 1 else \
            ndimage.spline_filter(np.pad(change, _SPLINE_PAD, mode="edge"), 3, mode="nearest")

    def _taps(self, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The first of the four coefficients each fine cell of ``cells``
        (along one axis) reads, and their cubic B-spline weights, shape
        (n, 4): the cell's centre on the padded block grid, as zoom maps it."""
        x = (cells + 0.5) * (1.0 / self.factor) - 0.5 + _SPLINE_PAD
        first = np.floor(x)
        t = x - first
        u = 1.0 - t
        weights = np.stack([u * u * u / 6.0, (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0,
                            (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0, t * t * t / 6.0], axis=1)
        return first.astype(np.int64) - 1, weights

    def _matrix(self, cells: np.ndarray) -> tuple[sparse.csr_matrix, int, int]:
        """The weights of ``cells`` (along one axis) as a sparse matrix on
        the coefficients they read (``lo:hi``)."""
        first, weights = self._taps(cells)
        lo, hi = int(first.min()), int(first.max()) + 4
        cols = (first - lo)[:, None] + np.arange(4)
        matrix = sparse.csr_matrix((weights.ravel(), cols.ravel(), np.arange(0, 4 * len(cells) + 1, 4)),
                                   shape=(len(cells), hi - lo))
        return matrix, lo, hi

    def _at_grid(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """The interpolated change at the cells ``rows`` x ``cols``."""
        if self.factor == 1:
            return self.coeffs[np.ix_(rows, cols)]
        if not len(rows) or not len(cols):
            return np.zeros((len(rows), len(cols)))
        wr, r0, r1 = self._matrix(rows)
        wc, c0, c1 = self._matrix(cols)
        # Rows first, then columns: each sum taken in tap order (as :meth:`at`).
        return np.asarray((wc @ (wr @ self.coeffs[r0:r1, c0:c1]).T).T)

    def over(self, box: tuple[int, int, int, int]) -> np.ndarray:
        """The lowering over ``box`` (output cells), float64 metres, at
        most 0."""
        r0, r1, c0, c1 = box
        lower = np.minimum(self._at_grid(np.arange(r0, r1), np.arange(c0, c1)) + self.tol, 0.0)
        if self.locked is not None:
            lower[self.locked.window(box)] = 0.0
        return lower

    def at(self, rr: np.ndarray, cc: np.ndarray) -> np.ndarray:
        """The lowering at cells ``(rr, cc)`` (integer arrays of one
        shape), float64 metres."""
        rr, cc = np.asarray(rr, np.int64), np.asarray(cc, np.int64)
        if self.factor == 1:
            change = self.coeffs[rr, cc]
        else:
            (fr, wr), (fc, wc) = self._taps(rr.ravel()), self._taps(cc.ravel())
            change = np.zeros(rr.size)
            for b in range(4):
                down = np.zeros(rr.size)
                for a in range(4):
                    down += wr[:, a] * self.coeffs[fr + a, fc + b]
                change += wc[:, b] * down
            change = change.reshape(rr.shape)
        lower = np.minimum(change + self.tol, 0.0)
        if self.locked is not None:
            lower[self.locked.at(rr, cc)] = 0.0
        return lower

    def apply_at(self, rr: np.ndarray, cc: np.ndarray, heights: np.ndarray) -> np.ndarray:
        """``heights`` (float32, at cells ``(rr, cc)``) lowered, in place and
        returned: :meth:`apply` cell by cell."""
        return _lowered(heights, self.at(rr, cc))

    def apply(self, box: tuple[int, int, int, int], heights: np.ndarray) -> np.ndarray:
        """``heights`` (float32, over ``box``) lowered, in place and
        returned; cells not lowered keep their bytes.  (A band of rows at a
        time: the float64 lowering of a large map is never held whole.)"""
        r0, r1, c0, c1 = box
        step = max(1, BAND_CELLS // max(c1 - c0, 1))
        for a in range(r0, r1, step):
            b = min(a + step, r1)
            _lowered(heights[a - r0:b - r0], self.over((a, b, c0, c1)))
        return heights


def _lowered(heights: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """``heights`` (float32) plus ``lower`` (float64, at most 0) where it
    is below 0, in place: the other cells keep their bytes."""
    moved = lower < 0
    heights[moved] = (heights[moved] + lower[moved]).astype(np.float32)
    return heights

