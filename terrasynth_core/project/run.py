"""How a project's layers and controls become a synthesis run.

One home for the rules the app and ``terrasynth-cli synth --project``
share: which painted cells count as strokes (:func:`stroke_map`), which
styles a run uses and the label map that points at them
(:func:`painted_styles`), and the run itself (:class:`RunSpec`), whose
:meth:`~RunSpec.make_session` reads the DEMs and builds the validated core
:class:`~terrasynth_core.synthesis.Session`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from ..errors import ParamsError
from ..features import SketchMap
from ..synthesis import Controls, Pin, Session, SynthesisParams, Water
from .footprints import check_stamp_footprints
from .refs import ExampleRef
from .resize import resize_pins, resize_stamps
from .specs import StampSpec, StyleSpec

__all__ = ["STROKE_THRESHOLD", "RunSpec", "painted_styles", "run_spec", "stroke_map"]

#: Intensity (0-255) from which a painted cell counts as stroked: the rule
#: the PNG sketch reader applies to anti-aliased strokes.
STROKE_THRESHOLD = 128


def stroke_map(ridge: np.ndarray, valley: np.ndarray) -> SketchMap:
    """The core sketch map of two stroke-intensity layers.

    Parameters
    ----------
    ridge, valley : ndarray of uint8, shape (rows, cols)
        Stroke intensities, 0 nothing to 255 a full stroke.

    Returns
    -------
    SketchMap
        Cells at :data:`STROKE_THRESHOLD` or more; a ridge wins a tie.
    """
    ridge_mask = (ridge >= STROKE_THRESHOLD) & (ridge >= valley)
    valley_mask = (valley >= STROKE_THRESHOLD) & ~ridge_mask
    return SketchMap(ridge_mask, valley_mask)


def painted_styles(style_layer: np.ndarray,
                   styles: Sequence[StyleSpec]) -> tuple[tuple[StyleSpec, ...], np.ndarray | None]:
    """The styles painted somewhere and the core's label map.

    Parameters
    ----------
    style_layer : ndarray of int16, shape (rows, cols)
        Style id per cell, -1 for none (cells of a removed style's id count
        as none).
    styles : sequence of StyleSpec

    Returns
    -------
    used : tuple of StyleSpec
        The styles with at least one cell, in the order of ``styles``.
    style_map : ndarray of int16, shape (rows, cols), or None
        Index into ``used`` per cell, -1 elsewhere; None when no style is
        painted.
    """
    labels = style_layer.astype(np.int32) + 1  # 0 = no style
    counts = np.bincount(labels.ravel(), minlength=1)
    used = tuple(s for s in styles if s.id + 1 < counts.size and counts[s.id + 1])
    if not used:
        return (), None
    lut = np.full(counts.size, -1, np.int16)
    for index, spec in enumerate(used):
        lut[spec.id + 1] = index
    return used, lut[labels]


@dataclass(frozen=True, eq=False)
class RunSpec:
    """Immutable inputs of one run, DEMs by reference.

    :meth:`make_session` does the slow part (reading and analysing the
    DEMs): the app calls it on a worker thread.

    Parameters
    ----------
    examples : tuple of ExampleRef
    sketch_map : SketchMap or None
    shape : (rows, cols)
    params : SynthesisParams
    styles : tuple of StyleSpec
        The styles painted somewhere, in ``style_map`` index order.
    style_map : ndarray of int16, shape (rows, cols), or None
        Index into ``styles`` per cell, -1 for the plain examples.
    water : ndarray of bool, shape (rows, cols), or None
    water_level : float
    height_range : (low, high) or None
    pins : tuple of Pin
    stamps : tuple of StampSpec
    previous : ndarray of float32, shape (rows, cols), or None
        For a re-synthesis: the terrain to keep outside ``selection``.
    selection : ndarray of bool, shape (rows, cols), or None
    """

    examples: tuple[ExampleRef, ...]
    sketch_map: SketchMap | None
    shape: tuple[int, int]
    params: SynthesisParams
    styles: tuple[StyleSpec, ...] = ()
    style_map: np.ndarray | None = None
    water: np.ndarray | None = None
    water_level: float = 0.0
    height_range: tuple[float, float] | None = None
    pins: tuple[Pin, ...] = ()
    stamps: tuple[StampSpec, ...] = ()
    previous: np.ndarray | None = None
    selection: np.ndarray | None = None

    def at_size(self, size: tuple[int, int]) -> RunSpec:
        """This run made at ``size`` (rows, cols) instead of :attr:`shape`:
        pins and stamps follow the sketch, as when the app resizes it (the
        painted maps are scaled by the run itself)."""
        size = (int(size[0]), int(size[1]))
        if size == tuple(self.shape):
            return self
        return replace(self, shape=size, pins=tuple(resize_pins(self.pins, self.shape, size)),
                       stamps=tuple(resize_stamps(self.stamps, self.shape, size)))

    def make_controls(self) -> Controls:
        """The core controls, style and stamp DEMs read (slow)."""
        return Controls(
            styles=tuple(spec.to_core() for spec in self.styles),
            style_map=self.style_map,
            water=Water(self.water, self.water_level) if self.water is not None else None,
            stamps=tuple(spec.to_core() for spec in self.stamps),
            pins=self.pins,
            height_range=self.height_range,
            previous=self.previous,
            selection=self.selection,
        )

    def example_fields(self) -> list:
        """The height fields of the plain examples (slow)."""
        return [ref.load() for ref in self.examples]

    def source_fields(self) -> list:
        """The height fields of the plain examples, then of the styles (slow)."""
        return self.example_fields() + [spec.example.load() for spec in self.styles]

    def make_session(self) -> Session:
        """Load the DEMs and build the validated core session.

        Raises
        ------
        TerraSynthError
            For an unreadable DEM or inconsistent inputs.
        """
        examples, controls = self.example_fields(), self.make_controls()
        check_stamp_footprints(controls, examples, self.params.cell_size)
        return Session(examples, self.sketch_map, shape=self.shape, params=self.params, controls=controls)


def run_spec(*, ridge: np.ndarray, valley: np.ndarray, style: np.ndarray, water: np.ndarray,
             examples: Sequence[ExampleRef], params: SynthesisParams, styles: Sequence[StyleSpec] = (),
             water_level: float = 0.0, height_range: tuple[float, float] | None = None,
             pins: Sequence[Pin] = (), stamps: Sequence[StampSpec] = ()) -> RunSpec:
    """The run a document (or a project file) stands for: what the app's
    *Synthesize* and ``terrasynth-cli synth --project`` both run.

    Parameters
    ----------
    ridge, valley : ndarray of uint8, shape (rows, cols)
        Stroke intensities.
    style : ndarray of int16, shape (rows, cols)
        Style id per cell, -1 none.
    water : ndarray of bool, shape (rows, cols)
    examples, params, styles, water_level, height_range, pins, stamps
        As a project holds them.

    Returns
    -------
    RunSpec
        Arrays copied: later edits of the layers do not reach it.

    Raises
    ------
    ParamsError
        When no example is chosen and styles do not cover every cell.
    """
    used, style_map = painted_styles(style, styles)
    if not examples and (style_map is None or (style_map < 0).any()):
        raise ParamsError("no example DEM chosen: add one from the example library"
                          + (" or paint every cell with a style" if styles else ""))
    sketch = stroke_map(ridge, valley)
    has_strokes = bool(sketch.ridge_mask.any() or sketch.valley_mask.any())
    return RunSpec(tuple(examples), sketch if has_strokes else None, tuple(ridge.shape), params, styles=used,
                   style_map=style_map, water=np.array(water, bool) if water.any() else None,
                   water_level=float(water_level), height_range=height_range, pins=tuple(pins),
                   stamps=tuple(stamps))
