"""The sketch being drawn: ridge and valley strokes, style regions and water,
brushes, history.

Strokes are kept as two ``uint8`` intensity layers (0 = nothing, 255 = full
stroke) rather than bare masks so that a soft brush leaves soft edges on
screen; the sketch map handed to synthesis is thresholded at half intensity,
the same rule the PNG sketch reader applies to anti-aliased strokes.

Style regions are an ``int16`` layer of style ids (-1 = the document's plain
examples) and water a ``bool`` layer, on the same grid; the region brushes
paint the cells a stroke brush would count as stroked.  All four layers
share one undo history.
"""

from __future__ import annotations

from typing import Iterable, Literal, Mapping

import numpy as np

from terrasynth_core.errors import SketchError
from terrasynth_core.features import SketchMap, resize_nearest
from terrasynth_core.project import STROKE_THRESHOLD, stroke_map
# Largest sketch side accepted, in cells (the core's output limit is 64 M cells).
from terrasynth_core.project import MAX_SIDE

from .observable import Observable
from .brushes import capsule_coverage
from .history import BBox, DocumentEdit, SketchEdit, SketchHistory

Tool = Literal["ridge", "valley", "erase", "style", "style_erase", "water", "water_erase"]
#: Tools that paint ridge and valley strokes.
STROKE_TOOLS: tuple[str, ...] = ("ridge", "valley", "erase")
#: Tools that paint style regions and water.
REGION_TOOLS: tuple[str, ...] = ("style", "style_erase", "water", "water_erase")
TOOLS: tuple[str, ...] = STROKE_TOOLS + REGION_TOOLS
#: Layers each tool changes.
_TOOL_LAYERS = {"ridge": ("ridge", "valley"), "valley": ("ridge", "valley"), "erase": ("ridge", "valley"),
                "style": ("style",), "style_erase": ("style",), "water": ("water",), "water_erase": ("water",)}

#: Style label of cells no style region claims.
NO_STYLE = -1
#: Largest style id (the style layer is int16).
MAX_STYLE_ID = np.iinfo(np.int16).max
#: How water is drawn over the sketch: RGBA.
WATER_RGBA = (30, 110, 230, 150)
#: Opacity of style region colours over the sketch.
STYLE_ALPHA = 110


def _read_only(layer: np.ndarray) -> np.ndarray:
    view = layer.view()
    view.flags.writeable = False
    return view


class _Layer:
    """A sketch layer as a read-only attribute (``sketch.ridge``...): a
    view callers cannot write through, so every edit goes through the
    sketch and its history."""

    def __init__(self, doc: str) -> None:
        self.__doc__ = doc

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, sketch, owner=None):
        return self if sketch is None else _read_only(sketch._layers[self.name])


class Sketch:
    """Ridge and valley strokes, style regions and water, with
    one-stroke-per-step undo.

    Parameters
    ----------
    ridge, valley : ndarray of uint8, shape (rows, cols)
        Stroke intensities; copied.
    style : ndarray of int, shape (rows, cols), optional
        Style id per cell, -1 for none; copied.  Default: no style anywhere.
    water : ndarray of bool, shape (rows, cols), optional
        Water cells; copied.  Default: no water.

    Attributes
    ----------
    changed : Observable
        Emitted with the window ``(r0, r1, c0, c1)`` that changed, or
        ``None`` when whole layers (maybe their shape) changed.
    history_changed : Observable
        Emitted with no argument when undo/redo availability may have changed.
    """

    def __init__(self, ridge: np.ndarray, valley: np.ndarray, *, style: np.ndarray | None = None,
                 water: np.ndarray | None = None) -> None:
        ridge = np.asarray(ridge)
        valley = np.asarray(valley)
        _check_layers(ridge, valley)
        self._layers = {"ridge": ridge.astype(np.uint8, copy=True), "valley": valley.astype(np.uint8, copy=True)}
        self._layers.update(_region_layers(ridge.shape, style, water))
        self.history = SketchHistory()
        self.changed = Observable()
        self.history_changed = Observable()
        self._stroke: _Stroke | None = None
        self._replaying = False

    # -- construction -----------------------------------------------------------
    @classmethod
    def blank(cls, shape: tuple[int, int]) -> "Sketch":
        """An empty sketch of ``shape`` (rows, cols)."""
        rows, cols = (int(v) for v in shape)
        if not (2 <= rows <= MAX_SIDE and 2 <= cols <= MAX_SIDE):
            raise SketchError(f"sketch size {rows}x{cols}: expected 2 to {MAX_SIDE} cells a side")
        return cls(np.zeros((rows, cols), np.uint8), np.zeros((rows, cols), np.uint8))

    @classmethod
    def from_sketch_map(cls, sketch_map: SketchMap) -> "Sketch":
        """Full-intensity strokes from a core :class:`SketchMap`."""
        ridge, valley = _layers_of(sketch_map)
        return cls(ridge, valley)

    # -- reading ----------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return self._layers["ridge"].shape

    ridge = _Layer("Ridge intensities, uint8 (rows, cols); a read-only view.")
    valley = _Layer("Valley intensities, uint8 (rows, cols); a read-only view.")
    style = _Layer("Style id per cell (-1 none), int16 (rows, cols); a read-only view.")
    water = _Layer("Water cells, bool (rows, cols); a read-only view.")

    @property
    def has_strokes(self) -> bool:
        ridge, valley = self._layers["ridge"], self._layers["valley"]
        return bool((ridge >= STROKE_THRESHOLD).any() or (valley >= STROKE_THRESHOLD).any())

    @property
    def has_water(self) -> bool:
        return bool(self._layers["water"].any())

    def to_sketch_map(self) -> SketchMap:
        """The core sketch map: cells at half intensity or more, ridge winning
        ties (:func:`terrasynth_core.project.stroke_map`, the rule projects
        rendered by the CLI follow too)."""
        return stroke_map(self._layers["ridge"], self._layers["valley"])

    def to_rgb(self, bbox: BBox | None = None) -> np.ndarray:
        """Strokes drawn like a sketch PNG: red ridges, blue valleys on white.

        Parameters
        ----------
        bbox : (r0, r1, c0, c1), optional
            Window to draw; default the whole sketch.

        Returns
        -------
        ndarray of uint8, shape (rows, cols, 3)
        """
        r0, r1, c0, c1 = bbox if bbox is not None else (0, self.shape[0], 0, self.shape[1])
        ridge = self._layers["ridge"][r0:r1, c0:c1].astype(np.uint16)
        valley = self._layers["valley"][r0:r1, c0:c1].astype(np.uint16)
        # White blended towards pure red or blue by the stronger stroke.
        strength = np.maximum(ridge, valley)
        rest = (255 - strength).astype(np.uint8)
        rgb = np.empty(ridge.shape + (3,), np.uint8)
        is_ridge = ridge >= valley
        rgb[..., 0] = np.where(is_ridge, 255, rest)
        rgb[..., 1] = rest
        rgb[..., 2] = np.where(is_ridge, rest, 255)
        return rgb

    def regions_rgba(self, colors: Mapping[int, tuple[int, int, int]], bbox: BBox | None = None) -> np.ndarray:
        """Style regions and water as a translucent overlay.

        Parameters
        ----------
        colors : mapping of style id -> (r, g, b)
            Colour of each style; cells of ids not listed (e.g. a removed
            style's) are left clear.
        bbox : (r0, r1, c0, c1), optional
            Window to draw; default the whole sketch.

        Returns
        -------
        ndarray of uint8, shape (rows, cols, 4)
            Style colours at :data:`STYLE_ALPHA`, water over them in
            :data:`WATER_RGBA`, transparent elsewhere.
        """
        r0, r1, c0, c1 = bbox if bbox is not None else (0, self.shape[0], 0, self.shape[1])
        labels = self._layers["style"][r0:r1, c0:c1]
        top = max([int(k) for k in colors] + [0])
        # Row 0 of the lookup table is "no style"; ids beyond it are clear too.
        lut = np.zeros((top + 2, 4), np.uint8)
        for style_id, rgb in colors.items():
            lut[int(style_id) + 1] = (*rgb, STYLE_ALPHA)
        index = np.where((labels >= 0) & (labels <= top), labels.astype(np.int32) + 1, 0)
        rgba = lut[index]
        rgba[self._layers["water"][r0:r1, c0:c1]] = WATER_RGBA
        return rgba

    # -- strokes ----------------------------------------------------------------
    @property
    def stroking(self) -> bool:
        """True between :meth:`begin_stroke` and :meth:`end_stroke`."""
        return self._stroke is not None

    def begin_stroke(self, tool: Tool, row: float, col: float, *, radius: float = 4.0,
                     hardness: float = 0.8, style: int | None = None) -> None:
        """Start a stroke with a round brush at ``(row, col)`` (cell units).

        Parameters
        ----------
        tool : {"ridge", "valley", "erase", "style", "style_erase", "water", "water_erase"}
            ``erase`` clears ridges and valleys, ``style_erase`` style
            regions, ``water_erase`` water.
        row, col : float
            Brush centre; cell ``(i, j)`` has its centre at ``(i, j)``.
        radius : float, default 4
            Brush radius in cells (at least 0.5).
        hardness : float, default 0.8
            1 paints full intensity up to the radius with a one-cell
            anti-aliased edge; lower values fade the edge over a wider band
            (the whole radius at 0).  Intensity is one half at the radius
            whatever the hardness, so the cells that count as stroked are
            the same; hardness changes how the stroke looks and blends.
            Region tools paint exactly the stroked cells.
        style : int, optional
            Style id the ``style`` tool paints (0 to 32767); required for it.
        """
        if tool not in TOOLS:
            raise ValueError(f"tool {tool!r}: expected one of {', '.join(TOOLS)}")
        if tool == "style" and (style is None or not 0 <= int(style) <= MAX_STYLE_ID):
            raise ValueError(f"the style tool needs a style id from 0 to {MAX_STYLE_ID}, got {style!r}")
        if self._stroke is not None:
            self.end_stroke()
        before = {name: self._layers[name].copy() for name in _TOOL_LAYERS[tool]}
        self._stroke = _Stroke(tool, max(float(radius), 0.5), min(max(float(hardness), 0.0), 1.0),
                               None if style is None else int(style), before, (row, col))
        self._paint_segment((row, col), (row, col))

    def stroke_to(self, row: float, col: float) -> None:
        """Continue the current stroke with a straight segment to ``(row, col)``."""
        if self._stroke is None:
            return
        last = self._stroke.last
        self._stroke.last = (row, col)
        self._paint_segment(last, (row, col))

    def end_stroke(self) -> None:
        """Finish the stroke and record it as one undo step (nothing if it changed nothing)."""
        stroke, self._stroke = self._stroke, None
        if stroke is None or stroke.bbox is None:
            return
        r0, r1, c0, c1 = stroke.bbox
        old = {name: layer[r0:r1, c0:c1].copy() for name, layer in stroke.before.items()}
        new = {name: self._layers[name][r0:r1, c0:c1].copy() for name in stroke.before}
        if all(np.array_equal(old[name], new[name]) for name in old):
            return
        self.history.push(SketchEdit(stroke.bbox, old, new))
        self.history_changed.emit()

    def draw_polyline(self, points: Iterable[tuple[float, float]], tool: Tool, *, radius: float = 4.0,
                      hardness: float = 0.8, style: int | None = None) -> None:
        """Draw straight segments through ``points`` ((row, col) pairs) as one step."""
        pts = [(float(r), float(c)) for r, c in points]
        if not pts:
            return
        self.begin_stroke(tool, *pts[0], radius=radius, hardness=hardness, style=style)
        for r, c in pts[1:]:
            self.stroke_to(r, c)
        self.end_stroke()

    # -- whole-layer edits -------------------------------------------------------
    def clear(self) -> None:
        """Remove every ridge and valley stroke (one undo step); regions stay."""
        self.replace(np.zeros(self.shape, np.uint8), np.zeros(self.shape, np.uint8))

    def replace(self, ridge: np.ndarray, valley: np.ndarray) -> None:
        """Replace both stroke layers, maybe with another shape, as one undo step.

        Style regions and water are kept; for another shape they are
        resized to it (nearest cell), in the same step.
        """
        ridge = np.asarray(ridge)
        valley = np.asarray(valley)
        _check_layers(ridge, valley)
        new = {"ridge": ridge.astype(np.uint8, copy=True), "valley": valley.astype(np.uint8, copy=True)}
        if ridge.shape != self.shape:
            new["style"] = resize_nearest(self._layers["style"], ridge.shape)
            new["water"] = resize_nearest(self._layers["water"], ridge.shape)
        self._replace_layers(new)

    def replace_with_map(self, sketch_map: SketchMap) -> None:
        """Replace the strokes with those of a core sketch map (one undo step)."""
        self.replace(*_layers_of(sketch_map))

    def replace_regions(self, *, style: np.ndarray | None = None, water: np.ndarray | None = None) -> None:
        """Replace the style layer, the water layer or both (one undo step).

        Parameters
        ----------
        style : ndarray of int, shape (rows, cols), optional
            Style ids, -1 for none.
        water : ndarray of bool, shape (rows, cols), optional
        """
        given = {name: arr for name, arr in (("style", style), ("water", water)) if arr is not None}
        if not given:
            return
        layers = _region_layers(self.shape, given.get("style"), given.get("water"))
        self._replace_layers({name: layers[name] for name in given})

    def reset(self, ridge: np.ndarray, valley: np.ndarray, *, style: np.ndarray | None = None,
              water: np.ndarray | None = None) -> None:
        """Replace every layer and forget the history (a document was opened)."""
        ridge = np.asarray(ridge)
        valley = np.asarray(valley)
        _check_layers(ridge, valley)
        self._stroke = None
        self.history.clear()
        layers = {"ridge": ridge.astype(np.uint8, copy=True), "valley": valley.astype(np.uint8, copy=True)}
        layers.update(_region_layers(ridge.shape, style, water))
        self._set_layers(layers)
        self.history_changed.emit()

    # -- undo -------------------------------------------------------------------
    @property
    def replaying(self) -> bool:
        """True while an undo or redo puts layers back (listeners that follow
        sketch edits with their own, recorded in the same step, skip them)."""
        return self._replaying

    def record(self, edit: DocumentEdit) -> None:
        """Record a change of the document outside the layers as its own undo step."""
        self.end_stroke()
        self.history.push(edit)
        self.history_changed.emit()

    def record_with_last(self, edit: DocumentEdit) -> None:
        """Record ``edit`` as part of the last step (a change that follows
        from it, such as pins moved by a resize)."""
        self.history.join(edit)
        self.history_changed.emit()

    @property
    def can_undo(self) -> bool:
        return self.history.can_undo

    @property
    def can_redo(self) -> bool:
        return self.history.can_redo

    def undo(self) -> bool:
        """Revert the last step; False when there was none."""
        return self._replay(self.history.undo, "old")

    def redo(self) -> bool:
        """Apply the last undone step again; False when there was none."""
        return self._replay(self.history.redo, "new")

    def _replay(self, step, side: str) -> bool:
        """Put back the ``side`` (``"old"``: undo, ``"new"``: redo) of the step ``step()`` returns."""
        self.end_stroke()
        edits = step()
        if edits is None:
            return False
        self._replaying = True
        try:
            for edit in (reversed(edits) if side == "old" else edits):
                if isinstance(edit, DocumentEdit):
                    (edit.undo if side == "old" else edit.redo)()
                else:
                    self._apply(edit.bbox, getattr(edit, side))
        finally:
            self._replaying = False
        self.history_changed.emit()
        return True

    # -- internals ----------------------------------------------------------------
    def _replace_layers(self, new: dict[str, np.ndarray]) -> None:
        self.end_stroke()
        edit = SketchEdit(None, {name: self._layers[name] for name in new},
                          {name: layer.copy() for name, layer in new.items()})
        self.history.push(edit)
        self._set_layers(new)
        self.history_changed.emit()

    def _apply(self, bbox: BBox | None, layers: dict[str, np.ndarray]) -> None:
        if bbox is None:
            self._set_layers({name: layer.copy() for name, layer in layers.items()})
            return
        r0, r1, c0, c1 = bbox
        for name, window in layers.items():
            self._layers[name][r0:r1, c0:c1] = window
        self.changed.emit(bbox)

    def _set_layers(self, layers: dict[str, np.ndarray]) -> None:
        self._layers.update(layers)
        self.changed.emit(None)

    def _paint_segment(self, p0: tuple[float, float], p1: tuple[float, float]) -> None:
        stroke = self._stroke
        bbox, coverage = capsule_coverage(self.shape, p0, p1, stroke.radius, stroke.hardness)
        if bbox is None:
            return
        r0, r1, c0, c1 = bbox
        tool = stroke.tool
        if tool in STROKE_TOOLS:
            ridge = self._layers["ridge"][r0:r1, c0:c1]
            valley = self._layers["valley"][r0:r1, c0:c1]
            if tool == "erase":
                keep = 255 - coverage
                np.minimum(ridge, keep, out=ridge)
                np.minimum(valley, keep, out=valley)
            else:
                # Painting one kind over the other replaces it: a cell is a
                # ridge or a valley, never both.
                paint, other = (ridge, valley) if tool == "ridge" else (valley, ridge)
                np.maximum(paint, coverage, out=paint)
                np.minimum(other, 255 - coverage, out=other)
        else:
            brushed = coverage >= STROKE_THRESHOLD
            if tool in ("style", "style_erase"):
                labels = self._layers["style"][r0:r1, c0:c1]
                labels[brushed] = stroke.style if tool == "style" else NO_STYLE
            else:
                water = self._layers["water"][r0:r1, c0:c1]
                water[brushed] = tool == "water"
        stroke.grow(bbox)
        self.changed.emit(bbox)


class _Stroke:
    """State of the stroke being drawn."""

    def __init__(self, tool: Tool, radius: float, hardness: float, style: int | None,
                 before: dict[str, np.ndarray], start: tuple[float, float]) -> None:
        self.tool = tool
        self.radius = radius
        self.hardness = hardness
        self.style = style
        self.before = before  # whole copies of the layers the tool changes
        self.last = start
        self.bbox: BBox | None = None

    def grow(self, bbox: BBox) -> None:
        if self.bbox is None:
            self.bbox = bbox
        else:
            a = self.bbox
            self.bbox = (min(a[0], bbox[0]), max(a[1], bbox[1]), min(a[2], bbox[2]), max(a[3], bbox[3]))


def _check_layers(ridge: np.ndarray, valley: np.ndarray) -> None:
    if ridge.ndim != 2 or ridge.shape != valley.shape or min(ridge.shape) < 2:
        raise SketchError(
            f"sketch layers must be two 2-D grids of the same shape, at least 2x2; "
            f"got {ridge.shape} and {valley.shape}"
        )
    if max(ridge.shape) > MAX_SIDE:
        raise SketchError(f"sketch {ridge.shape[0]}x{ridge.shape[1]} is larger than {MAX_SIDE} cells a side")


def _region_layers(shape: tuple[int, int], style: np.ndarray | None,
                   water: np.ndarray | None) -> dict[str, np.ndarray]:
    """Checked copies of the style and water layers (blank when not given)."""
    if style is None:
        style_layer = np.full(shape, NO_STYLE, np.int16)
    else:
        style = np.asarray(style)
        if style.shape != tuple(shape):
            raise SketchError(f"style layer is {style.shape} but the sketch is {shape[0]}x{shape[1]}")
        if style.size and (style.min() < NO_STYLE or style.max() > MAX_STYLE_ID):
            raise SketchError(f"style layer holds ids from {style.min()} to {style.max()}; "
                              f"expected -1 to {MAX_STYLE_ID}")
        style_layer = style.astype(np.int16, copy=True)
    if water is None:
        water_layer = np.zeros(shape, bool)
    else:
        water = np.asarray(water)
        if water.shape != tuple(shape):
            raise SketchError(f"water layer is {water.shape} but the sketch is {shape[0]}x{shape[1]}")
        water_layer = water.astype(bool, copy=True)
    return {"style": style_layer, "water": water_layer}


def _layers_of(sketch_map: SketchMap) -> tuple[np.ndarray, np.ndarray]:
    ridge = np.where(sketch_map.ridge_mask, 255, 0).astype(np.uint8)
    valley = np.where(sketch_map.valley_mask & ~sketch_map.ridge_mask, 255, 0).astype(np.uint8)
    return ridge, valley
