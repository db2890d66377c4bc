"""The array side of 3D terrain pictures, free of any renderer.

A renderer (pyvista in ``terrasynth_app.views.render_3d``) takes the grid
from :func:`surface_grid` and places its camera along
:func:`camera_direction`; :func:`trim_background` crops the empty margin
off its screenshot.
"""

from __future__ import annotations

import math

import numpy as np


def surface_grid(heights: np.ndarray, colours: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heights and vertex colours in the order of a grid whose y runs north.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres, finite; row 0 is the northern edge.
    colours : ndarray, shape (rows, cols, 3)
        RGB from 0 to 255 of every cell.

    Returns
    -------
    z : ndarray of float64, shape (rows * cols,)
        Height above the lowest cell in metres, southern row first, so a
        grid laid out with x east and y north is not mirrored.
    rgb : ndarray of uint8, shape (rows * cols, 3)
        The colours in the same order.
    """
    z = np.ascontiguousarray(heights[::-1], dtype=np.float64)
    rgb = np.ascontiguousarray(colours[::-1]).reshape(-1, 3).astype(np.uint8)
    return (z - z.min()).ravel(), rgb


def camera_direction(azimuth: float, elevation: float) -> np.ndarray:
    """Unit vector from the terrain's centre towards the camera.

    Parameters
    ----------
    azimuth : float
        Degrees from south towards east (negative = towards west).
    elevation : float
        Degrees above the horizon.

    Returns
    -------
    ndarray of float64, shape (3,)
        (east, north, up).
    """
    az, el = math.radians(azimuth), math.radians(elevation)
    return np.array([math.sin(az) * math.cos(el), -math.cos(az) * math.cos(el), math.sin(el)])


def trim_background(rgb: np.ndarray, *, threshold: int = 250, pad: int = 8) -> np.ndarray:
    """Crop a white background around a rendered terrain.

    Parameters
    ----------
    rgb : ndarray of uint8, shape (h, w, 3)
    threshold : int, default 250
        Pixels with every channel at or above it are background.
    pad : int, default 8
        Background pixels kept around the terrain.

    Returns
    -------
    ndarray of uint8, shape (h', w', 3)
        A view of ``rgb``; ``rgb`` itself when it is all background.
    """
    rows, cols = np.nonzero((rgb < threshold).any(axis=2))
    if rows.size == 0:
        return rgb
    return rgb[max(rows.min() - pad, 0):rows.max() + pad + 1, max(cols.min() - pad, 0):cols.max() + pad + 1]
