"""Local re-synthesis on a crop (terrasynth_core/synthesis/local.py)."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.errors import ParamsError, SynthesisCancelled
from terrasynth_core.features.sketch import SketchMap, read_sketch, sketch_features
from terrasynth_core.synthesis import (Controls, PatchPlaced, Pin, Session, SynthesisFinished, SynthesisParams, Water,
                                       changed_cells, iter_resynthesize_region, resynthesize_region, stroke_selection)
from terrasynth_core.synthesis.fill_workers import fill_window
from terrasynth_core.synthesis.local import crop_box

P = SynthesisParams(patch_size=32, k=2, seed=7)
SHAPE = (320, 320)


@pytest.fixture(scope="module")
def before(sketch_dir) -> SketchMap:
    return read_sketch(sketch_dir / "y_junction_512.png").resized(SHAPE)


@pytest.fixture(scope="module")
def after(before) -> SketchMap:
    """``before`` with a new ridge stroke across the upper left and part of a
    valley erased."""
    ridge = before.ridge_mask.copy()
    ridge[60:63, 40:140] = True
    valley = before.valley_mask & ~ridge
    return SketchMap(ridge, valley)


@pytest.fixture(scope="module")
def first(white_mountains, before):
    return Session([white_mountains], before, params=P).run()


def test_changed_cells_and_stroke_selection(before, after):
    changed = changed_cells(before, after)
    assert changed[61, 50] and changed.sum() == (after.ridge_mask != before.ridge_mask).sum() + \
        (after.valley_mask != before.valley_mask).sum() - ((after.ridge_mask != before.ridge_mask)
                                                          & (after.valley_mask != before.valley_mask)).sum()
    # An erase is a change too: the old stroke's pixels.
    erased = changed_cells(after, before)
    assert np.array_equal(erased, changed)
    selection = stroke_selection(changed, patch_size=32)
    assert selection[61, 50] and selection[61 + 30, 50] and not selection[61 + 34, 90]
    assert stroke_selection(np.zeros(SHAPE, bool), patch_size=32) is None
    assert not changed_cells(None, None, SHAPE).any()
    with pytest.raises(ParamsError, match="differ in size"):
        changed_cells(before, after.resized((160, 160)))


def test_crop_box_keeps_context_and_a_patch():
    sel = np.zeros(SHAPE, bool)
    sel[100:110, 150:160] = True
    assert crop_box(sel, patch_size=32) == (36, 174, 86, 224)
    corner = np.zeros(SHAPE, bool)
    corner[0, 319] = True
    r0, r1, c0, c1 = crop_box(corner, patch_size=32, context=0)
    assert (r0, c1) == (0, 320) and r1 - r0 >= 32 and c1 - c0 >= 32


def test_region_changes_only_the_selection_and_runs_on_a_crop(white_mountains, first, after, before):
    selection = stroke_selection(changed_cells(before, after), patch_size=P.patch_size)
    events = []
    result = resynthesize_region([white_mountains], after, previous=first.heights, selection=selection, params=P,
                                 previous_patch_id=first.patch_id, previous_seam_mask=first.seam_mask,
                                 progress=events.append)
    outside = ~selection
    assert result.heights.shape == SHAPE and result.heights.dtype == np.float32
    assert np.array_equal(result.heights[outside], first.heights[outside])  # bit for bit
    assert not np.array_equal(result.heights[selection], first.heights[selection])
    assert np.array_equal(result.patch_id[outside], first.patch_id[outside])
    assert result.patch_id[selection].min() > first.patch_id.max()
    assert np.array_equal(result.selection, selection)
    # The run worked on the crop, and reported its patches in map cells.
    r0, r1, c0, c1 = crop_box(selection, patch_size=P.patch_size)
    placed = [e for e in events if isinstance(e, PatchPlaced)]
    assert placed and all(r0 <= e.bbox[0] and e.bbox[1] <= r1 and c0 <= e.bbox[2] and e.bbox[3] <= c1
                          for e in placed)
    assert (r1 - r0) * (c1 - c0) < 0.6 * SHAPE[0] * SHAPE[1]
    assert any(p.kind in ("path", "end", "branch") for p in result.patches)  # the new ridge got a feature patch
    assert "crop" in result.timings and result.timings["sketch"] > 0
    # The result carries the whole sketch's networks (for the overlays), not the crop's.
    whole = sketch_features(after)
    assert result.sketch_features.ridges.paths and result.sketch_features.ridges.shape == SHAPE
    assert [p.points.tobytes() for p in result.sketch_features.ridges.paths] == \
        [p.points.tobytes() for p in whole.ridges.paths]
    # The new terrain meets the old: the step across the selection's edge is like the steps inside.
    from scipy import ndimage
    gy, gx = np.gradient(result.heights.astype(np.float64))
    slope = np.hypot(gy, gx)
    edge = ndimage.binary_dilation(selection) & ~ndimage.binary_erosion(selection)
    assert np.percentile(slope[edge], 99) < 2.0 * np.percentile(slope[selection], 99)


def test_region_with_controls_keeps_pins_and_water(white_mountains, first, after, before):
    selection = stroke_selection(changed_cells(before, after), patch_size=P.patch_size)
    water = np.zeros(SHAPE, bool)
    water[280:300, :] = True  # far from the change: outside the crop
    pins = (Pin(61, 90, float(first.heights[61, 90]) + 150.0), Pin(300, 300, 1000.0))
    controls = Controls(water=Water(water, 400.0), pins=pins)
    result = resynthesize_region([white_mountains], after, previous=first.heights, selection=selection, params=P,
                                 controls=controls)
    assert np.array_equal(result.heights[~selection], first.heights[~selection])
    assert result.heights[61, 90] == pytest.approx(pins[0].height, abs=1e-2)
    errors = {(e.row, e.col): e for e in result.pin_errors}
    assert errors[(300, 300)].height == first.heights[300, 300]  # outside: left as it was, and reported


def test_region_is_checked_and_cancellable(white_mountains, first, after):
    selection = np.zeros(SHAPE, bool)
    with pytest.raises(ParamsError, match="selection is empty"):
        resynthesize_region([white_mountains], after, previous=first.heights, selection=selection, params=P)
    selection[100:140, 100:140] = True
    with pytest.raises(ParamsError, match="selection is .* but the output is 100x320"):
        resynthesize_region([white_mountains], after, previous=first.heights[:100], selection=selection, params=P)
    with pytest.raises(ParamsError, match="not in the controls"):
        resynthesize_region([white_mountains], after, previous=first.heights, selection=selection, params=P,
                            controls=Controls(previous=first.heights, selection=selection))
    with pytest.raises(SynthesisCancelled):
        resynthesize_region([white_mountains], after, previous=first.heights, selection=selection, params=P,
                            cancel=lambda: True)
    events = iter_resynthesize_region([white_mountains], after, previous=first.heights, selection=selection,
                                      params=P)
    next(events)
    events.close()  # stops cleanly, nothing finished
    # Same inputs, same seed: same bytes.
    a = resynthesize_region([white_mountains], after, previous=first.heights, selection=selection, params=P)
    events = list(iter_resynthesize_region([white_mountains], after, previous=first.heights, selection=selection,
                                           params=P))
    assert isinstance(events[-1], SynthesisFinished)
    assert np.array_equal(a.heights, events[-1].result.heights)


def test_an_automatic_patch_size_is_chosen_as_a_whole_run_would(highland, after, before, first):
    # (The terrain's own size is kept by passing its params, as the app does.)
    selection = stroke_selection(changed_cells(before, after), patch_size=32)
    auto = SynthesisParams(k=2, seed=7)
    whole = Session([highland], after, params=auto)
    local = resynthesize_region([highland], after, previous=first.heights, selection=selection, params=auto)
    assert local.params.patch_size == whole.params.patch_size < 80


def test_a_stroke_uses_the_workers_once_they_are_up(white_mountains, first, after, before, monkeypatch):
    """A live stroke after a whole run: the run's worker processes are up,
    so the whole sketch's networks (for the result's overlays) are made on
    one beside the crop run, and the crop's fill windows go to them too;
    the result is the bytes of a crop run in this process alone."""
    from terrasynth_core.synthesis import workers

    selection = stroke_selection(changed_cells(before, after), patch_size=P.patch_size)
    kwargs = dict(previous=first.heights, selection=selection, previous_patch_id=first.patch_id,
                  previous_seam_mask=first.seam_mask)
    here = resynthesize_region([white_mountains], after, params=SynthesisParams(**{**P.__dict__, "workers": 1}),
                               **kwargs)
    workers.warm_up(2, P.patch_size)
    assert workers.wait_warm()
    assert workers.running(2)
    # However few its windows, a fill finds the warm workers.
    monkeypatch.setattr("terrasynth_core.synthesis.pipeline.MIN_PARALLEL_WINDOWS", 10**9)
    sent = []
    kit_submit = workers.KitWorkers.submit
    monkeypatch.setattr(workers.KitWorkers, "submit", lambda self, task, *a: sent.append(task) or kit_submit(self, task, *a))
    monkeypatch.setattr("terrasynth_core.synthesis.local.submit",
                        lambda n, task, *a: sent.append(task) or workers.submit(n, task, *a))
    there = resynthesize_region([white_mountains], after, params=SynthesisParams(**{**P.__dict__, "workers": 2}),
                                **kwargs)
    assert sent[0] is sketch_features
    assert len(sent) > 1 and all(task is fill_window for task in sent[1:])
    np.testing.assert_array_equal(here.heights, there.heights)
    np.testing.assert_array_equal(here.patch_id, there.patch_id)
    for kind in ("ridges", "valleys"):
        assert [p.points.tobytes() for p in getattr(here.sketch_features, kind).paths] == \
            [p.points.tobytes() for p in getattr(there.sketch_features, kind).paths]
