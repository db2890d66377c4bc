"""Terrain analysis helpers: hillshade, slope, topographic position.

Used to draw DEMs (hillshade under feature overlays) and to check that
extracted features sit where they should: ridges above their surroundings
(positive topographic position index), valleys below (negative).

All functions accept a 2-D height array in metres (NaN = nodata) or a
:class:`~terrasynth_core.heightfield.HeightField`, never modify it, treat
nodata so that it does not spread into valid neighbours, and return float32
grids of the input's shape with NaN at nodata cells.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage, signal

from .errors import ParamsError
from .features.graph import FeatureGraph
from .features.network import graph_mask
from .heightfield import HeightField


def _heights_and_cell_size(heights, cell_size) -> tuple[np.ndarray, tuple[float, float]]:
    """The float32 heights and ``(dy, dx)`` of an array or HeightField.

    ``cell_size`` wins over the HeightField's own; without either, cells are
    1 height unit wide.
    """
    if isinstance(heights, HeightField):
        if cell_size is None:
            cell_size = heights.cell_size
        heights = heights.heights
    h = np.asarray(heights)
    if h.ndim != 2 or min(h.shape) < 2:
        raise ParamsError(f"heights must be a 2-D grid of at least 2x2 cells, got shape {h.shape}")
    if not (np.issubdtype(h.dtype, np.floating) or np.issubdtype(h.dtype, np.integer)):
        raise ParamsError(f"heights must be numeric, got dtype {h.dtype}")
    h = h.astype(np.float32, copy=False)
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


def _gradient(h: np.ndarray, cell: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(dz/drow, dz/dcol)`` in metres per metre and the nodata mask."""
    filled, nodata = _fill_nodata(h)
    dz_drow, dz_dcol = np.gradient(filled.astype(np.float32), cell[0], cell[1])
    return dz_drow, dz_dcol, nodata


def slope(heights, *, cell_size=None) -> np.ndarray:
    """Slope angle of every cell.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
        Heights in metres, NaN = nodata.
    cell_size : float, (dy, dx) or None
        Cell size in metres; None takes the HeightField's, else 1.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        Degrees from 0 (flat) to 90; NaN at nodata cells.
    """
    h, cell = _heights_and_cell_size(heights, cell_size)
    dz_drow, dz_dcol, nodata = _gradient(h, cell)
    out = np.degrees(np.arctan(np.hypot(dz_drow, dz_dcol))).astype(np.float32)
    out[nodata] = np.nan
    return out


def slope_statistics(heights, *, cell_size=None) -> dict[str, float]:
    """Summary of the slope distribution over the valid cells.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
    cell_size : float, (dy, dx) or None
        As in :func:`slope`.

    Returns
    -------
    dict
        ``mean``, ``std``, ``median`` and ``p90`` of the slope in degrees.
    """
    s = slope(heights, cell_size=cell_size)
    valid = s[~np.isnan(s)].astype(np.float64)
    return {
        "mean": float(valid.mean()),
        "std": float(valid.std()),
        "median": float(np.median(valid)),
        "p90": float(np.percentile(valid, 90)),
    }


def hillshade(heights, *, cell_size=None, azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
    """Lambertian shading of the terrain under a distant light.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
        Heights in metres, NaN = nodata.
    cell_size : float, (dy, dx) or None
        Cell size in metres; None takes the HeightField's, else 1.
    azimuth : float, default 315
        Direction the light comes from, degrees clockwise from north (315 =
        north-west, the cartographic convention).
    altitude : float, default 45
        Light elevation above the horizon in degrees, 0 to 90.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        Brightness in [0, 1] at valid cells, NaN at nodata cells.
    """
    if not 0.0 <= altitude <= 90.0:
        raise ParamsError(f"altitude must be from 0 to 90 degrees, got {altitude}")
    h, cell = _heights_and_cell_size(heights, cell_size)
    dz_drow, dz_dcol, nodata = _gradient(h, cell)
    az, alt = math.radians(azimuth), math.radians(altitude)
    # Unit light vector in (east, north, up); rows run south, so north = -row.
    light = (math.sin(az) * math.cos(alt), math.cos(az) * math.cos(alt), math.sin(alt))
    dz_deast, dz_dnorth = dz_dcol, -dz_drow
    shade = (-dz_deast * light[0] - dz_dnorth * light[1] + light[2]) / np.sqrt(
        1.0 + dz_deast**2 + dz_dnorth**2
    )
    out = np.clip(shade, 0.0, 1.0).astype(np.float32)
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
    total = signal.fftconvolve(centred, kernel, mode="same")
    count = signal.fftconvolve(valid.astype(np.float64), kernel, mode="same")
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
