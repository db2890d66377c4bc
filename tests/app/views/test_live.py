"""Live sketching through the window: the toggle, a stroke's update, cancel by
a newer stroke, undo, failures, and no stall of the event loop."""

import time

import numpy as np
import pytest
from PySide6.QtCore import QTimer
from scipy import ndimage

from terrasynth_core.errors import ParamsError
from terrasynth_app.model import same_strokes

RUN_TIMEOUT_MS = 90_000


@pytest.fixture
def live_window(qtbot, window):
    """The window with a finished terrain and Live on (short debounce)."""
    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    window.live._timer.setInterval(20)
    window.actions.live.trigger()
    assert window.live.enabled
    yield window
    window.live.wait()


def _stroke_cells(window, before):
    return np.asarray(window.document.sketch.ridge != before)


def test_live_is_a_checkable_toolbar_action_off_by_default(qtbot, window):
    action = window.actions.live
    assert action.isCheckable() and not action.isChecked() and not window.live.enabled
    toolbar = window.findChild(type(window.addToolBar("probe")), "main_toolbar")
    assert action in toolbar.actions()
    action.trigger()
    assert window.live.enabled and action.isChecked()
    window.live.set_enabled(False)  # the controller keeps the action in step
    assert not action.isChecked()
    # No terrain yet: a stroke schedules nothing.
    action.trigger()
    window.document.sketch.draw_polyline([(100, 20), (100, 60)], "ridge", radius=2)
    assert not window.live.pending and not window.live.running


def test_a_stroke_updates_only_the_terrain_near_it_and_undo_follows(qtbot, live_window, drag):
    window = live_window
    old = window.document.result
    before = window.document.sketch.ridge.copy()
    got = []
    window.live.updated.connect(got.append)
    with qtbot.waitSignals([window.live.updated, window.heightmap.result_shown], timeout=RUN_TIMEOUT_MS):
        window.canvas.set_tool("ridge")
        drag(window.canvas, [(120, 100), (125, 120), (130, 145)])
    result = got[-1]
    new = window.document.result
    stroke = _stroke_cells(window, before)
    assert stroke.any()
    changed = new.heights != old.heights
    assert changed.any()
    # Only cells near the stroke changed (within a patch of it), and every
    # cell outside the update's selection is bit for bit the old one.
    near = ndimage.distance_transform_edt(~stroke) <= window.document.params.patch_size + 1
    assert not (changed & ~near).any()
    assert np.array_equal(new.heights[~result.selection], old.heights[~result.selection])
    np.testing.assert_array_equal(window.heightmap.heights, new.heights)
    assert same_strokes(window.document.result_strokes, window.document.sketch.to_sketch_map())
    # Undo takes the stroke back and the terrain follows it again.
    with qtbot.waitSignal(window.live.updated, timeout=RUN_TIMEOUT_MS):
        window.canvas.undo_action.trigger()
    np.testing.assert_array_equal(window.document.sketch.ridge, before)
    assert same_strokes(window.document.result_strokes, window.document.sketch.to_sketch_map())
    assert not (window.document.result.heights != old.heights)[~near].any()
    # The full run stays one click away.
    with qtbot.waitSignal(window.synthesis.finished, timeout=RUN_TIMEOUT_MS):
        window.actions.synthesize.trigger()


def test_a_second_stroke_cancels_the_running_update(qtbot, live_window):
    window, live = live_window, live_window.live
    sketch = window.document.sketch
    with qtbot.waitSignal(live.started, timeout=10_000):
        sketch.draw_polyline([(40, 120), (60, 140)], "ridge", radius=2)
    assert live.running
    with qtbot.waitSignal(live.cancelled, timeout=RUN_TIMEOUT_MS):
        sketch.draw_polyline([(140, 100), (150, 60)], "valley", radius=2)
    with qtbot.waitSignal(live.updated, timeout=RUN_TIMEOUT_MS) as blocker:
        pass
    # The update that landed covers both strokes.
    selection = blocker.args[0].selection
    assert selection[50, 130] and selection[145, 80]
    assert same_strokes(window.document.result_strokes, sketch.to_sketch_map())


def test_a_failed_update_keeps_the_sketch_and_the_terrain(qtbot, live_window, monkeypatch, dialogs):
    import terrasynth_app.model.live as live_model

    def broken(*_args, **_kwargs):
        raise ParamsError("example.tif: no such file")
        yield  # a generator, like the real one

    monkeypatch.setattr(live_model, "iter_resynthesize_region", broken)
    window = live_window
    old = window.document.result
    with qtbot.waitSignal(window.live.failed, timeout=RUN_TIMEOUT_MS):
        window.document.sketch.draw_polyline([(40, 120), (60, 140)], "ridge", radius=2)
    assert window.document.result is old
    assert window.document.sketch.ridge[50, 130] > 0
    assert "Live update failed: example.tif" in window.statusBar().currentMessage()
    assert not dialogs.calls


def test_the_event_loop_never_stalls_during_a_live_update(qtbot, live_window, record_property):
    window = live_window
    ticks = []
    timer = QTimer(interval=10)
    timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
    timer.start()
    with qtbot.waitSignals([window.live.updated, window.heightmap.result_shown], order="strict",
                           timeout=RUN_TIMEOUT_MS):
        window.document.sketch.draw_polyline([(100, 100), (140, 110)], "ridge", radius=2)
    count = len(ticks)
    qtbot.waitUntil(lambda: len(ticks) >= count + 5, timeout=2000)
    timer.stop()
    max_gap_ms = float(np.diff(ticks).max() * 1000)
    record_property("max_event_loop_gap_ms_live", round(max_gap_ms, 1))
    assert max_gap_ms < 100


def test_an_update_of_a_terrain_replaced_meanwhile_is_dropped(qtbot, live_window):
    window, live = live_window, live_window.live
    with qtbot.waitSignal(live.started, timeout=10_000):
        window.document.sketch.draw_polyline([(40, 120), (60, 140)], "ridge", radius=2)
    other = window.document.result
    replaced = type(other)(other.heights + 1.0, other.patch_id, other.seam_mask)
    window.document.set_result(replaced)  # as a variation taken meanwhile would
    with qtbot.waitSignal(live.runner.running_changed, timeout=RUN_TIMEOUT_MS):
        pass  # the update ends (it may be cancelled or finish)
    assert window.document.result is replaced


def test_live_prepares_the_first_strokes_analysis_in_the_background(qtbot, window, monkeypatch):
    """Turning Live on after a run makes the examples' pools and searches the
    first stroke's crop reads, in the background; the stroke then makes none."""
    from terrasynth_core.memo import Memo
    from terrasynth_core.synthesis import feature_patches, fill_patches

    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    made = []
    make_pools, make_search = feature_patches.feature_pools, fill_patches.FillSearch
    monkeypatch.setattr(feature_patches, "_POOLS", Memo(4, once=True))
    monkeypatch.setattr(fill_patches, "_SEARCHES", Memo(4, once=True))
    monkeypatch.setattr(feature_patches, "feature_pools", lambda *a, **k: made.append("pools") or make_pools(*a, **k))
    monkeypatch.setattr(fill_patches, "FillSearch", lambda *a, **k: made.append("search") or make_search(*a, **k))
    window.live._timer.setInterval(20)
    with qtbot.waitSignal(window.live.prepared, timeout=RUN_TIMEOUT_MS):
        window.actions.live.trigger()
    assert sorted(set(made)) == ["pools", "search"]
    prepared = len(made)
    with qtbot.waitSignal(window.live.updated, timeout=RUN_TIMEOUT_MS):
        window.document.sketch.draw_polyline([(120, 30), (125, 90)], "valley", radius=2)
    assert len(made) == prepared
    window.live.wait()


@pytest.mark.parametrize("work", ["run", "variations"])
def test_a_run_or_variations_stop_the_background_preparation(qtbot, window, monkeypatch, work):
    """The preparation builds zone indexes for seconds on a new example; a
    full run or variations started meanwhile need the cores, so they stop
    the preparation at its next zone index."""
    from terrasynth_app.model import live as live_model

    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    asked = []

    def preparing(*args, cancel, **kwargs):
        asked.append(cancel())
        cancel.__self__.wait(RUN_TIMEOUT_MS / 1000)  # the Event cancel reads: set when told to stop
        asked.append(cancel())

    monkeypatch.setattr(live_model, "prepare_resynthesis", preparing)
    ended = window.synthesis.finished if work == "run" else window.variations.finished
    with qtbot.waitSignals([window.live.prepared, ended], timeout=RUN_TIMEOUT_MS):
        window.actions.live.trigger()
        qtbot.waitUntil(lambda: len(asked) == 1)
        window.synthesize() if work == "run" else window.variations.make(2)
    assert asked[:2] == [False, True]  # (a run's end starts another preparation)
    window.live.wait()
    window.variations.wait()
