"""Synthesis through the worker thread: views update in order, cancel, errors, stalls."""

import time

import numpy as np
from PySide6.QtCore import QTimer

from terrasynth_core.synthesis import LandformProgress, PatchPlaced, StageFinished, StageStarted, SynthesisFinished
from terrasynth_app.model import ExampleRef, RunStarted

RUN_TIMEOUT_MS = 90_000


#: The name each event of a run is logged under.
_KINDS = {RunStarted: "run_started", StageStarted: "stage_started", LandformProgress: "landform_progress",
          PatchPlaced: "patch_placed", StageFinished: "stage_finished", SynthesisFinished: "synthesis_finished"}


def _record(runner):
    """Every event of the runner's current run, as (kind, stage or event)."""
    log = []

    def record(event):
        kind = _KINDS[type(event)]
        log.append((kind, event.stage if kind in ("stage_started", "stage_finished") else event))

    runner.yielded.connect(record)
    return log


def test_a_run_updates_the_views_patch_by_patch_then_shows_the_result(qtbot, window):
    synthesis, view = window.synthesis, window.heightmap
    log = _record(synthesis.runner)
    mismatches = []

    def check_view(event):
        # Connected after the window's own slot: the view has pasted already.
        r0, r1, c0, c1 = event.bbox
        if view.last_bbox != event.bbox or not np.array_equal(view.heights[r0:r1, c0:c1], event.heights):
            mismatches.append(event.index)

    synthesis.patch_placed.connect(check_view)
    sketch_before = window.document.sketch.ridge.copy()
    with qtbot.waitSignals([synthesis.finished, view.result_shown], order="strict",
                           timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    kinds = [k for k, _ in log]
    assert kinds[0] == "run_started" and kinds[-1] == "synthesis_finished"
    stages = [arg for k, arg in log if k == "stage_started"]
    assert stages == ["landform", "analyse", "features", "fill", "finish"]
    # The coarse landform pass reports its patches before the analysis starts.
    landform = [i for i, (k, _) in enumerate(log) if k == "landform_progress"]
    analyse = log.index(("stage_started", "analyse"))
    assert landform and max(landform) < analyse
    patches = [arg for k, arg in log if k == "patch_placed"]
    assert [p.index for p in patches] == list(range(len(patches)))
    assert any(p.kind == "fill" for p in patches) and any(p.kind != "fill" for p in patches)
    # The views paint each landform preview as it comes, then every patch.
    previews = [arg for k, arg in log if k == "landform_progress"]
    assert all(event.heights.shape == (event.bbox[1] - event.bbox[0], event.bbox[3] - event.bbox[2])
               for event in previews)
    assert mismatches == [] and view.patches_pasted == len(previews) + len(patches)
    # Feature patches come while the "features" stage runs, fill patches after.
    first_fill = kinds.index("stage_started", kinds.index("stage_finished"))
    assert all(p.kind != "fill" for k, p in log[:first_fill] if k == "patch_placed")

    result = window.document.result
    assert result is not None and result.shape == (160, 160)
    assert np.isfinite(result.heights).all()
    np.testing.assert_array_equal(view.heights, result.heights)
    assert window.document.dirty and not synthesis.running
    assert not window.actions.cancel.isEnabled()
    assert window.run_status.progress.value() == window.run_status.progress.maximum() == len(patches)
    np.testing.assert_array_equal(window.document.sketch.ridge, sketch_before)

    view.set_overlay("patch_ids", True)
    view.set_overlay("seams", True)
    assert view.patch_image.isVisible() and view.seam_image.isVisible()
    assert view.seam_image.image[..., 3].astype(bool).sum() == result.seam_mask.sum()
    with qtbot.waitSignal(view.terrain_features_ready, timeout=30_000):
        view.set_overlay("terrain_features", True)
    assert view.terrain_overlay.maps.ridges.paths


def test_cancel_mid_run_keeps_the_previous_result(qtbot, window):
    synthesis = window.synthesis
    with qtbot.waitSignal(synthesis.finished, timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    first = window.document.result
    window.document.sketch.draw_polyline([(100, 10), (100, 150)], "valley", radius=2)
    finished = []
    synthesis.finished.connect(finished.append)
    with qtbot.waitSignal(synthesis.patch_placed, timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    with qtbot.waitSignal(synthesis.cancelled, timeout=RUN_TIMEOUT_MS):
        window.cancel_synthesis()
    assert finished == [] and window.document.result is first
    np.testing.assert_array_equal(window.heightmap.heights, first.heights)
    assert window.run_status.stage_label.text() == "Cancelled"
    qtbot.waitUntil(lambda: not synthesis.running, timeout=5000)


def test_a_new_run_cancels_the_old_one(qtbot, window):
    synthesis = window.synthesis
    indices = []
    synthesis.patch_placed.connect(lambda event: indices.append(event.index))
    with qtbot.waitSignal(synthesis.patch_placed, timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    restart = len(indices)
    with qtbot.waitSignal(synthesis.finished, timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    second = indices[restart:]
    # Only the new run's patches arrive after the restart: one run, from 0.
    assert second == list(range(len(second))) and len(second) > 0
    assert window.document.result is not None


def test_a_corrupt_example_gives_an_error_dialog_and_loses_nothing(qtbot, window, dialogs, tmp_path):
    with qtbot.waitSignal(window.synthesis.finished, timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    good = window.document.result
    bad = tmp_path / "broken.hgt"
    bad.write_bytes(b"\x00\x01" * 1000)  # not 1201x1201 or 3601x3601 samples
    window.document.set_examples([ExampleRef(path=str(bad))])
    sketch = window.document.sketch.ridge.copy()
    with qtbot.waitSignal(window.synthesis.failed, timeout=RUN_TIMEOUT_MS) as blocker:
        window.synthesize()
    assert "broken.hgt" in blocker.args[0]
    assert len(dialogs.messages("critical")) == 1 and "broken.hgt" in dialogs.messages("critical")[0]
    assert "broken.hgt" in window.statusBar().currentMessage()
    assert window.document.result is good
    np.testing.assert_array_equal(window.document.sketch.ridge, sketch)
    np.testing.assert_array_equal(window.heightmap.heights, good.heights)


def test_the_event_loop_never_stalls_during_a_run(qtbot, window, record_property):
    ticks = []
    timer = QTimer(interval=10)
    timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
    timer.start()
    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], order="strict",
                           timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    # A few more ticks: showing the result follows the last signal.
    count = len(ticks)
    qtbot.waitUntil(lambda: len(ticks) >= count + 5, timeout=2000)
    timer.stop()
    gaps = np.diff(ticks)
    max_gap_ms = float(gaps.max() * 1000)
    record_property("max_event_loop_gap_ms", round(max_gap_ms, 1))
    print(f"\nevent loop: {len(ticks)} ticks, max gap {max_gap_ms:.1f} ms, "
          f"95th percentile {np.percentile(gaps, 95) * 1000:.1f} ms")
    assert max_gap_ms < 100
