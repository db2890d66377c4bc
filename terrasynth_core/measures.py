"""Terrain measures: surface gradient, slope, topographic position.

Used to check that extracted features sit where they should (ridges above
their surroundings, a positive topographic position index; valleys below, a
negative one) and, through :func:`surface_gradient`, by the hillshade of
:mod:`terrasynth_core.pictures`.

All functions accept a 2-D height array in metres (NaN = nodata) or a
:class:`~terrasynth_core.heightfield.HeightField`, never modify it, treat
nodata so that it does not spread into valid neighbours, and return float32
grids of the input's shape with NaN at nodata cells.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from .errors import ParamsError
from .features.graph import FeatureGraph
from .features.network import graph_mask
from .heightfield import HeightField, height_grid


def _heights_and_cell_size(heights, cell_size) -> tuple[np.ndarray, tuple[float, float]]:
    """The float32 heights and ``(dy, dx)`` of an array or HeightField.

    ``cell_size`` wins over the HeightField's own; without either, cells are
    1 height unit wide.
    """
    if cell_size is None and isinstance(heights, HeightField):
        cell_size = heights.cell_size
    h = height_grid(heights)
    if cell_size is None:
        cell = (1.0, 1.0)
    elif np.isscalar(cell_size):
        cell = (float(cell_size), float(cell_size))
    else:
        cell = tuple(float(v) for v in cell_size)
    if len(cell) != 2 or not all(math.isfinite(v) and v > 0 for v in cell):
        raise ParamsError(f"cell_size must be a positive number or (dy, dx) pair, got {cell_size!r}")
    return h, cell


def _fill_nodata(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heights with nodata replaced by the nearest valid height, and the
    nodata mask; keeps NaN out of neighbourhood operations."""
    nodata = np.isnan(h)
    if not nodata.any():
        return h, nodata
    if nodata.all():
        raise ParamsError("heights have no valid cell: every cell is NaN")
    index = ndimage.distance_transform_edt(nodata, return_distances=False, return_indices=True)
    return h[tuple(index)], nodata


def surface_gradient(heights, *, cell_size=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Height change per metre along rows and columns.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
        Heights in metres, NaN = nodata.
    cell_size : float, (dy, dx) or None
        Cell size in metres; None takes the HeightField's, else 1.

    Returns
    -------
    dz_drow, dz_dcol : ndarray of float32, shape (rows, cols)
        Metres per metre; rows run south, so ``-dz_drow`` is the northward
        slope.  Nodata cells take their nearest valid height first, so their
        neighbours' gradients stay finite.
    nodata : ndarray of bool, shape (rows, cols)
    """
    h, cell = _heights_and_cell_size(heights, cell_size)
    filled, nodata = _fill_nodata(h)
    dz_drow, dz_dcol = np.gradient(filled.astype(np.float32), cell[0], cell[1])
    return dz_drow, dz_dcol, nodata


def slope(heights, *, cell_size=None) -> np.ndarray:
    """Slope angle of every cell.

    Parameters
    ----------
    heights, cell_size
        As in :func:`surface_gradient`.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        Degrees from 0 (flat) to 90; NaN at nodata cells.
    """
    dz_drow, dz_dcol, nodata = surface_gradient(heights, cell_size=cell_size)
    out = np.degrees(np.arctan(np.hypot(dz_drow, dz_dcol))).astype(np.float32)
    out[nodata] = np.nan
    return out


def _disc(radius: float, inner_radius: float) -> np.ndarray:
    """Float kernel: 1 where ``inner_radius < distance <= radius``."""
    r = int(math.floor(radius))
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    d = np.hypot(yy, xx)
    return ((d <= radius) & (d > inner_radius)).astype(np.float64)


def topographic_position_index(heights, *, radius: float, inner_radius: float = 0.0) -> np.ndarray:
    """Height of each cell above the mean of its surroundings.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
        Heights in metres, NaN = nodata.
    radius : float
        Outer radius of the neighbourhood in cells, at least 1.
    inner_radius : float, default 0
        Cells closer than or at this distance are left out (an annulus);
        0 leaves out only the centre cell.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        ``z - mean(z over the valid neighbours)`` in metres: positive on
        ridges and peaks, negative in valleys.  NaN at nodata cells and where
        no neighbour is valid.

    Notes
    -----
    The neighbourhood sums are FFT convolutions of the valid heights and of
    the valid mask, so the cost does not grow with the radius and nodata is
    simply left out of the mean.
    """
    if not (isinstance(radius, (int, float, np.integer, np.floating)) and 1 <= radius <= 10_000):
        raise ParamsError(f"radius must be a number of cells from 1 to 10000, got {radius!r}")
    if not 0 <= inner_radius < radius:
        raise ParamsError(f"inner_radius must be from 0 to below radius {radius}, got {inner_radius!r}")
    h, _ = _heights_and_cell_size(heights, None)
    valid = ~np.isnan(h)
    if not valid.any():
        raise ParamsError("heights have no valid cell: every cell is NaN")
    # Centring on the mean keeps the float64 FFT sums precise.
    centred = np.where(valid, h - np.nanmean(h), 0.0).astype(np.float64)
    kernel = _disc(float(radius), float(inner_radius))
    # Imported here: scipy.signal pulls in scipy.stats, 40 % of a cold
    # start's imports, for this one function.
    from scipy.signal import fftconvolve

    total = fftconvolve(centred, kernel, mode="same")
    count = fftconvolve(valid.astype(np.float64), kernel, mode="same")
    count = np.rint(count)
    with np.errstate(invalid="ignore", divide="ignore"):
        tpi = centred - total / count
    tpi[~valid | (count < 1)] = np.nan
    return tpi.astype(np.float32)


def feature_tpi_score(heights, graph: FeatureGraph, *, radius: float) -> float:
    """How far above (ridges) or below (valleys) its surroundings a graph runs.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
        The grid the graph was extracted from.
    graph : FeatureGraph
        Ridges or valleys with ``graph.shape == heights.shape``.
    radius : float
        TPI radius in cells (see :func:`topographic_position_index`); choose
        it independently of the extraction's own scale.

    Returns
    -------
    float
        Mean TPI over the cells the paths pass, divided by the standard
        deviation of TPI over the whole grid: clearly positive for ridges,
        clearly negative for valleys.  NaN for a graph without paths.
    """
    h, _ = _heights_and_cell_size(heights, None)
    if tuple(graph.shape) != h.shape:
        raise ParamsError(f"graph shape {tuple(graph.shape)} does not match heights shape {h.shape}")
    if not graph.paths:
        return float("nan")
    tpi = topographic_position_index(h, radius=radius)
    on_path = graph_mask(graph) & ~np.isnan(tpi)
    if not on_path.any():
        return float("nan")
    return float(np.mean(tpi[on_path], dtype=np.float64) / np.nanstd(tpi, dtype=np.float64))
