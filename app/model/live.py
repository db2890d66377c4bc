"""Live sketching: after a finished run, each stroke re-makes the terrain
near it.

:func:`live_request` snapshots the document on the GUI thread (cheap: the
layers are copied, nothing is read); :func:`live_events` is the generator a
worker drains.  It finds the cells within about a patch of every stroke
pixel that differs from the strokes the terrain was made from (drawn,
erased or undone alike: :func:`~terrasynth_core.synthesis.changed_cells`,
:func:`~terrasynth_core.synthesis.stroke_selection`) and re-synthesizes
them on a crop around them
(:func:`~terrasynth_core.synthesis.iter_resynthesize_region`); every other
cell keeps its height bit for bit.  The examples' analysis is memoised in
the core (per example and patch size), so no stroke redoes it.

Only the ridge and valley strokes are followed: style regions, water,
pins, stamps and parameters reach the terrain through a full run (they
change it far beyond a stroke's neighbourhood).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from terrasynth_core.errors import ParamsError
from terrasynth_core.exemplars.patch_size import DEFAULT_PATCH
from terrasynth_core.features import SketchMap
from terrasynth_core.synthesis import (SynthesisFinished, SynthesisResult, changed_cells, iter_resynthesize_region,
                                       prepare_resynthesis, stroke_selection)

from .result import TerrainResult
from .run_request import SynthesisRequest


@dataclass(frozen=True, eq=False)
class LiveRequest:
    """What one live update needs, taken from the document on the GUI thread.

    Parameters
    ----------
    run : SynthesisRequest
        The document now (examples, strokes, controls, parameters).
    before : SketchMap or None
        The strokes the terrain was made from.
    terrain : TerrainResult
        The terrain to change.
    """

    run: SynthesisRequest
    before: SketchMap | None
    terrain: TerrainResult

    @property
    def strokes(self) -> SketchMap | None:
        """The strokes the updated terrain will follow."""
        return self.run.sketch_map


@dataclass(frozen=True, eq=False)
class LiveUpdated:
    """A live update is done: the last event of :func:`live_events`.

    Parameters
    ----------
    result : SynthesisResult
        The core's, of the whole map (its ``selection`` the cells changed).
    terrain : TerrainResult
        The same, as the document keeps it.
    strokes : SketchMap or None
        The strokes it follows.
    seconds : float
        From the start of the worker's work to here.
    """

    result: SynthesisResult
    terrain: TerrainResult
    strokes: SketchMap | None
    seconds: float


def live_request(document) -> LiveRequest | None:
    """A live update of ``document``'s terrain, or None when there is none
    to make (no terrain, or the strokes are those it was made from).

    Raises
    ------
    ParamsError
        When the terrain and the sketch differ in size (a full run is
        needed), or the document cannot be synthesized.
    """
    terrain = document.result
    if terrain is None:
        return None
    if terrain.shape != document.output_shape:
        raise ParamsError(f"the terrain is {terrain.shape[0]}x{terrain.shape[1]} but the sketch is "
                          f"{document.output_shape[0]}x{document.output_shape[1]}: synthesize it again first")
    run = document.synthesis_request()
    if same_strokes(run.sketch_map, document.result_strokes):
        return None
    return LiveRequest(run, document.result_strokes, terrain)


def live_preparation(document, cancel: Callable[[], bool] | None = None) -> Callable[[], None] | None:
    """What the first live stroke on ``document``'s terrain would make
    before placing a patch (the examples' feature pools and fill searches
    as its crop run reads them, with their zone indexes), as a function for
    a worker thread; None when there is no terrain to change.  Snapshots
    the document here, on the GUI thread.  ``cancel`` (thread-safe) is
    asked between zone indexes; True stops the preparation there."""
    terrain = document.result
    if terrain is None or terrain.shape != document.output_shape:
        return None
    run = document.synthesis_request()
    params = terrain.params_for_change(run.params)

    def prepare() -> None:
        prepare_resynthesis(run.example_fields(), run.sketch_map, previous=terrain.heights, params=params,
                            controls=run.make_controls(), cancel=cancel)

    return prepare


def same_strokes(a: SketchMap | None, b: SketchMap | None) -> bool:
    """Whether two stroke maps (None: no strokes) mark the same pixels."""
    if a is None or b is None:
        return (a is None or not a.has_strokes) and (b is None or not b.has_strokes)
    return (a.shape == b.shape and np.array_equal(a.ridge_mask, b.ridge_mask)
            and np.array_equal(a.valley_mask, b.valley_mask))


def live_events(request: LiveRequest) -> Iterator[object]:
    """Make ``request``'s update: the core's progress events (patch boxes in
    map cells), then one :class:`LiveUpdated`.  Nothing is yielded when no
    stroke pixel changed.  Closing the generator stops the run at the next
    patch."""
    start = time.perf_counter()
    run = request.run
    terrain = request.terrain
    params = terrain.params_for_change(run.params)
    changed = changed_cells(request.before, request.strokes, run.shape)
    selection = stroke_selection(changed, patch_size=params.patch_size or DEFAULT_PATCH)
    if selection is None:
        return
    result = None
    for event in iter_resynthesize_region(run.example_fields(), request.strokes, previous=terrain.heights,
                                          selection=selection, params=params, controls=run.make_controls(),
                                          previous_patch_id=terrain.patch_id,
                                          previous_seam_mask=terrain.seam_mask):
        if isinstance(event, SynthesisFinished):
            result = event.result
        else:
            yield event
    if result is None:
        return
    updated = TerrainResult.from_synthesis(result, cell_size=terrain.cell_size)
    if updated.georef is None and terrain.georef is not None:
        updated = TerrainResult(updated.heights, updated.patch_id, updated.seam_mask, updated.sketch_features,
                                updated.cell_size, updated.report, updated.pin_errors, terrain.georef)
    yield LiveUpdated(result, updated, request.strokes, time.perf_counter() - start)
