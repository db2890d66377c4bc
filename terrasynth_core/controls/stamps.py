"""Stamps rendered onto the output grid: a DEM window cropped, rotated and
scaled, its detail relative to its foot, its core to be kept by later
cuts."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import ParamsError
from ..exemplars.ground import on_ground
from ..exemplars.prepare import without_voids
from ..heightfield import HeightField
from .options import Stamp


@dataclass(frozen=True, eq=False)
class RenderedStamp:
    """A stamp resampled onto the output grid.

    ``detail`` is relative to the stamp's foot (the median height of its
    outline), so it stands on the level field like a synthesized patch.
    ``core`` is the part later patches may not cut away.
    """

    bbox: tuple[int, int, int, int]
    detail: np.ndarray
    valid: np.ndarray
    core: np.ndarray


def render_stamp(stamp: Stamp, shape: tuple[int, int], patch_size: int, *, cell_size: float | None = None,
                 notes: list | None = None) -> RenderedStamp:
    """Crop, rotate and scale a stamp onto the output grid (bilinear).

    Parameters
    ----------
    stamp : Stamp
        Its window is in the DEM's own cells; its scale multiplies the
        footprint the window has at its true size.
    shape : (rows, cols)
    patch_size : int
    cell_size : float or None
        The run's cell size in metres: the window is first resampled to it
        (None: used cell for cell).
    notes : list of str, optional
        Gets the resampling notes (up-sampling, nodata cropped).

    Raises
    ------
    ParamsError
        A window outside the DEM or too small, or a stamp that lands
        entirely outside the output.
    """
    fieldobj = stamp.field
    if not isinstance(fieldobj, HeightField):
        fieldobj = HeightField(np.asarray(fieldobj, dtype=np.float32), source="stamp")
    name = fieldobj.source or "stamp"
    heights = fieldobj.heights
    if stamp.window is not None:
        r0, r1, c0, c1 = (int(v) for v in stamp.window)
        H, W = heights.shape
        if not (0 <= r0 < r1 <= H and 0 <= c0 < c1 <= W):
            raise ParamsError(f"stamp window {stamp.window} is outside {name} ({H}x{W} cells): "
                              "give (r0, r1, c0, c1) with 0 <= r0 < r1 <= rows and 0 <= c0 < c1 <= cols")
        fieldobj = fieldobj.window(r0, r1, c0, c1)
    fieldobj, said = on_ground(fieldobj, cell_size, name=f"stamp {name}")
    if notes is not None:
        notes.extend(said)
    sub = HeightField(np.ascontiguousarray(fieldobj.heights, dtype=np.float32), source=name)
    real = None  # where the stamp has ground (None: everywhere), as examples trim and fill their voids
    if sub.nodata_count:
        sub, real = without_voids(sub)[:2]
    src = sub.heights.astype(np.float64)
    if min(src.shape) < 8:
        raise ParamsError(f"stamp {name} is {src.shape[0]}x{src.shape[1]} valid cells: use a window of at "
                          "least 8x8")
    s = float(stamp.scale)
    if s < 1:
        # Down-sampling: smooth first so the stamp does not alias.
        src = ndimage.gaussian_filter(src, 0.5 / s, mode="nearest")
    theta = math.radians(stamp.rotation)
    cos, sin = math.cos(theta), math.sin(theta)
    h, w = src.shape[0] * s, src.shape[1] * s
    # Footprint of the rotated rectangle, then the output cells in it.
    # (Rounded so that a quarter turn's float noise adds no row.)
    half_r = round(0.5 * (abs(h * cos) + abs(w * sin)), 6)
    half_c = round(0.5 * (abs(w * cos) + abs(h * sin)), 6)
    cr, cc = float(stamp.center[0]), float(stamp.center[1])
    R0, R1 = int(math.floor(cr - half_r)), int(math.ceil(cr + half_r)) + 1
    C0, C1 = int(math.floor(cc - half_c)), int(math.ceil(cc + half_c)) + 1
    R0c, R1c, C0c, C1c = max(R0, 0), min(R1, shape[0]), max(C0, 0), min(C1, shape[1])
    if R1c - R0c < 2 or C1c - C0c < 2:
        raise ParamsError(f"stamp {name} at ({cr}, {cc}) lies outside the output")
    rr, cc_ = np.mgrid[R0c:R1c, C0c:C1c].astype(np.float64)
    dr, dc = rr - cr, cc_ - cc
    # Output offset -> source offset: undo the on-screen counter-clockwise
    # rotation (rows point down), then the scale.
    sr = (dc * sin + dr * cos) / s + (src.shape[0] - 1) / 2
    sc = (dc * cos - dr * sin) / s + (src.shape[1] - 1) / 2
    valid = (sr >= 0) & (sr <= src.shape[0] - 1) & (sc >= 0) & (sc <= src.shape[1] - 1)
    if real is not None:  # (a basin clip stamps the basin)
        valid &= ndimage.map_coordinates(real.astype(np.uint8), [sr, sc], order=0, mode="nearest") > 0
    values = ndimage.map_coordinates(src, [sr, sc], order=1, mode="nearest")
    if valid.sum() < 16:
        raise ParamsError(f"stamp {name} covers fewer than 16 output cells: make it larger")
    outline = valid & ~ndimage.binary_erosion(valid)
    foot = float(np.median(values[outline]))
    detail = np.where(valid, values - foot, 0.0).astype(np.float32)
    # Leave the outer band (a third of a patch or a quarter of the stamp,
    # whichever is less) for the seam with the terrain around.
    band = max(2, int(min(patch_size / 3, min(h, w) / 4)))
    core = ndimage.distance_transform_edt(np.pad(valid, 1))[1:-1, 1:-1] > band
    return RenderedStamp((R0c, R1c, C0c, C1c), detail, valid, core)
