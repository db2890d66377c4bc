"""The level field: the large-scale elevation the synthesized detail sits
on, each style region's base height blurred across region borders, bent
through the elevation pins."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from .pins import Pin, apply_pins


#: Width of the level field's transition across region borders (Gaussian
#: standard deviation), in patch sizes.
LEVEL_SIGMA = 0.5


def level_field(group_map: np.ndarray, bases: np.ndarray, patch_size: int) -> np.ndarray:
    """The large-scale elevation: each region's base, blurred across borders.

    Parameters
    ----------
    group_map : ndarray of int, shape (rows, cols)
        Style group per cell (0..G-1).
    bases : ndarray of float, shape (G,)
        Base height per group, metres.
    patch_size : int

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        Constant inside regions far from a border; across a border it moves
        from one base to the other over about two patch sizes.
    """
    raw = np.asarray(bases, dtype=np.float64)[group_map]
    if np.ptp(bases) == 0:
        return raw.astype(np.float32)
    return ndimage.gaussian_filter(raw, LEVEL_SIGMA * patch_size, mode="nearest").astype(np.float32)


#: Reach of a pin's pull on the level field, in patch sizes.
PIN_LEVEL_REACH = 2.0


def steer_level(level: np.ndarray, pins, patch_size: int) -> np.ndarray:
    """The level field bent so that it passes through the pins.

    Synthesis then builds the terrain around a pin at about the pinned
    height, with its own detail, and the exact correction after synthesis
    (:func:`.pins.apply_pins`) only has to absorb that detail
    instead of raising a smooth dome.  The level field is smooth, so the
    bend is solved on a grid coarser by a sixteenth of a patch and
    interpolated back.

    Parameters
    ----------
    level : ndarray of float32, shape (rows, cols)
    pins : sequence of Pin
        Checked pins (final metres).
    patch_size : int

    Returns
    -------
    ndarray of float32, shape (rows, cols)
    """
    if not pins:
        return level
    f = max(1, patch_size // 16)
    coarse = level[::f, ::f]
    wanted: dict = {}
    for p in pins:
        key = (min(int(round(p.row / f)), coarse.shape[0] - 1), min(int(round(p.col / f)), coarse.shape[1] - 1))
        wanted.setdefault(key, []).append(p.height - float(level[p.row, p.col]))
    targets = [Pin(r, c, float(coarse[r, c]) + float(np.mean(v))) for (r, c), v in wanted.items()]
    bent, _ = apply_pins(coarse, targets, radius=PIN_LEVEL_REACH * patch_size / f)
    rows, cols = level.shape
    rr, cc = np.mgrid[0:rows, 0:cols].astype(np.float32) / f
    change = ndimage.map_coordinates((bent - coarse).astype(np.float64), [rr, cc], order=1, mode="nearest")
    return (level + change).astype(np.float32)
