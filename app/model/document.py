"""The document: sketch and regions, examples, styles, pins, stamps,
parameters and the last result.

Views subscribe to its events and translate user actions into its methods;
nothing here knows about Qt, so the whole editing logic is testable with
plain pytest.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Sequence

import numpy as np

from terrasynth_core.controls.options import check_height_range
from terrasynth_core.errors import ParamsError
from terrasynth_core.examples import DEFAULT_EXAMPLE, DEFAULT_SKETCH, resource_path
from terrasynth_core.features import SketchMap, read_sketch
from terrasynth_core.project import resize_pins, resize_stamps, run_spec, stroke_map
from terrasynth_core.synthesis import Pin, SynthesisParams

from .control_specs import STYLE_PALETTE, StampSpec, StyleSpec
from .example_library import ExampleRef, chosen_cell_size
from .observable import Observable
from .result import TerrainResult
from .run_request import SynthesisRequest
from .brushes import capsule_coverage
from .history import DocumentEdit
from .sketch_layers import MAX_STYLE_ID, Sketch

#: Marks "keep the current value" for keyword arguments that accept None.
_KEEP = object()


class Document:
    """Everything a project file holds, with change events.

    Parameters
    ----------
    sketch : Sketch
        Strokes, style regions and water.
    examples : list of ExampleRef
        The plain examples: the style of every cell no style region claims.
    params : SynthesisParams, optional
    result : TerrainResult or None, optional
    path : Path or None, optional
        File the document was read from or last saved to.
    styles : sequence of StyleSpec, optional
        Styles the sketch's style layer refers to by id.
    water_level : float, default 0
        Level of the painted water, metres.
    height_range : (low, high) or None, optional
        Final heights are mapped onto it, metres.
    pins : sequence of Pin, optional
        Wanted heights at output cells.
    stamps : sequence of StampSpec, optional
        DEMs placed as they are.
    next_style_id : int, default 0
        Lowest id a new style may take (ids are never reused).

    Attributes
    ----------
    changed : Observable
        Emitted with what changed: ``"examples"``, ``"params"``,
        ``"result"``, ``"styles"``, ``"water_level"``, ``"height_range"``,
        ``"pins"``, ``"stamps"``, ``"selection"``, ``"path"`` or ``"dirty"``
        (the unsaved-changes flag).  Sketch edits are announced by
        ``document.sketch.changed``.  The selection is saved in projects
        but changing it does not make the document dirty.

    Notes
    -----
    Removing a style is undoable with the strokes (one step in the
    sketch's history), and when the sketch changes size the pins and
    stamps move (and stamps scale) with it, in the same undo step
    (:func:`terrasynth_core.project.resize_pins`, ``resize_stamps``).
    """

    def __init__(self, sketch: Sketch, examples: list[ExampleRef], *, params: SynthesisParams | None = None,
                 result: TerrainResult | None = None, path: Path | None = None,
                 styles: Sequence[StyleSpec] = (), water_level: float = 0.0,
                 height_range: tuple[float, float] | None = None, pins: Sequence[Pin] = (),
                 stamps: Sequence[StampSpec] = (), next_style_id: int = 0) -> None:
        self.sketch = sketch
        self._examples = list(examples)
        self._params = params if params is not None else SynthesisParams()
        self._result = result
        self._path = Path(path) if path is not None else None
        self._styles = list(styles)
        self._water_level = _finite(water_level, "water level")
        self._height_range = check_height_range(height_range)
        self._pins = list(pins)
        self._stamps = list(stamps)
        self._next_style_id = int(next_style_id)
        self._selection: np.ndarray | None = None
        self._result_strokes = self._strokes_now() if result is not None else None
        # The grid pins and stamps are placed on: they follow the sketch when it changes size.
        self._shape = sketch.shape
        self.changed = Observable()
        # Every change bumps the generation; the document is dirty while it
        # differs from the generation last saved.
        self._generation = 0
        self._saved_generation = 0
        self.sketch.changed.connect(self._sketch_changed)

    @classmethod
    def default(cls) -> "Document":
        """The first-start document: the default built-in example and sketch."""
        sketch = Sketch.from_sketch_map(read_sketch(resource_path("sketches", DEFAULT_SKETCH)))
        return cls(sketch, [ExampleRef(builtin=DEFAULT_EXAMPLE)])

    # -- properties ---------------------------------------------------------------
    @property
    def examples(self) -> list[ExampleRef]:
        return list(self._examples)

    @property
    def params(self) -> SynthesisParams:
        return self._params

    @property
    def result(self) -> TerrainResult | None:
        return self._result

    @property
    def path(self) -> Path | None:
        return self._path

    @property
    def styles(self) -> list[StyleSpec]:
        return list(self._styles)

    @property
    def water_level(self) -> float:
        return self._water_level

    @property
    def height_range(self) -> tuple[float, float] | None:
        return self._height_range

    @property
    def pins(self) -> list[Pin]:
        return list(self._pins)

    @property
    def stamps(self) -> list[StampSpec]:
        return list(self._stamps)

    @property
    def next_style_id(self) -> int:
        """Id the next added style gets: above every id used so far."""
        layer_max = int(self.sketch.style.max()) if self.sketch.style.size else -1
        return max([self._next_style_id, layer_max + 1] + [s.id + 1 for s in self._styles])

    @property
    def selection(self) -> np.ndarray | None:
        """Cells chosen for re-synthesis, bool (rows, cols) read-only, or None."""
        if self._selection is None:
            return None
        view = self._selection.view()
        view.flags.writeable = False
        return view

    @property
    def output_shape(self) -> tuple[int, int]:
        """Size of the terrain to synthesize: the sketch's."""
        return self.sketch.shape

    def cell_size(self) -> float | None:
        """The output's square cell size in metres as far as the loaded DEMs
        tell (:func:`.example_library.chosen_cell_size` over the examples,
        styles and stamps)."""
        refs = [*self._examples, *(s.example for s in self._styles), *(s.example for s in self._stamps)]
        return chosen_cell_size(self._params.cell_size, refs)

    @property
    def generation(self) -> int:
        """Counter bumped by every change (autosave compares it)."""
        return self._generation

    @property
    def dirty(self) -> bool:
        """True when there are changes not saved to :attr:`path`."""
        return self._generation != self._saved_generation

    @property
    def title(self) -> str:
        """File name for the window title, ``"Untitled"`` before the first save."""
        return self._path.name if self._path is not None else "Untitled"

    # -- examples, parameters, result ------------------------------------------------
    def set_examples(self, examples: list[ExampleRef]) -> None:
        examples = list(examples)
        if examples == self._examples:
            return
        self._examples = examples
        self._touch("examples")

    def add_example(self, example: ExampleRef) -> None:
        """Add ``example`` unless it is already chosen."""
        if example not in self._examples:
            self.set_examples(self._examples + [example])

    def remove_example(self, example: ExampleRef) -> None:
        self.set_examples([e for e in self._examples if e != example])

    def set_params(self, params: SynthesisParams) -> None:
        if not isinstance(params, SynthesisParams):
            raise ParamsError(f"params must be SynthesisParams, got {type(params).__name__}")
        if params == self._params:
            return
        self._params = params
        self._touch("params")

    @property
    def result_strokes(self) -> SketchMap | None:
        """The ridge and valley strokes the result was made from (None: no
        strokes, or no result); live sketching re-makes what differs."""
        return self._result_strokes

    def set_result(self, result: TerrainResult | None, *, strokes: SketchMap | None | object = _KEEP) -> None:
        """Make ``result`` the terrain.

        Parameters
        ----------
        result : TerrainResult or None
        strokes : SketchMap or None, optional
            The strokes it was made from (a run's request knows them);
            default the sketch's strokes now (a variation, a project).
        """
        self._result = result
        self._result_strokes = self._strokes_now() if strokes is _KEEP else strokes
        self._touch("result")

    def _strokes_now(self) -> SketchMap | None:
        sketch_map = stroke_map(self.sketch.ridge, self.sketch.valley)
        return sketch_map if sketch_map.has_strokes else None

    # -- styles ---------------------------------------------------------------------------
    def style(self, style_id: int) -> StyleSpec:
        """The style with ``style_id``.

        Raises
        ------
        KeyError
            When there is none.
        """
        for spec in self._styles:
            if spec.id == style_id:
                return spec
        raise KeyError(f"no style with id {style_id}")

    def add_style(self, example: ExampleRef, *, name: str | None = None, color: str | None = None,
                  relief_scale: float = 1.0, base: float | None = None) -> StyleSpec:
        """Add a style with a new id; the name defaults to the example's, the
        colour to the first palette colour not in use."""
        style_id = self.next_style_id
        if style_id > MAX_STYLE_ID:
            raise ParamsError(f"no style ids left (the largest is {MAX_STYLE_ID})")
        if color is None:
            taken = {s.color for s in self._styles}
            free = [c for c in STYLE_PALETTE if c not in taken]
            color = free[0] if free else STYLE_PALETTE[len(self._styles) % len(STYLE_PALETTE)]
        spec = StyleSpec(style_id, example.label if name is None else name, color, example, relief_scale, base)
        self._styles.append(spec)
        self._next_style_id = style_id + 1
        self._touch("styles")
        return spec

    def update_style(self, style_id: int, **changes) -> StyleSpec:
        """Change fields of a style (``name``, ``color``, ``example``,
        ``relief_scale``, ``base``); its id stays."""
        if "id" in changes:
            raise ParamsError("a style's id cannot change")
        old = self.style(style_id)
        new = dataclasses.replace(old, **changes)
        if new != old:
            self._styles[self._styles.index(old)] = new
            self._touch("styles")
        return new

    def remove_style(self, style_id: int) -> None:
        """Remove a style; its painted cells fall back to the plain examples
        (ids are never reused, so they never turn into another style)."""
        spec = self.style(style_id)
        index = self._styles.index(spec)

        def remove() -> None:
            self._styles.remove(spec)
            self._touch("styles")

        def put_back() -> None:
            self._styles.insert(min(index, len(self._styles)), spec)
            self._touch("styles")

        remove()
        self.sketch.record(DocumentEdit(undo=put_back, redo=remove))

    # -- water and height range ------------------------------------------------------
    def set_water_level(self, level: float) -> None:
        level = _finite(level, "water level")
        if level != self._water_level:
            self._water_level = level
            self._touch("water_level")

    def suggested_water_level(self) -> float | None:
        """A level from the current terrain: the median height under the
        painted water, or the 10th percentile of all heights when none is
        painted; None without a terrain of the sketch's size."""
        result = self._result
        if result is None or result.shape != self.output_shape:
            return None
        water = self.sketch.water
        heights = result.heights[water] if water.any() else result.heights
        return round(float(np.percentile(heights, 50 if water.any() else 10)), 1)

    def set_height_range(self, height_range: tuple[float, float] | None) -> None:
        height_range = check_height_range(height_range)
        if height_range != self._height_range:
            self._height_range = height_range
            self._touch("height_range")

    # -- pins -----------------------------------------------------------------------------
    def add_pin(self, row: int, col: int, height: float) -> Pin:
        """Pin cell ``(row, col)`` to ``height`` metres (replacing a pin on that cell)."""
        rows, cols = self.output_shape
        row, col = int(row), int(col)
        if not (0 <= row < rows and 0 <= col < cols):
            raise ParamsError(f"pin at ({row}, {col}) is outside the {rows}x{cols} output")
        pin = Pin(row, col, _finite(height, "pin height"))
        self._pins = [p for p in self._pins if (p.row, p.col) != (row, col)] + [pin]
        self._touch("pins")
        return pin

    def update_pin(self, index: int, height: float) -> None:
        old = self._pins[index]
        self._pins[index] = Pin(old.row, old.col, _finite(height, "pin height"))
        if self._pins[index] != old:
            self._touch("pins")

    def remove_pin(self, index: int) -> None:
        del self._pins[index]
        self._touch("pins")

    # -- stamps ---------------------------------------------------------------------------
    def add_stamp(self, stamp: StampSpec) -> None:
        rows, cols = self.output_shape
        r, c = stamp.center
        if not (0 <= r < rows and 0 <= c < cols):
            raise ParamsError(f"stamp centre ({r:g}, {c:g}) is outside the {rows}x{cols} output")
        self._stamps.append(stamp)
        self._touch("stamps")

    def update_stamp(self, index: int, **changes) -> StampSpec:
        """Change fields of stamp ``index`` (``center``, ``rotation``, ``scale``...)."""
        old = self._stamps[index]
        new = dataclasses.replace(old, **changes)
        if new != old:
            self._stamps[index] = new
            self._touch("stamps")
        return new

    def remove_stamp(self, index: int) -> None:
        del self._stamps[index]
        self._touch("stamps")

    # -- selection --------------------------------------------------------------------------
    def set_selection(self, mask: np.ndarray | None) -> None:
        """Replace the selection (None or an all-False mask clears it)."""
        if mask is not None:
            mask = np.asarray(mask, dtype=bool)
            if mask.shape != self.output_shape:
                raise ParamsError(f"selection is {mask.shape} but the output is "
                                  f"{self.output_shape[0]}x{self.output_shape[1]}")
            mask = mask.copy() if mask.any() else None
        self._selection = mask
        self.changed.emit("selection")

    def select_rect(self, r0: int, r1: int, c0: int, c1: int, *, add: bool = False) -> None:
        """Select the half-open window rows ``r0:r1``, columns ``c0:c1``
        (clipped to the output); ``add`` keeps what was selected."""
        rows, cols = self.output_shape
        mask = self._selection.copy() if add and self._selection is not None else np.zeros((rows, cols), bool)
        mask[max(int(r0), 0):min(int(r1), rows), max(int(c0), 0):min(int(c1), cols)] = True
        self.set_selection(mask)

    def paint_selection(self, p0: tuple[float, float], p1: tuple[float, float], *, radius: float,
                        add: bool = True) -> None:
        """Add (or with ``add=False`` remove) the cells a round brush of
        ``radius`` cells covers from ``p0`` to ``p1`` ((row, col))."""
        bbox, coverage = capsule_coverage(self.output_shape, p0, p1, max(float(radius), 0.5), 1.0)
        if bbox is None:
            return
        mask = self._selection.copy() if self._selection is not None else np.zeros(self.output_shape, bool)
        r0, r1, c0, c1 = bbox
        mask[r0:r1, c0:c1][coverage >= 128] = add
        self.set_selection(mask)

    def clear_selection(self) -> None:
        if self._selection is not None:
            self.set_selection(None)

    # -- files ------------------------------------------------------------------------------
    def mark_saved(self, path: Path) -> None:
        """Record that the document was written to ``path``."""
        self._path = Path(path)
        self._saved_generation = self._generation
        self.changed.emit("path")
        self.changed.emit("dirty")

    def mark_unsaved(self) -> None:
        """Flag changes that are not in :attr:`path` (e.g. after recovery)."""
        self._touch("dirty")

    def assign(self, other: "Document") -> None:
        """Take over ``other``'s contents (a project was opened).

        The sketch object stays the same, so views stay connected; its history
        is cleared, and so is the selection.  The result is clean unless
        ``other`` was dirty.
        """
        s = other.sketch
        # Set before the layers change, so the pins are not moved as for a resize.
        self._shape = s.shape
        self._pins = other.pins
        self._stamps = other.stamps
        self.sketch.reset(s.ridge, s.valley, style=s.style, water=s.water)
        self._examples = other.examples
        self._params = other.params
        self._result = other.result
        self._result_strokes = other.result_strokes
        self._path = other.path
        self._styles = other.styles
        self._water_level = other.water_level
        self._height_range = other.height_range
        self._pins = other.pins
        self._stamps = other.stamps
        self._next_style_id = other.next_style_id
        self._selection = None if other.selection is None else np.array(other.selection)
        self._generation += 1
        self._saved_generation = self._generation if not other.dirty else -1
        for what in ("examples", "params", "styles", "water_level", "height_range", "pins", "stamps", "result",
                     "selection", "path", "dirty"):
            self.changed.emit(what)

    def snapshot(self, *, path: Path | None | object = _KEEP) -> "Document":
        """A copy whose sketch no later edit can touch (for autosaving on a
        thread, or recovery); ``path`` replaces the file it belongs to.

        The result's arrays are shared: nothing writes into a result.
        """
        s = self.sketch
        copy = Document(Sketch(s.ridge, s.valley, style=s.style, water=s.water), self._examples,
                        params=self._params, result=self._result, path=self._path if path is _KEEP else path,
                        styles=self._styles, water_level=self._water_level, height_range=self._height_range,
                        pins=self._pins, stamps=self._stamps, next_style_id=self.next_style_id)
        copy._selection = None if self._selection is None else self._selection.copy()
        if self.dirty:
            copy.mark_unsaved()
        return copy

    # -- synthesis --------------------------------------------------------------------
    def synthesis_request(self) -> SynthesisRequest:
        """A snapshot of what to synthesize, safe to hand to a worker thread.

        Raises
        ------
        ParamsError
            When no example is chosen and styles do not cover the sketch.
        """
        s = self.sketch
        # The core's rule (terrasynth_core.project.run_spec), which
        # ``terrasynth-cli synth --project`` follows too.
        spec = run_spec(ridge=s.ridge, valley=s.valley, style=s.style, water=s.water, examples=self._examples,
                        params=self._params, styles=self._styles, water_level=self._water_level,
                        height_range=self._height_range, pins=self._pins, stamps=self._stamps)
        return SynthesisRequest(**{f.name: getattr(spec, f.name) for f in dataclasses.fields(spec)})

    def resynthesis_request(self, seed: int) -> SynthesisRequest:
        """What to synthesize to replace the selected cells of the current
        terrain with a new variant (seed ``seed``); the rest stays as it is.

        Raises
        ------
        ParamsError
            No terrain, a terrain of another size than the sketch, or no
            selection.
        """
        result = self._result
        if result is None:
            raise ParamsError("there is no terrain to change: synthesize one first")
        if result.shape != self.output_shape:
            raise ParamsError(f"the terrain is {result.shape[0]}x{result.shape[1]} but the sketch is "
                              f"{self.output_shape[0]}x{self.output_shape[1]}: synthesize it again first")
        if self._selection is None:
            raise ParamsError("nothing is selected: select the part of the terrain to synthesize again")
        request = self.synthesis_request()
        params = result.params_for_change(dataclasses.replace(self._params, seed=int(seed)))
        return dataclasses.replace(request, params=params, previous=result.heights, selection=self._selection.copy())

    # -- internals --------------------------------------------------------------------
    def _touch(self, what: str) -> None:
        was_dirty = self.dirty
        self._generation += 1
        if what != "dirty":
            self.changed.emit(what)
        if not was_dirty or what == "dirty":
            self.changed.emit("dirty")

    def _sketch_changed(self, bbox) -> None:
        # During a stroke the sketch changes on every mouse move; the document
        # only needs to know it is dirty.
        was_dirty = self.dirty
        self._generation += 1
        if not was_dirty:
            self.changed.emit("dirty")
        if bbox is None and self._selection is not None and self._selection.shape != self.output_shape:
            self.set_selection(None)
        if bbox is None and self.sketch.shape != self._shape:
            old, self._shape = self._shape, self.sketch.shape
            if not self.sketch.replaying:  # an undo or redo puts pins and stamps back itself
                self._follow_resize(old, self._shape)

    def _follow_resize(self, old: tuple[int, int], new: tuple[int, int]) -> None:
        """Move pins and stamps from the ``old`` grid to the ``new`` one, in the
        resize's undo step."""
        before = (list(self._pins), list(self._stamps))
        after = (resize_pins(self._pins, old, new), resize_stamps(self._stamps, old, new))
        if after == before:
            return

        def put(state) -> None:
            pins, stamps = state
            if pins != self._pins:
                self._pins = list(pins)
                self._touch("pins")
            if stamps != self._stamps:
                self._stamps = list(stamps)
                self._touch("stamps")

        put(after)
        self.sketch.record_with_last(DocumentEdit(undo=lambda: put(before), redo=lambda: put(after)))


def _finite(value: float, what: str) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ParamsError(f"{what} must be a finite number of metres, got {value}")
    return value
