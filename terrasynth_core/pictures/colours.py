"""Colours of terrain and of patches.

One hypsometric ramp (lowland green through rock brown to snow) colours
heights everywhere: the CLI, the app's 2D and 3D views, the thumbnails and
the README pictures.
"""

from __future__ import annotations

import colorsys

import numpy as np

from .shading import hillshade, lit

#: Height fraction -> colour of the ramp, RGB.
RAMP_STOPS = np.array([0.0, 0.2, 0.45, 0.7, 0.88, 1.0])
RAMP_RGB = np.array([
    (46, 104, 58),
    (112, 156, 84),
    (196, 188, 124),
    (150, 112, 74),
    (170, 160, 152),
    (250, 250, 250),
], dtype=np.float64)
#: The ramp at 256 evenly spaced height levels, uint8 (256, 3).
TERRAIN_LUT = np.rint(
    np.stack([np.interp(np.linspace(0.0, 1.0, 256), RAMP_STOPS, RAMP_RGB[:, i]) for i in range(3)], axis=1)
).astype(np.uint8)


def height_ticks(low: float, high: float, *, count: int = 5) -> list[float]:
    """Round heights between ``low`` and ``high`` to label a legend with.

    Parameters
    ----------
    low, high : float
        Metres at the ends of the ramp.
    count : int, default 5
        About how many ticks.

    Returns
    -------
    list of float
        Multiples of 1, 2 or 5 times a power of ten, ascending, all within
        ``[low, high]``; at least the two ends when no round value fits.
    """
    span = high - low
    if not (np.isfinite(span) and span > 0):
        return [float(low)]
    # A step a little under span / (count - 1) rounds to 1-2-5 without
    # falling to half the ticks wanted.
    raw = span / max(count - 1, 1) / 1.5
    power = 10.0 ** np.floor(np.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    ticks = np.arange(np.ceil(low / step) * step, high + step * 1e-9, step) + 0.0  # no -0.0
    return [float(t) for t in ticks] if len(ticks) >= 2 else [float(low), float(high)]


def ramp_strip(length: int, *, width: int = 1) -> np.ndarray:
    """The ramp as a vertical strip, highest colour at the top (a legend).

    Returns
    -------
    ndarray of uint8, shape (length, width, 3)
    """
    levels = np.rint(np.linspace(255, 0, length)).astype(np.uint8)
    return np.repeat(TERRAIN_LUT[levels][:, None, :], width, axis=1)


def height_range(heights: np.ndarray, *, tail: float = 0.0) -> tuple[float, float]:
    """Heights that span the ramp.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres, NaN = nodata.
    tail : float, default 0
        Percent of the finite heights left out at each end, so a few
        extreme cells do not wash out the rest (0 = min to max).

    Returns
    -------
    (low, high) : floats, metres
        Never an empty interval; ``(0, 1)`` when no height is finite.
    """
    finite = heights[np.isfinite(heights)]
    if finite.size == 0:
        return 0.0, 1.0
    low, high = (float(v) for v in np.percentile(finite, [tail, 100.0 - tail]))
    return (low, high) if high > low else (low, low + 1.0)


def terrain_colours(heights: np.ndarray, *, vrange: tuple[float, float] | None = None) -> np.ndarray:
    """Heights coloured by the ramp.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres; NaN cells take the lowest colour.
    vrange : (low, high) or None
        Heights at the ends of the ramp; None takes :func:`height_range`
        with a 0.5 % tail.

    Returns
    -------
    ndarray of uint8, shape (rows, cols, 3)
    """
    low, high = height_range(heights, tail=0.5) if vrange is None else vrange
    level = (np.nan_to_num(heights, nan=low) - low) * (255.0 / max(high - low, 1e-6))
    return TERRAIN_LUT[np.rint(np.clip(level, 0, 255)).astype(np.uint8)]


def shaded_relief(heights: np.ndarray, *, cell_size=None, vrange: tuple[float, float] | None = None) -> np.ndarray:
    """Ramp colours lit by a north-west :func:`hillshade`.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres; NaN cells (nodata, or not synthesized yet) come out
        transparent.
    cell_size : float, (dy, dx) or None
        Cell size in metres, for the slopes of the hillshade.
    vrange : (low, high) or None
        As in :func:`terrain_colours`.

    Returns
    -------
    ndarray of uint8, shape (rows, cols, 4)
        RGBA.
    """
    valid = np.isfinite(heights)
    rgba = np.zeros(heights.shape + (4,), np.uint8)
    if valid.any():
        shade = hillshade(heights, cell_size=cell_size)
        rgba[..., :3] = lit(terrain_colours(heights, vrange=vrange), shade)
        rgba[..., 3] = np.where(valid, 255, 0)
    return rgba


def ringed(bbox: tuple[int, int, int, int], shape: tuple[int, int]) -> tuple[int, int, int, int]:
    """The window ``bbox`` (r0, r1, c0, c1) with a one-cell ring, within a
    grid of ``shape``: the cells whose shading reads the window's heights."""
    r0, r1, c0, c1 = bbox
    return max(r0 - 1, 0), min(r1 + 1, shape[0]), max(c0 - 1, 0), min(c1 + 1, shape[1])


def shaded_window(heights: np.ndarray, bbox: tuple[int, int, int, int], *, cell_size=None,
                  vrange: tuple[float, float]) -> np.ndarray:
    """:func:`shaded_relief` of the window ``bbox`` (r0, r1, c0, c1) of ``heights``.

    The window is shaded with a one-cell margin so its border slopes see
    their neighbours, then cut to ``bbox``.

    Returns
    -------
    ndarray of uint8, shape (r1 - r0, c1 - c0, 4)
    """
    r0, r1, c0, c1 = bbox
    R0, R1, C0, C1 = ringed(bbox, heights.shape)
    rgba = shaded_relief(heights[R0:R1, C0:C1], cell_size=cell_size, vrange=vrange)
    return rgba[r0 - R0:r1 - R0, c0 - C0:c1 - C0]


def thumbnail(heights: np.ndarray, *, cell_size=None, side: int = 128) -> np.ndarray:
    """A :func:`shaded_relief` at most ``side`` cells a side (strided, not filtered).

    Returns
    -------
    ndarray of uint8, shape (ceil(rows / step), ceil(cols / step), 4)
        RGBA, ``step`` the smallest stride that fits.
    """
    step = max(1, int(np.ceil(max(heights.shape) / side)))
    small = heights[::step, ::step]
    if cell_size is not None:
        dy, dx = (cell_size, cell_size) if np.isscalar(cell_size) else cell_size
        cell_size = (dy * step, dx * step)
    return shaded_relief(small, cell_size=cell_size, vrange=height_range(small))


def _patch_palette(count: int) -> np.ndarray:
    """``count`` RGBA colours; consecutive ones far apart in hue."""
    golden = (5 ** 0.5 - 1) / 2
    colours = [colorsys.hsv_to_rgb((k * golden) % 1.0, (0.8, 0.55)[k % 2], (0.95, 0.7, 0.85)[k % 3])
               for k in range(count)]
    return np.concatenate([np.rint(np.array(colours) * 255), np.full((count, 1), 255)], axis=1).astype(np.uint8)


_PATCH_PALETTE = _patch_palette(256)


def patch_colours(patch_id: np.ndarray) -> np.ndarray:
    """A colour per patch, to show where each patch went.

    Parameters
    ----------
    patch_id : ndarray of int, shape (rows, cols)
        Index of the patch each cell came from, -1 for none.

    Returns
    -------
    ndarray of uint8, shape (rows, cols, 4)
        RGBA; the same id always has the same colour, ids one apart have
        far-apart hues (patches placed one after the other usually touch),
        ids repeat their colours every 256; -1 is transparent.
    """
    rgba = _PATCH_PALETTE[np.mod(patch_id, len(_PATCH_PALETTE))]
    rgba[patch_id < 0] = 0
    return rgba
