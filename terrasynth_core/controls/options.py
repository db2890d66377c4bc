"""Artist controls beyond the paper's sketch: style regions, stamps, water,
elevation pins, a global height range and local re-synthesis.

The paper's Middle-earth map (§6) paints regions, gives each its own example
DEM, places a localized feature (Mount St. Helens) and a water mask.  Here:

- every example is synthesized as *detail* about its median height, scaled
  by its style's relief scale; a smooth *level field* (each region's base
  height, blurred across region borders) carries the large-scale elevation.
  Patches are matched and placed relative to the level field, so examples
  of very different elevations meet without cliffs and blend without seams;
- a :class:`Stamp` is a DEM window placed first, rotated and scaled, its
  foot on the level field; its core is protected and the rest is
  synthesized around it, meeting it through the usual graph cut and seam
  solve;
- water, pins and the height range act on the finished heights
  (:mod:`.water`, :mod:`.pins`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import ParamsError
from ..heightfield import HeightField
from .pins import check_pins
from .water import Water

#: Footprint scales a :class:`Stamp` may have, (lowest, highest).
STAMP_SCALE_RANGE = (0.05, 20.0)


def check_stamp_transform(scale: float, rotation: float, what: str = "stamp") -> None:
    """Check a stamp's footprint scale and rotation (degrees).

    Raises
    ------
    ParamsError
        Naming ``what``, unless the scale is within :data:`STAMP_SCALE_RANGE`
        and the rotation is finite.
    """
    lo, hi = STAMP_SCALE_RANGE
    if not (math.isfinite(scale) and lo <= scale <= hi):
        raise ParamsError(f"{what}: scale must be between {lo:g} and {hi:g}, got {scale}")
    if not math.isfinite(rotation):
        raise ParamsError(f"{what}: rotation must be a finite angle in degrees, got {rotation}")


def check_height_range(height_range) -> tuple[float, float] | None:
    """A final height range as two floats, or None for none.

    Parameters
    ----------
    height_range : (lo, hi) or None
        Metres.

    Raises
    ------
    ParamsError
        Unless both are finite and ``lo < hi``.
    """
    if height_range is None:
        return None
    lo, hi = (float(v) for v in height_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise ParamsError(f"height range must be two finite heights LO < HI, got {height_range}")
    return lo, hi


@dataclass(frozen=True, eq=False)
class Style:
    """A terrain style for a painted region.

    Parameters
    ----------
    example : HeightField or ndarray
        The style's example DEM, metres.
    relief_scale : float, default 1
        Multiplies the example's height variation about its median.
    base : float, optional
        Height the style's terrain sits at, metres.  Default: the example's
        median height (times nothing: bases are not relief-scaled).
    name : str
    """

    example: HeightField | np.ndarray
    relief_scale: float = 1.0
    base: float | None = None
    name: str = ""


@dataclass(frozen=True, eq=False)
class Stamp:
    """A DEM window placed as it is (the paper's localized feature).

    Parameters
    ----------
    field : HeightField or ndarray
        The DEM, metres.  Nodata is cropped away (largest valid rectangle).
    center : (row, col)
        Output position of the window's centre, cells.
    rotation : float, default 0
        Degrees, counter-clockwise as seen on screen.
    scale : float, default 1
        Footprint scale; heights are not scaled.
    window : (r0, r1, c0, c1), optional
        DEM cells to use (half-open); default the whole valid DEM.
    """

    field: HeightField | np.ndarray
    center: tuple[float, float]
    rotation: float = 0.0
    scale: float = 1.0
    window: tuple[int, int, int, int] | None = None


@dataclass(frozen=True, eq=False)
class Controls:
    """Everything a run can be given besides examples and a sketch.

    Parameters
    ----------
    styles : tuple of Style
    style_map : ndarray of int, shape (rows, cols), optional
        Index into ``styles`` per output cell; -1 means the session's plain
        examples.  Resized (nearest) when its shape differs from the output
        but has the same aspect ratio.  With no map, a single style covers
        everything.
    water : Water, optional
    stamps : tuple of Stamp
    pins : tuple of Pin
    height_range : (lo, hi), optional
        Final heights, metres.  The styles are scaled towards it before
        synthesis and the result is mapped onto it exactly afterwards
        (before water and pins, which are in final metres).
    pin_radius : float, optional
        Cells a pin's correction reaches.  Default one patch size.
    previous : ndarray of float32, shape (rows, cols), optional
        Local re-synthesis: the result to keep ...
    selection : ndarray of bool, shape (rows, cols), optional
        ... and the cells to synthesize again.  Every other cell keeps its
        ``previous`` height bit for bit.
    """

    styles: tuple = ()
    style_map: np.ndarray | None = None
    water: Water | None = None
    stamps: tuple = ()
    pins: tuple = ()
    height_range: tuple[float, float] | None = None
    pin_radius: float | None = None
    previous: np.ndarray | None = None
    selection: np.ndarray | None = None

    @property
    def resynthesis(self) -> bool:
        return self.selection is not None

    def checked(self, shape: tuple[int, int], patch_size: int, n_default: int) -> "Controls":
        """Validated copy for an output ``shape`` (arrays converted, maps
        fitted to the shape).

        Parameters
        ----------
        shape : (rows, cols)
        patch_size : int
        n_default : int
            Number of plain examples the session has (for -1 labels).

        Raises
        ------
        ParamsError
            Naming the bad value and what was expected.
        """
        styles = tuple(self.styles)
        for i, s in enumerate(styles):
            if not isinstance(s, Style):
                raise ParamsError(f"style {i + 1} must be a Style, got {type(s).__name__}")
            if not (math.isfinite(s.relief_scale) and s.relief_scale > 0):
                raise ParamsError(f"style {_style_name(s, i)}: relief scale must be a positive number, "
                                  f"got {s.relief_scale}")
            if s.base is not None and not math.isfinite(s.base):
                raise ParamsError(f"style {_style_name(s, i)}: base height must be finite, got {s.base}")
        style_map = None
        if self.style_map is not None:
            if not styles:
                raise ParamsError("a style map needs styles: give one Style per colour")
            style_map = _fit_map("style map", np.asarray(self.style_map), shape, order=0).astype(np.int16)
            bad = (style_map < -1) | (style_map >= len(styles))
            if bad.any():
                raise ParamsError(f"style map holds label {int(style_map[bad][0])} but there are "
                                  f"{len(styles)} styles (labels -1 to {len(styles) - 1})")
            if n_default == 0 and (style_map == -1).any():
                raise ParamsError(f"{int((style_map == -1).sum())} cells of the style map have no style and no "
                                  "default example is given: paint them or give an example")
        elif len(styles) > 1:
            raise ParamsError(f"{len(styles)} styles but no style map saying where each goes")
        elif len(styles) == 1:
            style_map = np.zeros(shape, np.int16)
        if not styles and n_default == 0:
            raise ParamsError("no example DEM given: synthesis needs an example or a style")
        water = None
        if self.water is not None:
            fitted = _fit_map("water mask", np.asarray(self.water.mask), shape, order=0)
            water = Water(fitted, self.water.level, self.water.depth, self.water.bank_width).checked(shape)
        for i, st in enumerate(self.stamps):
            if not isinstance(st, Stamp):
                raise ParamsError(f"stamp {i + 1} must be a Stamp, got {type(st).__name__}")
            check_stamp_transform(st.scale, st.rotation, f"stamp {i + 1}")
            r, c = st.center
            if not (0 <= r < shape[0] and 0 <= c < shape[1]):
                raise ParamsError(f"stamp {i + 1} centre ({r}, {c}) is outside the {shape[0]}x{shape[1]} output")
        pins = check_pins(self.pins, shape)
        height_range = check_height_range(self.height_range)
        radius = float(patch_size if self.pin_radius is None else self.pin_radius)
        if not (math.isfinite(radius) and radius > 2):
            raise ParamsError(f"pin radius must be more than 2 cells, got {self.pin_radius}")
        previous = selection = None
        if (self.previous is None) != (self.selection is None):
            raise ParamsError("local re-synthesis needs both the previous result and the selection")
        if self.selection is not None:
            previous = np.asarray(self.previous, dtype=np.float32)
            selection = np.asarray(self.selection, dtype=bool)
            for name, arr in (("previous result", previous), ("selection", selection)):
                if arr.shape != tuple(shape):
                    raise ParamsError(f"{name} is {arr.shape} but the output is {shape[0]}x{shape[1]}")
            if not selection.any():
                raise ParamsError("the selection is empty: select the cells to synthesize again")
            if not np.isfinite(previous).all():
                raise ParamsError("the previous result holds non-finite heights")
        return Controls(styles, style_map, water, tuple(self.stamps), pins, height_range, radius,
                        previous, selection)


def _style_name(style: Style, i: int) -> str:
    return repr(style.name) if style.name else str(i + 1)


def _fit_map(name: str, arr: np.ndarray, shape: tuple[int, int], *, order: int) -> np.ndarray:
    """``arr`` resized (nearest) to ``shape`` when the aspect ratio agrees."""
    if arr.ndim != 2:
        raise ParamsError(f"{name} must be a 2-D array, got shape {arr.shape}")
    if arr.shape == tuple(shape):
        return arr
    ratio = (arr.shape[0] / arr.shape[1]) / (shape[0] / shape[1])
    if abs(ratio - 1) > 0.02:
        raise ParamsError(f"{name} is {arr.shape[0]}x{arr.shape[1]} but the output is {shape[0]}x{shape[1]} "
                          "(another aspect ratio): paint it on the output grid")
    rr = np.minimum((np.arange(shape[0]) + 0.5) * arr.shape[0] / shape[0], arr.shape[0] - 1).astype(int)
    cc = np.minimum((np.arange(shape[1]) + 0.5) * arr.shape[1] / shape[1], arr.shape[1] - 1).astype(int)
    return arr[np.ix_(rr, cc)]


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
    from .pins import Pin, apply_pins

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


def render_stamp(stamp: Stamp, shape: tuple[int, int], patch_size: int) -> RenderedStamp:
    """Crop, rotate and scale a stamp onto the output grid (bilinear).

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
        heights = heights[r0:r1, c0:c1]
    sub = HeightField(np.ascontiguousarray(heights, dtype=np.float32), source=name)
    if sub.nodata_count:
        sub = sub.crop_valid()
        if sub.nodata_count:
            sub = sub.fill_nodata()
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
