"""Terrain colours: hypsometric tints shaded by a hillshade, as RGBA images."""

from __future__ import annotations

import numpy as np

from terrasynth_core.measures import hillshade

# Hypsometric tints from lowland green through tan and brown to snow, at
# fractions of the height range.
_STOPS = np.array([0.0, 0.15, 0.35, 0.6, 0.82, 1.0])
_COLORS = np.array([
    (56, 102, 60),
    (106, 146, 82),
    (196, 186, 120),
    (150, 110, 72),
    (150, 140, 132),
    (248, 248, 248),
], dtype=np.float64)
_LUT = np.stack([np.interp(np.linspace(0, 1, 256), _STOPS, _COLORS[:, i]) for i in range(3)], axis=1)
#: Colour of each of 256 height levels, uint8 (256, 3).
TERRAIN_LUT = np.rint(_LUT).astype(np.uint8)


def height_range(heights: np.ndarray) -> tuple[float, float]:
    """``(low, high)`` of the finite heights, never an empty interval."""
    finite = heights[np.isfinite(heights)]
    if finite.size == 0:
        return 0.0, 1.0
    low, high = float(finite.min()), float(finite.max())
    return (low, high) if high > low else (low, low + 1.0)


def shaded_terrain(heights: np.ndarray, *, cell_size: tuple[float, float] | None,
                   vrange: tuple[float, float]) -> np.ndarray:
    """Colour heights by elevation and shade them.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Metres; NaN cells (not synthesized yet) come out transparent.
    cell_size : (dy, dx) or None
        Ground cell size in metres, for the slopes of the hillshade.
    vrange : (low, high)
        Heights mapped to the first and last tint.

    Returns
    -------
    ndarray of uint8, shape (rows, cols, 4)
        RGBA.
    """
    low, high = vrange
    valid = np.isfinite(heights)
    level = np.clip((np.where(valid, heights, low) - low) * (255.0 / max(high - low, 1e-6)), 0, 255)
    rgb = TERRAIN_LUT[level.astype(np.uint8)].astype(np.float32)
    if valid.any():
        shade = np.nan_to_num(hillshade(heights, cell_size=cell_size), nan=0.7)
    else:
        shade = np.full(heights.shape, 0.7, np.float32)
    # Keep a floor of ambient light so shadowed slopes still show their tint.
    rgb *= (0.35 + 0.65 * shade)[..., None]
    rgba = np.empty(heights.shape + (4,), np.uint8)
    rgba[..., :3] = np.clip(rgb, 0, 255).astype(np.uint8)
    rgba[..., 3] = np.where(valid, 255, 0)
    return rgba


def shaded_window(heights: np.ndarray, bbox: tuple[int, int, int, int], *,
                  cell_size: tuple[float, float] | None, vrange: tuple[float, float]) -> np.ndarray:
    """:func:`shaded_terrain` of the window ``bbox`` of ``heights``.

    The window is shaded with a one-cell margin so its border slopes see
    their neighbours, then cut to ``bbox`` (r0, r1, c0, c1).

    Returns
    -------
    ndarray of uint8, shape (r1 - r0, c1 - c0, 4)
    """
    r0, r1, c0, c1 = bbox
    rows, cols = heights.shape
    R0, R1, C0, C1 = max(r0 - 1, 0), min(r1 + 1, rows), max(c0 - 1, 0), min(c1 + 1, cols)
    rgba = shaded_terrain(heights[R0:R1, C0:C1], cell_size=cell_size, vrange=vrange)
    return rgba[r0 - R0:r1 - R0, c0 - C0:c1 - C0]


def thumbnail(heights: np.ndarray, *, cell_size: tuple[float, float] | None, side: int = 128) -> np.ndarray:
    """A shaded RGBA thumbnail at most ``side`` cells a side (strided, not filtered)."""
    step = max(1, int(np.ceil(max(heights.shape) / side)))
    small = heights[::step, ::step]
    cs = None if cell_size is None else (cell_size[0] * step, cell_size[1] * step)
    return shaded_terrain(small, cell_size=cs, vrange=height_range(small))
