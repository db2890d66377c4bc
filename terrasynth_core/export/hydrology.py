"""Where water runs: depression filling, D8 flow directions, flow accumulation.

A mask maker's hydrology, not a hydrologist's: enough to paint river beds
and wet hollows on a terrain (World Machine's and Gaea's flow maps).  Our
own, in numpy and scikit-image, because the libraries that do it either
are GPL (richdem, a benchmark-only dependency here), break on numpy 2
(pysheds) or download a binary at run time (whitebox).

1. **Fill**: every depression is raised to its spill height by morphological
   reconstruction by erosion from the grid's edge and its nodata (Soille
   2004, equivalent to a priority-flood fill without epsilon; scikit-image,
   in C).
2. **D8**: every cell drains to its steepest lower neighbour (drop over
   distance, diagonals at sqrt 2).
3. **Flats** (filled lakes, plateaus) are drained towards their outlets:
   a cell without a lower neighbour follows the shortest path inside its
   flat to a cell that spills (scikit-image's minimum-cost path search,
   Dijkstra in C), so water crosses a lake instead of stopping on it.
4. **Accumulation**: cells are visited from upstream to downstream (by
   filled height, then by distance to the flat's outlet) and each passes
   its count to its receiver.

References
----------
Soille, P. (2004). Optimal removal of spurious pits in grid digital
elevation models. Water Resources Research 40(12).
O'Callaghan, J. F., Mark, D. M. (1984). The extraction of drainage networks
from digital elevation data. CVGIP 28(3) (D8).
"""

from __future__ import annotations

import numpy as np
from skimage.graph import MCP_Geometric
from skimage.morphology import reconstruction

#: The 8 neighbours as (row, col) offsets.
_NEIGHBOURS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def fill_depressions(heights: np.ndarray) -> np.ndarray:
    """Heights with every pit raised to the level where it spills.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres; NaN cells are nodata, where water leaves the grid as at its
        edge.

    Returns
    -------
    ndarray of float64, shape (rows, cols)
        Filled heights (never lower than the input); NaN kept.
    """
    nodata = np.isnan(heights)
    h = np.where(nodata, -np.inf, heights).astype(np.float64)
    top = float(np.nanmax(heights)) if (~nodata).any() else 0.0
    lowest = float(np.nanmin(heights)) if (~nodata).any() else 0.0
    h[nodata] = lowest - 1.0
    seed = np.full(h.shape, top, dtype=np.float64)
    edge = np.zeros(h.shape, dtype=bool)
    edge[0, :] = edge[-1, :] = edge[:, 0] = edge[:, -1] = True
    edge |= nodata
    seed[edge] = h[edge]
    filled = reconstruction(seed, h, method="erosion")
    filled[nodata] = np.nan
    return filled


def flow_receivers(filled: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """D8 receiver of every cell of a depression-filled grid.

    Parameters
    ----------
    filled : ndarray of float, shape (rows, cols)
        From :func:`fill_depressions`; NaN = nodata.

    Returns
    -------
    receiver : ndarray of int64, shape (rows * cols,)
        Flat index of the cell each cell drains to; -1 where water leaves
        the grid: the outside and nodata count as lower than anything, so
        edge cells and cells next to nodata drain out (as RichDEM's D8
        does), and nodata itself is -1.
    flat_distance : ndarray of float64, shape (rows * cols,)
        Path length in cells to the flat's outlet for cells drained across
        a flat, -1 for the others (orders the accumulation).
    """
    rows, cols = filled.shape
    nodata = np.isnan(filled)
    h = np.where(nodata, -np.inf, filled)
    padded = np.pad(h, 1, constant_values=-np.inf)  # outside the grid: a sink
    best_drop = np.zeros(h.shape)
    best = np.full(h.shape, -1, dtype=np.int64)
    index = np.arange(rows * cols).reshape(rows, cols)
    padded_index = np.pad(index, 1, constant_values=-1)
    for dr, dc in _NEIGHBOURS:
        neighbour = padded[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols]
        neighbour_index = padded_index[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols]
        with np.errstate(invalid="ignore"):
            drop = (h - neighbour) / np.hypot(dr, dc)
        drop = np.where(np.isinf(neighbour), np.inf, drop)  # off the grid or into nodata
        better = drop > best_drop
        best_drop = np.where(better, drop, best_drop)
        best = np.where(better, neighbour_index, best)
    drains = best_drop > 0
    receiver = np.where(drains, best, -1).ravel()
    receiver[nodata.ravel()] = -1

    # Flats: cells without a lower neighbour, drained along the shortest path
    # inside the flat to one next to a draining cell of the same height.
    stuck = ~drains & ~nodata
    flat_distance = np.full(rows * cols, -1.0)
    if stuck.any():
        # A stuck cell next to a draining cell of the same height spills into it.
        spill_to = np.full(h.shape, -1, dtype=np.int64)
        padded_drains = np.pad(drains, 1, constant_values=False)
        for dr, dc in _NEIGHBOURS:
            neighbour = padded[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols]
            exit_ = (neighbour == h) & padded_drains[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols] & stuck
            spill_to = np.where(exit_ & (spill_to < 0), padded_index[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols],
                                spill_to)
        spill = spill_to >= 0
        # On a flat touching the grid's edge, the edge is an outlet too.
        edge = np.zeros(h.shape, dtype=bool)
        edge[0, :] = edge[-1, :] = edge[:, 0] = edge[:, -1] = True
        outlets = spill | (stuck & edge)
        starts = np.argwhere(outlets)
        if len(starts):
            mcp = MCP_Geometric(np.where(stuck, 1.0, -1.0))
            cost, traceback = mcp.find_costs([tuple(p) for p in starts])
            offsets = np.asarray(mcp.offsets)
            inner = stuck & ~outlets & (traceback >= 0)
            r, c = np.nonzero(inner)
            step = offsets[traceback[r, c]]
            receiver[index[r, c]] = index[r - step[:, 0], c - step[:, 1]]
            sr, sc = np.nonzero(spill)
            receiver[index[sr, sc]] = spill_to[sr, sc]
            reached = stuck & np.isfinite(cost)
            flat_distance[reached.ravel()] = cost[reached]
    return receiver, flat_distance


def flow_accumulation(heights: np.ndarray) -> np.ndarray:
    """Number of cells draining through each cell (itself included).

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres, NaN = nodata.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        At least 1 at valid cells; NaN at nodata.
    """
    filled = fill_depressions(heights)
    receiver, flat_distance = flow_receivers(filled)
    nodata = np.isnan(filled).ravel()
    # Upstream first: higher filled height, then further from the flat's outlet.
    order = np.lexsort((-flat_distance, -np.nan_to_num(filled.ravel(), nan=-np.inf)))
    order = order[~nodata[order]]
    counts = np.ones(filled.size, dtype=np.float64)
    # A chain of receivers is sequential; a Python loop over lists is about
    # 0.3 s per million cells.
    acc = counts.tolist()
    rec = receiver.tolist()
    for i in order.tolist():
        r = rec[i]
        if r >= 0:
            acc[r] += acc[i]
    out = np.asarray(acc, dtype=np.float32).reshape(heights.shape)
    out[nodata.reshape(heights.shape)] = np.nan
    return out
