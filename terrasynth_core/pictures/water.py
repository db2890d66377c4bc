"""Water drawn over terrain: blues by depth below a water level, and the shoreline.

The app's 2D and 3D views, and the README's map pictures, draw water with
these colours, so a lake looks the same wherever it is shown.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

#: Water colour at the shore (shallow) and at full depth, RGB.
SHALLOW_RGB = np.array((120, 170, 215), np.float64)
DEEP_RGB = np.array((30, 70, 140), np.float64)
#: The line where the level meets the land, RGB.
SHORE_RGB = (235, 245, 255)


def depth_colours(depth: np.ndarray, *, full_depth: float | None = None) -> np.ndarray:
    """Blues from shallow to deep.

    Parameters
    ----------
    depth : ndarray of float, shape (n,) or (rows, cols)
        Metres below the water level (0 at the shore; negative counts as 0).
    full_depth : float or None
        Depth that takes the deepest blue; None takes the 95th percentile of
        ``depth`` (so a few deep holes do not wash out the rest).

    Returns
    -------
    ndarray of float64, shape ``depth.shape + (3,)``
        RGB from 0 to 255.
    """
    depth = np.clip(np.asarray(depth, np.float64), 0.0, None)
    if full_depth is None:
        full_depth = float(np.percentile(depth, 95)) if depth.size else 1.0
    t = (depth / max(full_depth, 1e-6)).clip(0.0, 1.0)[..., None]
    return (1.0 - t) * SHALLOW_RGB + t * DEEP_RGB


#: :func:`depth_colours` at 256 depths from the shore to full depth, uint8 (256, 3): a
#: table lookup colours a large lake many times faster than blending each cell.
WATER_LUT = np.rint((1.0 - np.linspace(0.0, 1.0, 256)[:, None]) * SHALLOW_RGB
                    + np.linspace(0.0, 1.0, 256)[:, None] * DEEP_RGB).astype(np.uint8)


def water_cells(heights: np.ndarray, level: float, *, painted: np.ndarray | None = None) -> np.ndarray:
    """Cells under water at ``level``.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres; NaN (not synthesized yet) is dry.
    level : float
        Water surface height, metres.
    painted : ndarray of bool, shape (rows, cols), optional
        Painted water.  Given, only the cells below the level that connect
        (8-neighbours) to painted water are water: a basin below the level
        with no painted water in it stays dry, as it would under real water.
        None: every cell below the level (a water plane at the level in
        another program covers them all).

    Returns
    -------
    ndarray of bool, shape (rows, cols)
    """
    with np.errstate(invalid="ignore"):
        wet = heights < level  # NaN compares False: dry
    if painted is not None and wet.any():
        labels, count = ndimage.label(wet, structure=np.ones((3, 3), bool))
        reached = np.zeros(count + 1, bool)
        reached[labels[painted & wet]] = True
        reached[0] = False  # label 0: dry
        wet = reached[labels]
    return wet


def _shore(wet: np.ndarray) -> np.ndarray:
    """Wet cells with a dry 4-neighbour (the map's edge counts as wet)."""
    inner = wet.copy()
    inner[1:] &= wet[:-1]
    inner[:-1] &= wet[1:]
    inner[:, 1:] &= wet[:, :-1]
    inner[:, :-1] &= wet[:, 1:]
    return wet & ~inner


def water_rgba(heights: np.ndarray, level: float, *, painted: np.ndarray | None = None,
               alpha: int = 230) -> np.ndarray:
    """The cells of :func:`water_cells` as water, blue by depth, with a shoreline.

    Parameters
    ----------
    heights, level, painted
        As in :func:`water_cells`.
    alpha : int, default 230
        Opacity of the water, 0 to 255 (the hillshade shows through a little).

    Returns
    -------
    ndarray of uint8, shape (rows, cols, 4)
        RGBA; dry cells transparent, water cells next to dry land drawn in
        :data:`SHORE_RGB`, opaque.
    """
    wet = water_cells(heights, level, painted=painted)
    if not wet.any():
        return np.zeros(heights.shape + (4,), np.uint8)
    # Whole-array steps and a 32-bit lookup: this runs on the GUI thread
    # each time the level moves.
    depth = np.float32(level) - heights.astype(np.float32, copy=False)
    full_depth = max(float(np.percentile(depth[wet], 95)), 1e-6)  # as depth_colours
    index = np.clip(np.nan_to_num(depth, nan=0.0) * np.float32(255.0 / full_depth) + np.float32(0.5), 0, 255)
    table = np.empty((256, 4), np.uint8)
    table[:, :3], table[:, 3] = WATER_LUT, alpha
    pixels = table.view(np.uint32).ravel()[index.astype(np.uint8)]
    pixels[~wet] = 0
    pixels[_shore(wet)] = np.array([(*SHORE_RGB, 255)], np.uint8).view(np.uint32)[0, 0]
    rgba = pixels.view(np.uint8).reshape(heights.shape + (4,))
    return rgba
