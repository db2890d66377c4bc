"""Local re-synthesis on a crop: a change to the sketch re-made where it
matters, in a fraction of a whole-map run.

A local re-synthesis (``Controls(previous=, selection=)``) already keeps
every cell outside its selection, but it still runs every stage over the
whole map: the landform pass, the sketch analysis and the finish
(drainage, water) cost as much as for a new terrain.  Here the run is made
on a *crop*: the selection's bounding box plus :data:`CONTEXT_PATCHES`
patch sizes of context on each side, cut from every input (sketch, style
map, water, stamps, pins and the previous heights, which stay locked).  The
crop's session sees the locked terrain around the selection, so its patches
match it and merge at the selection's edge as in a whole-map
re-synthesis; then the selected cells are pasted back into the previous
terrain, and every other cell keeps its previous height bit for bit.

What the crop cannot see is farther than the context: style levels are
smooth over about two patch sizes
(:func:`~terrasynth_core.controls.layout.level_field`), so two patches of
context give the same level inside the selection up to the blur's tail.
The landform pass is left out by default (see ``landform`` in
:func:`resynthesize_region`): the kept terrain around the selection
carries the landforms, and the new patches are matched to it.

:func:`stroke_selection` gives the selection for a sketch edit: the cells
within about a patch of the pixels that changed (old and new strokes
alike, so an erase re-makes the terrain under the erased stroke).

Usage::

    # old.params: the old run's, with the patch size it chose
    selection = stroke_selection(changed_cells(before, after), patch_size=old.params.patch_size)
    result = resynthesize_region([example], after, previous=old.heights, selection=selection,
                                 params=old.params)
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable, Iterator, NamedTuple, Sequence

import numpy as np
from scipy import ndimage

from ..controls.layout import grounded_examples
from ..controls.options import Controls
from ..controls.pins import Pin, PinError
from ..controls.water import Water
from ..errors import ParamsError
from ..features import FeatureMaps, SketchMap, sketch_features
from ..features.network import mask_box
from ..heightfield import HeightField
from ..io.resample import output_georeference
from .events import PatchPlaced, SynthesisFinished, drive
from .params import SynthesisParams
from .pipeline import examples_read
from .result import SynthesisResult
from .session import Session, with_patch_size
from .workers import running, submit

__all__ = ["CONTEXT_PATCHES", "STROKE_REACH", "changed_cells", "crop_box", "iter_resynthesize_region",
           "prepare_resynthesis", "resynthesize_region", "stroke_selection"]

#: Context kept around the selection's bounding box, in patch sizes: the
#: level field and the landforms are smooth over about two patches.
CONTEXT_PATCHES = 2.0

#: How far a stroke's selection reaches from the changed sketch pixels, in
#: patch sizes: a feature patch centred on the stroke spans half a patch
#: either side, and its seam with the old terrain needs room beyond it.
STROKE_REACH = 1.0


def changed_cells(before: SketchMap | None, after: SketchMap | None,
                  shape: tuple[int, int] | None = None) -> np.ndarray:
    """The sketch pixels whose ridge or valley mark differs.

    Parameters
    ----------
    before, after : SketchMap or None
        The sketch the terrain was made from and the sketch now (None: no
        strokes).  Both of the same shape.
    shape : (rows, cols), optional
        Needed when both are None.

    Returns
    -------
    ndarray of bool, shape (rows, cols)
        True where a stroke was drawn, erased or changed kind.

    Raises
    ------
    ParamsError
        When the two sketches differ in size.
    """
    sketches = [s for s in (before, after) if s is not None]
    if not sketches:
        if shape is None:
            raise ParamsError("changed_cells needs a shape when both sketches are None")
        return np.zeros(shape, bool)
    shape = sketches[0].shape
    for s in sketches:
        if s.shape != shape:
            raise ParamsError(f"the sketches differ in size ({before.shape} and {after.shape}): "
                              "a change of size needs a whole new run")
    blank = np.zeros(shape, bool)
    rb, vb = (blank, blank) if before is None else (before.ridge_mask, before.valley_mask)
    ra, va = (blank, blank) if after is None else (after.ridge_mask, after.valley_mask)
    return (rb != ra) | (vb != va)


def stroke_selection(changed: np.ndarray, *, patch_size: int, reach: float = STROKE_REACH) -> np.ndarray | None:
    """The cells to synthesize again after a sketch edit.

    Parameters
    ----------
    changed : ndarray of bool, shape (rows, cols)
        Pixels that changed (:func:`changed_cells`; for an erase the erased
        stroke's pixels, for a redrawn stroke the old and the new).
    patch_size : int
        Output cells.
    reach : float, default :data:`STROKE_REACH`
        Patch sizes the selection reaches from a changed pixel.

    Returns
    -------
    ndarray of bool, shape (rows, cols), or None
        None when nothing changed.
    """
    changed = np.asarray(changed, bool)
    if not changed.any():
        return None
    radius = max(float(reach) * patch_size, 1.0)
    pad = int(np.ceil(radius)) + 1
    # The distance transform only over the changes' box and its reach: a
    # stroke is small next to the map, and this runs on every stroke.
    r0, r1, c0, c1 = _bbox(changed)
    rows, cols = changed.shape
    r0, r1, c0, c1 = max(r0 - pad, 0), min(r1 + pad, rows), max(c0 - pad, 0), min(c1 + pad, cols)
    near = ndimage.distance_transform_edt(~changed[r0:r1, c0:c1]) <= radius
    selection = np.zeros(changed.shape, bool)
    selection[r0:r1, c0:c1] = near
    return selection


def crop_box(selection: np.ndarray, *, patch_size: int,
             context: float = CONTEXT_PATCHES) -> tuple[int, int, int, int]:
    """The window a region's re-synthesis runs on: the selection's bounding
    box and ``context`` patch sizes around it, within the map.

    Parameters
    ----------
    selection : ndarray of bool, shape (rows, cols)
        Not empty.
    patch_size : int
    context : float, default :data:`CONTEXT_PATCHES`

    Returns
    -------
    (r0, r1, c0, c1)
        Half-open; at least one patch in each direction when the map is.
    """
    rows, cols = selection.shape
    margin = int(np.ceil(context * patch_size))
    r0, r1, c0, c1 = _bbox(selection)
    r0, r1, c0, c1 = max(r0 - margin, 0), min(r1 + margin, rows), max(c0 - margin, 0), min(c1 + margin, cols)
    # A session needs at least a patch each way (a thin selection at the
    # map's edge could leave less).
    r0, r1 = _widened(r0, r1, patch_size, rows)
    c0, c1 = _widened(c0, c1, patch_size, cols)
    return r0, r1, c0, c1


def resynthesize_region(examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None, *,
                        previous: np.ndarray, selection: np.ndarray, params: SynthesisParams = SynthesisParams(),
                        controls: Controls | None = None, context: float = CONTEXT_PATCHES,
                        previous_patch_id: np.ndarray | None = None, previous_seam_mask: np.ndarray | None = None,
                        features: FeatureMaps | None = None, landform: bool = False,
                        progress: Callable[[object], None] | None = None,
                        cancel: Callable[[], bool] | None = None) -> SynthesisResult:
    """Synthesize ``selection`` again on a crop and paste it into ``previous``.

    Parameters
    ----------
    examples, sketch, params
        As for :class:`~.session.Session`, the inputs of the run that made
        ``previous``.  The sketch is scaled to ``previous``'s shape.
    previous : ndarray of float, shape (rows, cols)
        The terrain to change, metres.
    selection : ndarray of bool, shape (rows, cols)
        Cells to synthesize again (e.g. :func:`stroke_selection`); not empty.
    controls : Controls, optional
        The run's artist controls, without ``previous`` and ``selection``
        (they are the arguments above).
    context : float, default :data:`CONTEXT_PATCHES`
        Patch sizes of terrain kept around the selection's bounding box.
    previous_patch_id, previous_seam_mask : ndarray, shape (rows, cols), optional
        The previous result's debug maps, kept outside the selection
        (default: no patch, no seam there).
    features : FeatureMaps, optional
        The whole sketch's feature networks for the result, when the caller
        has them (default: computed from ``sketch``, about 0.1 s at
        1000x1000, on a worker process beside the crop run when the run's
        workers are up, else once the crop run is done).
    landform : bool, default False
        Run the landform pass on the crop (``params.landform`` is ignored).
        Off by default: the coarse pass builds new landforms over the whole
        crop, and a re-synthesis eases the level from the kept terrain's to
        them within a quarter patch of the selection's edge, which prints
        the selection's outline into the terrain as a rim or a trough
        (a whole-map re-synthesis shows it too).  Without it the patches
        carry the examples' full detail and are matched to the kept
        terrain around them, which hides the edge, and the run is faster.
    progress, cancel : callable, optional
        As for :meth:`.session.Session.run`.

    Returns
    -------
    SynthesisResult
        Of ``previous``'s shape.  ``heights`` equals ``previous`` bit for
        bit outside ``selection``.  ``patches`` are the new patches (boxes
        in map cells); in ``patch_id`` the new patch ``i`` has id
        ``first + i``, where ``first`` is one more than the largest id of
        ``previous_patch_id`` (0 without it), so old and new patches keep
        distinct ids.  ``timings`` are the crop run's, plus ``"crop"``
        (cutting the inputs, making the crop's session and pasting the
        result) and ``"sketch"`` (the whole sketch's networks, 0 when
        ``features`` were given).

    Raises
    ------
    ParamsError
        Naming the bad input (shapes, an empty selection, anything the
        session checks).
    SynthesisCancelled
        When ``cancel`` returned True.
    """
    events = iter_resynthesize_region(examples, sketch, previous=previous, selection=selection, params=params,
                                      controls=controls, context=context, previous_patch_id=previous_patch_id,
                                      previous_seam_mask=previous_seam_mask, features=features, landform=landform)
    return drive(events, progress=progress, cancel=cancel, what="re-synthesis")


def iter_resynthesize_region(examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None, *,
                             previous: np.ndarray, selection: np.ndarray,
                             params: SynthesisParams = SynthesisParams(), controls: Controls | None = None,
                             context: float = CONTEXT_PATCHES, previous_patch_id: np.ndarray | None = None,
                             previous_seam_mask: np.ndarray | None = None,
                             features: FeatureMaps | None = None, landform: bool = False) -> Iterator[object]:
    """:func:`resynthesize_region` step by step: the crop run's events, with
    ``PatchPlaced`` boxes in map cells, and last a ``SynthesisFinished``
    carrying the whole map's result.  Closing the generator stops the run
    at the next patch.  Everything is checked before the first event."""
    t_start = time.perf_counter()
    examples, previous, whole, box, sketch, params, local = _crop_session(
        examples, sketch, previous, selection, params, controls, context, landform,
        previous_patch_id=previous_patch_id, previous_seam_mask=previous_seam_mask)
    shape = previous.shape
    r0, r1, c0, c1 = box
    crop = (slice(r0, r1), slice(c0, c1))
    t_crop = time.perf_counter() - t_start
    whole_features = None
    if features is None and sketch is not None and running(params.thread_count):
        # The whole sketch's networks (for the result's overlays) on a
        # worker process while the crop runs here: the worker is idle
        # until the crop's fill (on a thread beside the run they competed
        # for the interpreter lock and saved nothing).
        whole_features = submit(params.thread_count, sketch_features, sketch)
    finished = None
    events = local.iter_run()
    try:
        for event in events:
            if isinstance(event, SynthesisFinished):
                finished = event.result
            elif isinstance(event, PatchPlaced):
                yield dataclasses.replace(event, bbox=_shifted(event.bbox, r0, c0))
            else:
                yield event
    finally:
        events.close()
        if finished is None and whole_features is not None:
            whole_features.cancel()  # (cancelled or failed: not wanted)
    if finished is None:
        return

    t_sketch = time.perf_counter()
    if whole_features is not None:
        try:
            features = whole_features.result()
        except Exception:  # a worker lost (killed, restarted): made here instead
            features = _features_of(sketch, shape)
    elif features is None:
        features = _features_of(sketch, shape)
    t_paste = time.perf_counter()
    sel = whole.selection[crop]
    heights = previous.copy()
    heights[crop][sel] = finished.heights[sel]
    if previous_patch_id is None:
        patch_id = np.full(shape, -1, np.int32)
    else:
        patch_id = np.asarray(previous_patch_id, dtype=np.int32).copy()
    first = int(patch_id.max()) + 1 if patch_id.size else 0
    first = max(first, 0)
    new_ids = np.where(finished.patch_id >= 0, finished.patch_id + first, -1).astype(np.int32)
    patch_id[crop][sel] = new_ids[sel]
    seam_mask = (np.zeros(shape, bool) if previous_seam_mask is None
                 else np.asarray(previous_seam_mask, bool).copy())
    # The seams of the new patches against the kept terrain show on both sides.
    seam_mask[crop][sel] = False
    seam_mask[crop] |= finished.seam_mask
    records = tuple(dataclasses.replace(rec, bbox=_shifted(rec.bbox, r0, c0)) for rec in finished.patches)
    cell = finished.cell_size
    georef = None if cell is None else output_georeference(
        [*examples, *(s.example for s in whole.styles)], shape, cell)
    timings = dict(finished.timings)
    timings["crop"] = t_crop + (time.perf_counter() - t_paste)
    timings["sketch"] = t_paste - t_sketch
    yield SynthesisFinished(SynthesisResult(
        heights=heights,
        patch_id=patch_id,
        seam_mask=seam_mask,
        patches=records,
        sketch_features=features,
        timings=timings,
        total_seconds=time.perf_counter() - t_start,
        warnings=finished.warnings,
        params=finished.params,
        style_map=None if whole.style_map is None else whole.style_map.copy(),
        pin_errors=tuple(PinError(p.row, p.col, p.height, float(heights[p.row, p.col]),
                                  float(heights[p.row, p.col]) - p.height) for p in whole.pins),
        selection=whole.selection.copy(),
        cell_size=cell,
        georef=georef,
    ))


class _Crop(NamedTuple):
    """A re-synthesis's checked inputs and its crop's session.

    Attributes
    ----------
    examples : list
    previous : ndarray of float32, shape (rows, cols)
        The terrain to change.
    whole : Controls
        The whole map's controls, checked, with the previous terrain and
        the selection.
    box : (r0, r1, c0, c1)
        The crop, map cells.
    sketch : SketchMap or None
        At the map's size.
    params : SynthesisParams
        With the patch size chosen when it was automatic.
    session : Session
        The crop's.
    """

    examples: list
    previous: np.ndarray
    whole: Controls
    box: tuple[int, int, int, int]
    sketch: SketchMap | None
    params: SynthesisParams
    session: Session


def _crop_session(examples, sketch: SketchMap | None, previous: np.ndarray, selection: np.ndarray,
                  params: SynthesisParams, controls: Controls | None, context: float, landform: bool, *,
                  previous_patch_id: np.ndarray | None = None,
                  previous_seam_mask: np.ndarray | None = None) -> _Crop:
    """Check a re-synthesis's inputs (those of :func:`resynthesize_region`)
    and make the crop's session."""
    previous = np.asarray(previous, dtype=np.float32)
    if previous.ndim != 2:
        raise ParamsError(f"the previous result must be a 2-D height array, got shape {previous.shape}")
    shape = previous.shape
    controls = Controls() if controls is None else controls
    if not isinstance(controls, Controls):
        raise ParamsError(f"controls must be Controls, got {type(controls).__name__}")
    if controls.previous is not None or controls.selection is not None:
        raise ParamsError("give the previous result and the selection as arguments, not in the controls")
    if not isinstance(params, SynthesisParams):
        raise ParamsError(f"params must be SynthesisParams, got {type(params).__name__}")
    examples = list(examples or ())
    # The whole map's controls, checked (and their maps fitted) once, so the
    # crop cuts exactly what a whole-map re-synthesis would use.
    whole = dataclasses.replace(controls, previous=previous, selection=selection).checked(shape, len(examples))
    # An automatic patch size: chosen as a run of the whole map would, for
    # the new strokes (the terrain's own run may have chosen another, for
    # other strokes: pass its ``result.params`` to keep it).
    if params.patch_size is None:
        params, _ = with_patch_size(params, grounded_examples(examples, whole, params.cell_size), sketch, shape)
    if sketch is not None and sketch.shape != shape:
        sketch = sketch.resized(shape)
    for name, arr in (("patch ids", previous_patch_id), ("seam mask", previous_seam_mask)):
        if arr is not None and np.shape(arr) != shape:
            raise ParamsError(f"the previous {name} are {np.shape(arr)} but the terrain is {shape[0]}x{shape[1]}")

    box = crop_box(whole.selection, patch_size=params.patch_size, context=context)
    if not _same_styles_in(whole, box):
        # With a height range, the styles' heights are scaled by the span of
        # the styles present (controls/layout.py): a crop holding fewer
        # styles would scale them differently.  The whole map keeps them alike.
        box = (0, shape[0], 0, shape[1])
    r0, r1, c0, c1 = box
    crop = (slice(r0, r1), slice(c0, c1))
    local = Session(examples, None if sketch is None else _cropped_sketch(sketch, crop), shape=(r1 - r0, c1 - c0),
                    params=dataclasses.replace(params, landform=bool(landform)),
                    controls=_cropped_controls(whole, crop))
    return _Crop(examples, previous, whole, box, sketch, params, local)


def prepare_resynthesis(examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None, *,
                        previous: np.ndarray, params: SynthesisParams = SynthesisParams(),
                        controls: Controls | None = None, cancel: Callable[[], bool] | None = None) -> None:
    """Make, and keep, what a re-synthesis of this map reads from its
    examples before it places a patch: their feature pools and fill
    searches as a stroke's crop run (no landform pass) uses them, with
    every zone index of the searches (on disk, for the fill's workers;
    :data:`~terrasynth_core.matching.window_index.ZONES_BY_SIDES`).

    They are kept in the core by what they are made of, so the first live
    stroke after a run need not make them (0.4-0.5 s for a 1201x1201
    example, and 0.3-0.4 s per zone index); a stroke asking for them while
    this runs waits for them rather than making them twice.  The arguments
    are those of :func:`resynthesize_region`; ``cancel`` is asked between
    zone indexes (about 5 s in all for a new 1201x1201 example, nothing once
    they are on disk) and True stops there.  The selection is a cell at
    the map's centre: the pools do not depend on it, nor do the searches on
    a map of one style (with several, only the styles within the crop
    around it get theirs; a stroke elsewhere makes the others).
    """
    rows, cols = np.shape(previous)[:2] if np.ndim(previous) == 2 else (0, 0)
    selection = np.zeros((rows, cols), bool)
    if selection.size:
        selection[rows // 2, cols // 2] = True
    session = _crop_session(examples, sketch, previous, selection, params, controls, CONTEXT_PATCHES,
                            False).session
    _pools, searches = examples_read(session.layout, session.params)
    # With the zones a crop's holes ask for, which a whole-map run may not
    # have made: the first strokes built them (0.3-0.4 s each, 15 MB on
    # disk for a 1201x1201 example).  All 15: leaving out those of windows
    # filled on one side, the first stroke built one (1.6 s against 0.7 s).
    for search in searches:
        if search is not None:
            search.make_indexes(cancel)


# -- cutting the inputs --------------------------------------------------------------------
def _cropped_sketch(sketch: SketchMap, crop: tuple[slice, slice]) -> SketchMap:
    return SketchMap(sketch.ridge_mask[crop], sketch.valley_mask[crop])


def _cropped_controls(whole: Controls, crop: tuple[slice, slice]) -> Controls:
    """The checked whole-map controls cut to ``crop``: maps cut, pins and
    stamps moved into the crop's cells (those outside it left out)."""
    (rs, cs) = crop
    r0, r1, c0, c1 = rs.start, rs.stop, cs.start, cs.stop
    water = None
    if whole.water is not None and whole.water.mask[crop].any():
        w = whole.water
        # The default bed depth is 3 % of the terrain's height range
        # (controls/water.py): the whole map's, not the crop's.
        depth = w.depth if w.depth is not None else 0.03 * float(np.ptp(whole.previous))
        water = Water(w.mask[crop], w.level, depth, w.bank_width)
    # A stamp is placed by its centre; one centred outside the crop lies
    # mostly in the kept terrain, which holds it already.
    stamps = tuple(dataclasses.replace(st, center=(st.center[0] - r0, st.center[1] - c0))
                   for st in whole.stamps if r0 <= st.center[0] < r1 and c0 <= st.center[1] < c1)
    pins = tuple(Pin(p.row - r0, p.col - c0, p.height) for p in whole.pins
                 if r0 <= p.row < r1 and c0 <= p.col < c1)
    return Controls(styles=whole.styles, style_map=None if whole.style_map is None else whole.style_map[crop],
                    water=water, stamps=stamps, pins=pins, height_range=whole.height_range,
                    pin_radius=whole.pin_radius, previous=whole.previous[crop], selection=whole.selection[crop])


def _same_styles_in(whole: Controls, box: tuple[int, int, int, int]) -> bool:
    """Whether the crop holds every style label the map holds (only matters
    under a height range)."""
    if whole.height_range is None or whole.style_map is None:
        return True
    r0, r1, c0, c1 = box
    return np.array_equal(np.unique(whole.style_map), np.unique(whole.style_map[r0:r1, c0:c1]))


def _features_of(sketch: SketchMap | None, shape: tuple[int, int]) -> FeatureMaps:
    return sketch_features(sketch if sketch is not None else SketchMap.empty(shape))


def _shifted(bbox: tuple[int, int, int, int], dr: int, dc: int) -> tuple[int, int, int, int]:
    r0, r1, c0, c1 = bbox
    return (r0 + dr, r1 + dr, c0 + dc, c1 + dc)


def _bbox(mask: np.ndarray) -> tuple[int, int, int, int]:
    """Half-open bounding box of a non-empty mask."""
    rows, cols = mask_box(mask, 0)
    return rows.start, rows.stop, cols.start, cols.stop


def _widened(lo: int, hi: int, least: int, size: int) -> tuple[int, int]:
    """``[lo, hi)`` grown to ``least`` cells within ``[0, size)`` (as far as it goes)."""
    short = least - (hi - lo)
    if short <= 0:
        return lo, hi
    lo = max(lo - (short + 1) // 2, 0)
    hi = min(max(hi, lo + least), size)
    lo = max(min(lo, hi - least), 0)
    return lo, hi
