"""Masks (splat maps) of a terrain: what texturing tools paint with.

Every mask is a float32 grid in [0, 1] of the heightmap's shape (a few
have channels), made from heights in metres and the cell size, so the same
terrain gives the same masks at any resolution:

=============  ========  ==========================================================
name           channels  value
=============  ========  ==========================================================
slope          1         slope angle / 90 degrees
convex         1         convex curvature (ridges, crests), scaled
concave        1         concave curvature (gullies, valley floors), scaled
flow           1         log(1 + upstream cells) / log(1 + all cells)
wetness        1         topographic wetness index ln(a / tan b), scaled
water          1         1 where there is water (given, or at/below sea level)
height_bands   4 (RGBA)  soft low / mid / high / peak bands, summing to 1
normal         3 (RGB)   tangent-space normal, (n + 1) / 2, OpenGL (green = north)
style_regions  1         uint8 style id + 1 (0: no style), only when given
=============  ========  ==========================================================

Style regions exist only where the caller has them (the app's painted
style layer); a DEM file carries none, so the CLI makes no such mask.

Curvature and wetness are scaled by their 99th percentile over the
terrain (the scale is returned, so the numbers can be recovered).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from ..errors import ParamsError
from ..heightfield import HeightField
from ..measures import surface_gradient
from .hydrology import flow_accumulation

#: Masks :func:`terrain_masks` makes, in order.
MASK_NAMES = ("slope", "convex", "concave", "flow", "wetness", "water", "height_bands", "normal")

#: Number of height bands.
BANDS = 4

#: Curvature (1/m) below which ground counts as flat for the scale.
MIN_CURVATURE = 1e-6

#: Smallest slope tangent in the wetness index (flat ground would divide by 0).
MIN_TAN_SLOPE = 1e-3


@dataclass(frozen=True)
class TerrainMasks:
    """The masks of one terrain.

    Attributes
    ----------
    masks : dict of str to ndarray
        name -> float32 array in [0, 1], shape (rows, cols) or
        (rows, cols, channels); see the module table.
    scales : dict of str to float
        What 1.0 stands for in the scaled masks (``convex``/``concave``:
        1/m; ``wetness``: the index; ``flow``: cells).
    notes : list of str
        Masks left out and why (e.g. no water).
    cell_size : (dy, dx)
        Metres, of the grid the masks were made on.
    """

    masks: dict = field(default_factory=dict)
    scales: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    cell_size: tuple[float, float] = (1.0, 1.0)


def _robust_scale(values: np.ndarray, floor: float = 0.0) -> float:
    """The 99th percentile of the positive ``values``, at least ``floor`` (1 when there are none)."""
    positive = values[np.isfinite(values) & (values > 0)]
    return max(float(np.percentile(positive, 99)), floor) if positive.size else 1.0


def curvature(heights: np.ndarray, cell_size: tuple[float, float]) -> np.ndarray:
    """Laplacian of the heights, 1/m: positive in hollows, negative on crests.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Metres, no NaN (fill first).
    cell_size : (dy, dx)
        Metres.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        ``d2z/dy2 + d2z/dx2`` (the mean curvature times 2 for gentle slopes).
    """
    dy, dx = cell_size
    # A light smoothing first: the second difference of a DEM is mostly noise.
    # Odd reflection continues slopes past the edges, so planes stay planes.
    pad = 4
    padded = np.pad(heights.astype(np.float64), pad, mode="reflect", reflect_type="odd")
    h = ndimage.gaussian_filter(padded, 1.0, mode="nearest")[pad:-pad, pad:-pad]
    d2y = (np.roll(h, -1, 0) + np.roll(h, 1, 0) - 2 * h) / dy**2
    d2x = (np.roll(h, -1, 1) + np.roll(h, 1, 1) - 2 * h) / dx**2
    d2y[0] = d2y[1]
    d2y[-1] = d2y[-2]
    d2x[:, 0] = d2x[:, 1]
    d2x[:, -1] = d2x[:, -2]
    return (d2y + d2x).astype(np.float32)


def height_bands(heights: np.ndarray, *, bands: int = BANDS) -> np.ndarray:
    """Soft elevation bands: tent functions over the height range.

    Returns
    -------
    ndarray of float32, shape (rows, cols, bands)
        Band ``k`` peaks at the fraction ``k / (bands - 1)`` of the range;
        the bands of a cell sum to 1.
    """
    lo, hi = float(np.nanmin(heights)), float(np.nanmax(heights))
    t = (np.nan_to_num(heights, nan=lo) - lo) / max(hi - lo, 1e-9) * (bands - 1)
    out = np.stack([np.clip(1 - np.abs(t - k), 0, 1) for k in range(bands)], axis=-1)
    return out.astype(np.float32)


def normal_map(heights: np.ndarray, cell_size: tuple[float, float]) -> np.ndarray:
    """Tangent-space normals of the terrain seen from above, encoded as colours.

    Returns
    -------
    ndarray of float32, shape (rows, cols, 3)
        ``(n + 1) / 2`` with ``n = normalize(-dz/dx_east, -dz/dy_north, 1)``:
        red east, green north (the OpenGL convention; Unreal and DirectX
        engines flip green), blue up.
    """
    dz_drow, dz_dcol, _ = surface_gradient(heights, cell_size=cell_size)
    nx, ny = -dz_dcol, dz_drow  # north is -row, so -dz/dnorth = +dz/drow
    length = np.sqrt(nx**2 + ny**2 + 1.0)
    n = np.stack([nx / length, ny / length, 1.0 / length], axis=-1)
    return ((n + 1.0) / 2.0).astype(np.float32)


def terrain_masks(field: HeightField, *, water: np.ndarray | None = None, sea_level: float = 0.0,
                  style_ids: np.ndarray | None = None, names: tuple[str, ...] = MASK_NAMES) -> TerrainMasks:
    """Every mask of ``field`` (see the module table).

    Parameters
    ----------
    field : HeightField
        Heights in metres; nodata is filled from its neighbours for the
        masks (and is 0 in the single-channel masks).  Without a cell size
        cells are taken as 1 m (a note says so).
    water : ndarray of bool, shape (rows, cols), optional
        Where there is water (a result's water layer).  Without it, water is
        the cells at or below ``sea_level``; with none, the mask is left out.
    sea_level : float, default 0
        Metres.
    style_ids : ndarray of int, shape (rows, cols), optional
        Style region id per cell (-1 for none, at most 254): adds the
        ``style_regions`` mask (uint8, id + 1).
    names : tuple of str
        Which masks to make, from :data:`MASK_NAMES`.

    Returns
    -------
    TerrainMasks

    Raises
    ------
    ParamsError
        An unknown mask name, a water mask of another shape, a sea level
        that is not a finite height.
    """
    unknown = [n for n in names if n not in MASK_NAMES]
    if unknown:
        raise ParamsError(f"unknown mask {unknown[0]!r}; expected some of {', '.join(MASK_NAMES)}")
    if not np.isfinite(sea_level):
        raise ParamsError(f"sea level must be a finite height in metres, got {sea_level}")
    notes = []
    cell_size = field.cell_size
    if cell_size is None:
        cell_size = (1.0, 1.0)
        notes.append("the DEM has no cell size: cells taken as 1 m (slope, curvature and wetness follow)")
    nodata = field.nodata
    heights = field.fill_nodata().heights
    masks, scales = {}, {}
    slope_tan = None
    if {"slope", "wetness"} & set(names):
        dz_drow, dz_dcol, _ = surface_gradient(heights, cell_size=cell_size)
        slope_tan = np.hypot(dz_drow, dz_dcol)
    if "slope" in names:
        masks["slope"] = (np.degrees(np.arctan(slope_tan)) / 90.0).astype(np.float32)
        scales["slope"] = 90.0
    if {"convex", "concave"} & set(names):
        lap = curvature(heights, cell_size)
        for name, values in (("convex", -lap), ("concave", lap)):
            if name in names:
                # Floor: rounding noise on a plane is no curvature (1e-6/m is a
                # radius of 1000 km).
                scale = _robust_scale(values, MIN_CURVATURE)
                masks[name] = np.clip(values / scale, 0, 1).astype(np.float32)
                scales[name] = scale
    if {"flow", "wetness"} & set(names):
        acc = flow_accumulation(np.where(nodata, np.nan, heights))
        acc = np.nan_to_num(acc, nan=1.0)
        if "flow" in names:
            masks["flow"] = (np.log1p(acc) / math.log1p(acc.size)).astype(np.float32)
            scales["flow"] = float(acc.size)
        if "wetness" in names:
            # Specific catchment area: upstream area per unit contour width.
            area = acc * (cell_size[0] * cell_size[1]) / math.sqrt(cell_size[0] * cell_size[1])
            twi = np.log(area / np.maximum(slope_tan, MIN_TAN_SLOPE))
            lo = float(np.percentile(twi, 1))
            scale = max(_robust_scale(twi - lo), 1e-6)
            masks["wetness"] = np.clip((twi - lo) / scale, 0, 1).astype(np.float32)
            scales["wetness"] = scale
            scales["wetness_offset"] = lo
    if "water" in names:
        if water is not None:
            water = np.asarray(water, dtype=bool)
            if water.shape != field.shape:
                raise ParamsError(f"water mask of shape {water.shape} does not match the terrain's {field.shape}")
            masks["water"] = water.astype(np.float32)
        elif (field.heights[~nodata] <= sea_level).any():
            masks["water"] = ((field.heights <= sea_level) & ~nodata).astype(np.float32)
            notes.append(f"water: the cells at or below sea level ({sea_level:g} m); the DEM holds no water layer")
        else:
            notes.append(f"water: left out: the DEM holds no water layer and no cell is at or below "
                         f"sea level ({sea_level:g} m)")
    if "height_bands" in names:
        masks["height_bands"] = height_bands(heights)
        scales["height_bands_range"] = [field.min, field.max]
    if "normal" in names:
        masks["normal"] = normal_map(heights, cell_size)
    for name, mask in masks.items():
        if mask.ndim == 2 and name != "water":
            mask[nodata] = 0
    if style_ids is not None:
        ids = np.asarray(style_ids)
        if ids.shape != field.shape or not np.issubdtype(ids.dtype, np.integer):
            raise ParamsError(f"style ids must be integers of the terrain's shape {field.shape}, got "
                              f"{ids.dtype} {ids.shape}")
        if ids.size and not (-1 <= int(ids.min()) and int(ids.max()) <= 254):
            raise ParamsError(f"style ids must be -1 to 254 to fit 8 bits, got {ids.min()} to {ids.max()}")
        masks["style_regions"] = (ids + 1).astype(np.uint8)
    return TerrainMasks(masks=masks, scales=scales, notes=notes, cell_size=tuple(cell_size))
