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
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ParamsError
from ..features.sketch import resize_nearest
from ..heightfield import HEIGHT_LIMIT, HeightField
from .pins import check_pin_heights, check_pins
from .water import Water, check_bank_width

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
    if math.isfinite(scale) and scale <= 0:
        raise ParamsError(f"{what}: scale {scale:g} must be a positive number (1 keeps its size), "
                          f"between {lo:g} and {hi:g}")
    if not (math.isfinite(scale) and lo <= scale <= hi):
        raise ParamsError(f"{what}: scale must be between {lo:g} and {hi:g}, got {scale}")
    if not math.isfinite(rotation):
        raise ParamsError(f"{what}: rotation must be a finite angle in degrees, got {rotation}")


#: Pins may lie up to this many times the examples' height span beyond it ...
PIN_SPANS = 3.0
#: ... the span counting as at least this many metres (flat examples).
MIN_PIN_SPAN = 100.0


def _as_heights(example) -> np.ndarray | None:
    """An example's heights as a real array (no copy), None if not numbers."""
    arr = np.asarray(example.heights if isinstance(example, HeightField) else example)
    return arr if arr.dtype.kind in "iuf" and arr.size else None


def _height_span(arr: np.ndarray) -> tuple[float, float] | None:
    """Lowest and highest finite height, None when there is none."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN
        lo, hi = float(np.nanmin(arr)), float(np.nanmax(arr))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        finite = arr[np.isfinite(arr)]
        if not finite.size:
            return None
        lo, hi = float(finite.min()), float(finite.max())
    return lo, hi


def check_heights(examples, controls: "Controls") -> None:
    """Refuse absurd heights before a run: examples beyond :data:`HEIGHT_LIMIT`
    and pins too far from the terrain's heights.

    The pins' allowed range is the height range when one is given, else the
    span of the example heights (the plain examples as they are, each style's
    example about its base, times its relief scale); widened on each side by
    :data:`PIN_SPANS` times that span (at least :data:`MIN_PIN_SPAN` metres).

    Parameters
    ----------
    examples : sequence of HeightField or ndarray
    controls : Controls
        Checked (:meth:`Controls.checked`).

    Raises
    ------
    ParamsError
        Naming the example or pin, the value and the allowed range.
    """
    spans = []
    named = [(ex, getattr(ex, "source", None) or f"example {i + 1}") for i, ex in enumerate(examples)]
    named += [(st.example, f"style {_style_name(st, i)}") for i, st in enumerate(controls.styles)]
    named += [(st.field, f"stamp {i + 1}") for i, st in enumerate(controls.stamps)]
    finite = {}
    for ex, name in named:
        heights = _as_heights(ex)
        span = None if heights is None else _height_span(heights)
        if span is None:
            continue  # reported by the example analysis
        lo, hi = span
        worst = lo if abs(lo) > abs(hi) else hi
        if abs(worst) > HEIGHT_LIMIT:
            raise ParamsError(f"{name}: holds a height of {worst:g} m; heights must be within "
                              f"+-{HEIGHT_LIMIT:g} m (a DEM in other units, or an unmarked fill value?)")
        finite[id(ex)] = (heights, lo, hi)
    for i, st in enumerate(controls.styles):
        if id(st.example) not in finite:
            continue
        heights, lo, hi = finite[id(st.example)]
        # (The median, and so the exact span, only when a bound that needs
        # none is over: a session is made for every live stroke.)
        bound = (abs(st.base) if st.base is not None else max(abs(lo), abs(hi))) + st.relief_scale * (hi - lo)
        if bound > HEIGHT_LIMIT:
            lo, hi = _styled_span(st, heights, lo, hi)
            if max(abs(lo), abs(hi)) > HEIGHT_LIMIT:
                raise ParamsError(f"style {_style_name(st, i)}: its relief scale {st.relief_scale:g} and base put "
                                  f"its heights at {lo:.3g}..{hi:.3g} m; heights must be within "
                                  f"+-{HEIGHT_LIMIT:g} m: a smaller relief scale or base would do")
    if not controls.pins:
        return
    if controls.height_range is not None:
        lo, hi = controls.height_range
        source = "the height range"
    else:
        for ex in examples:
            if id(ex) in finite:
                spans.append(finite[id(ex)][1:])
        for st in controls.styles:
            if id(st.example) in finite:
                spans.append(_styled_span(st, *finite[id(st.example)]))
        if not spans:
            return
        lo, hi = min(s[0] for s in spans), max(s[1] for s in spans)
        source = "the examples' heights"
    reach = PIN_SPANS * max(hi - lo, MIN_PIN_SPAN)
    check_pin_heights(controls.pins, (lo - reach, hi + reach),
                      f"{source} {lo:.0f}..{hi:.0f} m widened by {PIN_SPANS:g} times their span")


def _styled_span(style: "Style", heights: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """The heights of ``style``'s example (lowest ``lo``, highest ``hi``,
    metres) about its base, times its relief scale."""
    median = float(np.nanmedian(np.where(np.isfinite(heights), heights, np.nan)))
    base = median if style.base is None else float(style.base)
    return base + style.relief_scale * (lo - median), base + style.relief_scale * (hi - median)


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
    if max(abs(lo), abs(hi)) > HEIGHT_LIMIT:
        raise ParamsError(f"height range {lo:g}..{hi:g} m: heights must be within +-{HEIGHT_LIMIT:g} m")
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
        Cells a pin's correction reaches.  Default one patch size, once the
        run has one (:meth:`pin_reach`).
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

    def pin_reach(self, patch_size: int) -> float:
        """Cells a pin's correction reaches: ``pin_radius``, or the run's
        patch size when none was given."""
        return float(patch_size if self.pin_radius is None else self.pin_radius)

    def check_kinds(self) -> None:
        """Raise ParamsError unless every style is a Style and every stamp a
        Stamp (what reading their examples needs, before any shape is known)."""
        for i, s in enumerate(self.styles):
            if not isinstance(s, Style):
                raise ParamsError(f"style {i + 1} must be a Style, got {type(s).__name__}")
        for i, st in enumerate(self.stamps):
            if not isinstance(st, Stamp):
                raise ParamsError(f"stamp {i + 1} must be a Stamp, got {type(st).__name__}")

    def checked(self, shape: tuple[int, int], n_default: int) -> "Controls":
        """Validated copy for an output ``shape`` (arrays converted, maps
        fitted to the shape).  Needs no patch size: a pin radius not given
        stays None (:meth:`pin_reach`).

        Parameters
        ----------
        shape : (rows, cols)
        n_default : int
            Number of plain examples the session has (for -1 labels).

        Raises
        ------
        ParamsError
            Naming the bad value and what was expected.
        """
        self.check_kinds()
        styles = tuple(self.styles)
        for i, s in enumerate(styles):
            if not (math.isfinite(s.relief_scale) and s.relief_scale > 0):
                raise ParamsError(f"style {_style_name(s, i)}: relief scale must be a positive number, "
                                  f"got {s.relief_scale}")
            if s.base is not None and not (math.isfinite(s.base) and abs(s.base) <= HEIGHT_LIMIT):
                raise ParamsError(f"style {_style_name(s, i)}: base height must be a height within "
                                  f"+-{HEIGHT_LIMIT:g} m, got {s.base}")
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
            if self.previous is None:  # (a re-synthesis's crop keeps the whole map's bank)
                check_bank_width(water.bank_width, shape)
        for i, st in enumerate(self.stamps):
            check_stamp_transform(st.scale, st.rotation, f"stamp {i + 1}")
            r, c = st.center
            if not (0 <= r < shape[0] and 0 <= c < shape[1]):
                raise ParamsError(f"stamp {i + 1} centre ({r}, {c}) is outside the {shape[0]}x{shape[1]} output")
        pins = check_pins(self.pins, shape)
        height_range = check_height_range(self.height_range)
        radius = None if self.pin_radius is None else float(self.pin_radius)
        if radius is not None and not (math.isfinite(radius) and radius > 2):
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
    return resize_nearest(arr, shape)
