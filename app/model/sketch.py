"""The sketch being drawn: ridge and valley stroke layers, brushes, history.

Strokes are kept as two ``uint8`` intensity layers (0 = nothing, 255 = full
stroke) rather than bare masks so that a soft brush leaves soft edges on
screen; the sketch map handed to synthesis is thresholded at half intensity,
the same rule the PNG sketch reader applies to anti-aliased strokes.
"""

from __future__ import annotations

from typing import Iterable, Literal

import numpy as np

from terrasynth_core.errors import SketchError
from terrasynth_core.features import SketchMap

from .events import Event
from .history import BBox, SketchEdit, SketchHistory

Tool = Literal["ridge", "valley", "erase"]
TOOLS: tuple[str, ...] = ("ridge", "valley", "erase")

#: Intensity from which a cell counts as stroked.
STROKE_THRESHOLD = 128
#: Largest sketch side accepted, in cells (the core's output limit is 64 M cells).
MAX_SIDE = 8000


class Sketch:
    """Ridge and valley strokes with one-stroke-per-step undo.

    Parameters
    ----------
    ridge, valley : ndarray of uint8, shape (rows, cols)
        Stroke intensities; copied.

    Attributes
    ----------
    changed : Event
        Emitted with the window ``(r0, r1, c0, c1)`` that changed, or
        ``None`` when the whole sketch (maybe its shape) changed.
    history_changed : Event
        Emitted with no argument when undo/redo availability may have changed.
    """

    def __init__(self, ridge: np.ndarray, valley: np.ndarray) -> None:
        ridge = np.asarray(ridge)
        valley = np.asarray(valley)
        _check_layers(ridge, valley)
        self._ridge = ridge.astype(np.uint8, copy=True)
        self._valley = valley.astype(np.uint8, copy=True)
        self.history = SketchHistory()
        self.changed = Event()
        self.history_changed = Event()
        self._stroke: _Stroke | None = None

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
        return self._ridge.shape

    @property
    def ridge(self) -> np.ndarray:
        """Ridge intensities, uint8 (rows, cols); a read-only view."""
        view = self._ridge.view()
        view.flags.writeable = False
        return view

    @property
    def valley(self) -> np.ndarray:
        """Valley intensities, uint8 (rows, cols); a read-only view."""
        view = self._valley.view()
        view.flags.writeable = False
        return view

    @property
    def has_strokes(self) -> bool:
        return bool((self._ridge >= STROKE_THRESHOLD).any() or (self._valley >= STROKE_THRESHOLD).any())

    def to_sketch_map(self) -> SketchMap:
        """The core sketch map: cells at half intensity or more, ridge winning ties."""
        ridge = (self._ridge >= STROKE_THRESHOLD) & (self._ridge >= self._valley)
        valley = (self._valley >= STROKE_THRESHOLD) & ~ridge
        return SketchMap(ridge, valley)

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
        ridge = self._ridge[r0:r1, c0:c1].astype(np.uint16)
        valley = self._valley[r0:r1, c0:c1].astype(np.uint16)
        # White blended towards pure red or blue by the stronger stroke.
        strength = np.maximum(ridge, valley)
        rest = (255 - strength).astype(np.uint8)
        rgb = np.empty(ridge.shape + (3,), np.uint8)
        is_ridge = ridge >= valley
        rgb[..., 0] = np.where(is_ridge, 255, rest)
        rgb[..., 1] = rest
        rgb[..., 2] = np.where(is_ridge, rest, 255)
        return rgb

    # -- strokes ----------------------------------------------------------------
    @property
    def stroking(self) -> bool:
        """True between :meth:`begin_stroke` and :meth:`end_stroke`."""
        return self._stroke is not None

    def begin_stroke(self, tool: Tool, row: float, col: float, *, radius: float = 4.0,
                     hardness: float = 0.8) -> None:
        """Start a stroke with a round brush at ``(row, col)`` (cell units).

        Parameters
        ----------
        tool : {"ridge", "valley", "erase"}
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
        """
        if tool not in TOOLS:
            raise ValueError(f"tool {tool!r}: expected one of {', '.join(TOOLS)}")
        if self._stroke is not None:
            self.end_stroke()
        self._stroke = _Stroke(tool, max(float(radius), 0.5), min(max(float(hardness), 0.0), 1.0),
                               self._ridge.copy(), self._valley.copy(), (row, col))
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
        old_r = stroke.ridge_before[r0:r1, c0:c1]
        old_v = stroke.valley_before[r0:r1, c0:c1]
        new_r = self._ridge[r0:r1, c0:c1]
        new_v = self._valley[r0:r1, c0:c1]
        if np.array_equal(old_r, new_r) and np.array_equal(old_v, new_v):
            return
        self.history.push(SketchEdit(stroke.bbox, old_r.copy(), old_v.copy(), new_r.copy(), new_v.copy()))
        self.history_changed.emit()

    def draw_polyline(self, points: Iterable[tuple[float, float]], tool: Tool, *, radius: float = 4.0,
                      hardness: float = 0.8) -> None:
        """Draw straight segments through ``points`` ((row, col) pairs) as one step."""
        pts = [(float(r), float(c)) for r, c in points]
        if not pts:
            return
        self.begin_stroke(tool, *pts[0], radius=radius, hardness=hardness)
        for r, c in pts[1:]:
            self.stroke_to(r, c)
        self.end_stroke()

    # -- whole-sketch edits -----------------------------------------------------
    def clear(self) -> None:
        """Remove every stroke (one undo step)."""
        self.replace(np.zeros(self.shape, np.uint8), np.zeros(self.shape, np.uint8))

    def replace(self, ridge: np.ndarray, valley: np.ndarray) -> None:
        """Replace both layers, maybe with another shape, as one undo step."""
        ridge = np.asarray(ridge)
        valley = np.asarray(valley)
        _check_layers(ridge, valley)
        self.end_stroke()
        edit = SketchEdit(None, self._ridge, self._valley, ridge.astype(np.uint8, copy=True),
                          valley.astype(np.uint8, copy=True))
        self.history.push(edit)
        self._set_layers(edit.new_ridge.copy(), edit.new_valley.copy())
        self.history_changed.emit()

    def replace_with_map(self, sketch_map: SketchMap) -> None:
        """Replace the strokes with those of a core sketch map (one undo step)."""
        self.replace(*_layers_of(sketch_map))

    def reset(self, ridge: np.ndarray, valley: np.ndarray) -> None:
        """Replace both layers and forget the history (a document was opened)."""
        ridge = np.asarray(ridge)
        valley = np.asarray(valley)
        _check_layers(ridge, valley)
        self._stroke = None
        self.history.clear()
        self._set_layers(ridge.astype(np.uint8, copy=True), valley.astype(np.uint8, copy=True))
        self.history_changed.emit()

    # -- undo -------------------------------------------------------------------
    @property
    def can_undo(self) -> bool:
        return self.history.can_undo

    @property
    def can_redo(self) -> bool:
        return self.history.can_redo

    def undo(self) -> bool:
        """Revert the last step; False when there was none."""
        self.end_stroke()
        edit = self.history.undo()
        if edit is None:
            return False
        self._apply(edit.bbox, edit.old_ridge, edit.old_valley)
        self.history_changed.emit()
        return True

    def redo(self) -> bool:
        """Apply the last undone step again; False when there was none."""
        self.end_stroke()
        edit = self.history.redo()
        if edit is None:
            return False
        self._apply(edit.bbox, edit.new_ridge, edit.new_valley)
        self.history_changed.emit()
        return True

    # -- internals ----------------------------------------------------------------
    def _apply(self, bbox: BBox | None, ridge: np.ndarray, valley: np.ndarray) -> None:
        if bbox is None:
            self._set_layers(ridge.copy(), valley.copy())
            return
        r0, r1, c0, c1 = bbox
        self._ridge[r0:r1, c0:c1] = ridge
        self._valley[r0:r1, c0:c1] = valley
        self.changed.emit(bbox)

    def _set_layers(self, ridge: np.ndarray, valley: np.ndarray) -> None:
        self._ridge = ridge
        self._valley = valley
        self.changed.emit(None)

    def _paint_segment(self, p0: tuple[float, float], p1: tuple[float, float]) -> None:
        stroke = self._stroke
        bbox, coverage = capsule_coverage(self.shape, p0, p1, stroke.radius, stroke.hardness)
        if bbox is None:
            return
        r0, r1, c0, c1 = bbox
        ridge = self._ridge[r0:r1, c0:c1]
        valley = self._valley[r0:r1, c0:c1]
        if stroke.tool == "erase":
            keep = 255 - coverage
            np.minimum(ridge, keep, out=ridge)
            np.minimum(valley, keep, out=valley)
        else:
            # Painting one kind over the other replaces it: a cell is a ridge
            # or a valley, never both.
            paint, other = (ridge, valley) if stroke.tool == "ridge" else (valley, ridge)
            np.maximum(paint, coverage, out=paint)
            np.minimum(other, 255 - coverage, out=other)
        stroke.grow(bbox)
        self.changed.emit(bbox)


class _Stroke:
    """State of the stroke being drawn."""

    def __init__(self, tool: Tool, radius: float, hardness: float, ridge_before: np.ndarray,
                 valley_before: np.ndarray, start: tuple[float, float]) -> None:
        self.tool = tool
        self.radius = radius
        self.hardness = hardness
        self.ridge_before = ridge_before
        self.valley_before = valley_before
        self.last = start
        self.bbox: BBox | None = None

    def grow(self, bbox: BBox) -> None:
        if self.bbox is None:
            self.bbox = bbox
        else:
            a = self.bbox
            self.bbox = (min(a[0], bbox[0]), max(a[1], bbox[1]), min(a[2], bbox[2]), max(a[3], bbox[3]))


def capsule_coverage(shape: tuple[int, int], p0: tuple[float, float], p1: tuple[float, float],
                     radius: float, hardness: float) -> tuple[BBox | None, np.ndarray]:
    """Brush intensity of a round brush dragged from ``p0`` to ``p1``.

    Parameters
    ----------
    shape : (rows, cols)
        Grid the brush paints on.
    p0, p1 : (row, col)
        Segment ends in cell units.
    radius : float
        Brush radius in cells.
    hardness : float in [0, 1]
        Width of the linear fall-off is ``(1 - hardness) * radius`` cells
        (at least one); intensity is one half at the radius.

    Returns
    -------
    bbox : (r0, r1, c0, c1) or None
        Window of cells the brush reaches inside the grid (None if none).
    coverage : ndarray of uint8, shape of ``bbox``
        Intensity 0-255 of the brush on each cell of the window.
    """
    rows, cols = shape
    (ra, ca), (rb, cb) = p0, p1
    # Intensity falls linearly over ``falloff`` cells centred on the radius,
    # so the stroked cells (at least half intensity) are those within the
    # radius for any hardness.  At least one cell of fall-off even for a hard
    # brush: an anti-aliased edge.
    falloff = max((1.0 - hardness) * radius, 1.0)
    reach = radius + 0.5 * falloff
    r0 = max(int(np.floor(min(ra, rb) - reach)), 0)
    r1 = min(int(np.ceil(max(ra, rb) + reach)) + 1, rows)
    c0 = max(int(np.floor(min(ca, cb) - reach)), 0)
    c1 = min(int(np.ceil(max(ca, cb) + reach)) + 1, cols)
    if r0 >= r1 or c0 >= c1:
        return None, np.zeros((0, 0), np.uint8)
    rr, cc = np.ogrid[r0:r1, c0:c1]
    dr, dc = rb - ra, cb - ca
    length2 = dr * dr + dc * dc
    if length2 > 0:
        t = np.clip(((rr - ra) * dr + (cc - ca) * dc) / length2, 0.0, 1.0)
    else:
        t = 0.0
    dist = np.hypot(rr - (ra + t * dr), cc - (ca + t * dc))
    coverage = np.clip((radius - dist) / falloff + 0.5, 0.0, 1.0)
    coverage = np.rint(coverage * 255).astype(np.uint8)
    if not coverage.any():
        return None, np.zeros((0, 0), np.uint8)
    return (r0, r1, c0, c1), coverage


def _check_layers(ridge: np.ndarray, valley: np.ndarray) -> None:
    if ridge.ndim != 2 or ridge.shape != valley.shape or min(ridge.shape) < 2:
        raise SketchError(
            f"sketch layers must be two 2-D grids of the same shape, at least 2x2; "
            f"got {ridge.shape} and {valley.shape}"
        )
    if max(ridge.shape) > MAX_SIDE:
        raise SketchError(f"sketch {ridge.shape[0]}x{ridge.shape[1]} is larger than {MAX_SIDE} cells a side")


def _layers_of(sketch_map: SketchMap) -> tuple[np.ndarray, np.ndarray]:
    ridge = np.where(sketch_map.ridge_mask, 255, 0).astype(np.uint8)
    valley = np.where(sketch_map.valley_mask & ~sketch_map.ridge_mask, 255, 0).astype(np.uint8)
    return ridge, valley
