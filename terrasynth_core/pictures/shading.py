"""Light on the terrain: hillshade, grey hillshade, and colours lit by it."""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParamsError
from ..measures import surface_gradient


def hillshade(heights, *, cell_size=None, azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
    """Lambertian shading of the terrain under a distant light.

    Parameters
    ----------
    heights, cell_size
        As in :func:`terrasynth_core.measures.surface_gradient`: metres,
        NaN = nodata.
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
    dz_drow, dz_dcol, nodata = surface_gradient(heights, cell_size=cell_size)
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


def grey_hillshade(heights, *, cell_size=None) -> np.ndarray:
    """:func:`hillshade` as grey levels.

    Returns
    -------
    ndarray of uint8, shape (rows, cols)
        0 (full shadow) to 255 (facing the light); nodata cells white.
    """
    shade = np.nan_to_num(hillshade(heights, cell_size=cell_size), nan=1.0)
    return (shade * 255).astype(np.uint8)


def lit(colours: np.ndarray, shade: np.ndarray) -> np.ndarray:
    """Colours brightened or darkened by a hillshade.

    Parameters
    ----------
    colours : ndarray, shape (rows, cols, 3)
        RGB from 0 to 255, any numeric dtype.
    shade : ndarray of float, shape (rows, cols)
        :func:`hillshade` brightness in [0, 1]; NaN (nodata) counts as lit.

    Returns
    -------
    ndarray of uint8, shape (rows, cols, 3)
    """
    shade = np.nan_to_num(shade, nan=1.0)
    # Flat ground under a 45-degree light has shade sin(45) ~ 0.71: scale so
    # it keeps its colour, lit slopes brighten a little, shadows darken.
    light = np.clip(0.15 + 1.2 * shade, 0.0, 1.25)[..., None]
    return np.clip(colours * light, 0, 255).astype(np.uint8)
