"""Water: painted sea, lakes and rivers brought to a water level, with beds
carved below it and banks that ease down to the shore.

Everything is a function of the distance to the shoreline (Euclidean
distance transforms), so it is smooth, vectorised and independent of the
order patches were placed in:

- in the water, the bed lies ``depth * s(d_in / width)`` below the level,
  where ``d_in`` is the distance to land and ``s`` a smoothstep: wide water
  gets the full depth, a river a few cells wide a shallow bed.  Terrain
  already deeper than the bed keeps its own shape (a soft minimum);
- on land within ``bank_width`` cells of water, the broad height above the
  shore level is scaled by ``s(d_out / bank_width)`` and the fine detail by
  ``s(4 d_out / bank_width)``: the land meets the water at the level and
  rises back to the synthesized terrain with zero slope at both ends, so a
  river carves a valley, not a trench, and its banks keep their texture.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import ParamsError
from ..heightfield import HEIGHT_LIMIT


@dataclass(frozen=True, eq=False)
class Water:
    """Painted water and its level.

    Parameters
    ----------
    mask : ndarray of bool, shape (rows, cols)
        Sea, lakes and rivers.
    level : float
        Water surface height, metres (final output frame).
    depth : float, optional
        How far the bed of wide water lies below the level, metres.
        Default 3 % of the terrain's height range.
    bank_width : float, optional
        Cells over which land eases down to the shore.  Default half a patch.
    """

    mask: np.ndarray
    level: float
    depth: float | None = None
    bank_width: float | None = None

    def checked(self, shape: tuple[int, int]) -> "Water":
        """This water with its mask as a bool array of ``shape``.

        Raises
        ------
        ParamsError
            Wrong mask shape, non-finite level, negative depth or width, a
            level or depth beyond :data:`~terrasynth_core.heightfield.HEIGHT_LIMIT`.
        """
        mask = np.asarray(self.mask)
        if mask.shape != tuple(shape):
            raise ParamsError(f"water mask is {mask.shape[0]}x{mask.shape[1]} but the output is "
                              f"{shape[0]}x{shape[1]}: paint it on the output grid")
        if not math.isfinite(self.level):
            raise ParamsError(f"water level must be a finite height in metres, got {self.level}")
        for name, v in (("depth", self.depth), ("bank width", self.bank_width)):
            if v is not None and not (math.isfinite(v) and v >= 0):
                raise ParamsError(f"water {name} must be a non-negative number, got {v}")
        for name, v in (("level", self.level), ("depth", self.depth)):
            if v is not None and abs(v) > HEIGHT_LIMIT:
                raise ParamsError(f"water {name} {v:g} m: heights must be within +-{HEIGHT_LIMIT:g} m")
        return Water(mask.astype(bool), float(self.level), self.depth, self.bank_width)


def check_bank_width(bank_width: float | None, shape: tuple[int, int]) -> None:
    """Refuse a bank wider than the whole output ``shape`` (its banks'
    Gaussian would need memory beyond any machine's: 1e9 cells took 23 GB).

    Raises
    ------
    ParamsError
    """
    if bank_width is not None and bank_width > max(shape):
        raise ParamsError(f"water bank width {bank_width:g} cells is wider than the {shape[0]}x{shape[1]} map: "
                          f"at most {max(shape)} cells (its longer side)")


#: Cells over which wide water reaches its full depth.
FULL_DEPTH_CELLS = 12.0
#: Smoothing of the shore distance (Gaussian sigma, cells).
SHORE_SMOOTHING = 1.5


def smoothstep(x: np.ndarray) -> np.ndarray:
    """0 below 0, 1 above 1, and the cubic 3x^2 - 2x^3 between: a ramp
    with no kink at either end."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def apply_water(heights: np.ndarray, water: Water, *, bank_width: float,
                locked: np.ndarray | None = None) -> np.ndarray:
    """Bring painted water to its level and shape the beds and banks.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Metres; not modified.
    water : Water
        Checked against the shape (:meth:`Water.checked`).
    bank_width : float
        Used when ``water.bank_width`` is None, cells.
    locked : ndarray of bool, shape (rows, cols), optional
        Cells that must keep their heights (outside a local re-synthesis);
        the shaping eases in from them over the bank width, but water
        whose nearest locked water lies below the level ends below it too.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        Every water cell below the level; land next to water at the level
        plus a lip, easing back to ``heights`` over the bank width.
    """
    mask = water.mask
    out = np.array(heights, dtype=np.float32, copy=True)
    if not mask.any():
        return out
    h = out.astype(np.float64)
    span = float(np.ptp(h)) or 1.0
    depth = 0.03 * span if water.depth is None else float(water.depth)
    width = float(bank_width if water.bank_width is None else water.bank_width)
    level = water.level
    # A hair's step at the waterline keeps the painted shore exactly where
    # the level cuts the terrain (too small to see in a hillshade).
    lip = max(1e-4 * span, 0.01)
    if mask.all():
        d_in = np.full(mask.shape, np.inf)
        d_out = np.zeros(mask.shape)
    else:
        # Signed distance to the shore, lightly smoothed: a painted edge is
        # a staircase of cells, and raw distances would print its steps
        # into the banks as ripples.
        signed = ndimage.distance_transform_edt(~mask) - ndimage.distance_transform_edt(mask)
        signed = ndimage.gaussian_filter(signed, SHORE_SMOOTHING)
        d_in = np.where(mask, np.maximum(-signed, 0.0) + 0.5, 0.0)
        d_out = np.where(mask, 0.0, np.maximum(signed, 0.0) + 0.5)
    t_in = smoothstep((d_in - 0.5) / FULL_DEPTH_CELLS)
    bed = level - lip - depth * t_in
    # Terrain deeper than the bed keeps its shape (a soft minimum, smooth
    # where they cross), fading in with the bed's depth so the water still
    # meets the land at the level instead of under a cliff.
    k = max(0.25 * depth, 1e-3 * span)
    deeper = np.minimum(-k * np.logaddexp(0.0, (bed - h) / k) + k * math.log(2.0), 0.0)
    wet = bed + t_in * deeper
    shore = level + lip
    t = smoothstep((d_out - 1.0) / max(width, 1.0)) if width > 0 else np.ones(mask.shape)
    # The broad shape eases down over the whole bank; the fine detail
    # returns within its first quarter, so banks keep the style's texture
    # instead of becoming smooth ramps.
    broad = ndimage.gaussian_filter(h, max(width / 4.0, 1.0), mode="nearest")
    t_fine = smoothstep((d_out - 1.0) / max(width / 4.0, 1.0))
    dry = shore + t * (broad - shore) + t_fine * (h - broad)
    # Land below the shore level is lifted too: fully over the inner half of
    # the bank (the fine detail, back within its first quarter, would dip
    # there below the water beside it), then less and less, not at all at
    # the bank's outer edge; beyond the bank it is left alone (see
    # flooded_land()).
    half = max(width / 2.0, 0.5)
    lift = 1.0 - smoothstep((d_out - 1.0 - half) / half) if width > 0 else np.zeros(mask.shape)
    dry = dry + lift * np.maximum(shore - dry, 0.0)
    new = np.where(mask, wet, dry)
    if locked is not None and locked.any():
        # Ease the change in from the locked cells over the bank width, so
        # water shaped inside a re-synthesis does not end in a step.
        ease = smoothstep((ndimage.distance_transform_edt(~locked) - 0.5) / max(width, 1.0))
        new = np.where(locked, h, h + ease * (new - h))
        # Water whose nearest locked water is already below the level (a
        # tiled run's finished neighbour, a re-synthesis inside water made
        # before) lies below the level too: eased in from the lock, land
        # freshly made in it would stand out of the water.  (Water painted
        # on to locked dry land keeps the ease: the lock cannot follow it
        # down.)
        held = locked & mask
        if held.any():
            _, nearest = ndimage.distance_transform_edt(~held, return_indices=True)
            settled = held & (h < level)
            joined = mask & ~locked & settled[nearest[0], nearest[1]]
            new = np.where(joined, np.minimum(new, level - lip), new)
    return new.astype(np.float32)


def flooded_note(count: int, level: float) -> str:
    """The warning for ``count`` land cells below the water ``level``
    (:func:`flooded_land`)."""
    return (f"{count} land cells lie below the water level {level:g} m away from painted water: paint them as "
            "water or raise the level")


def flooded_land(heights: np.ndarray, water: Water) -> int:
    """Land cells below the water level (they would read as water)."""
    return int((~water.mask & (heights < water.level)).sum())
