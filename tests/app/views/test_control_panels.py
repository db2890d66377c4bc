"""Artist controls through the GUI: region brushes, the Regions and Pins &
stamps panels, styled runs, local re-synthesis and variations."""

import time

import numpy as np
from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QInputDialog

from terrasynth_app.model import ExampleRef, TerrainResult, builtin_refs

RUN_TIMEOUT_MS = 90_000
GABON = ExampleRef(builtin="gabon-plateau", crop=(0, 300, 0, 300))


def _click(qtbot, canvas, cell_pos, cell):
    qtbot.mouseClick(canvas.view.viewport(), Qt.LeftButton, pos=cell_pos(canvas, *cell))


def _show_all(window):
    window.canvas.view_box.autoRange(padding=0)


def _ramp_result(shape=(160, 160)):
    heights = (300 + np.add.outer(np.arange(shape[0]), np.arange(shape[1]))).astype(np.float32)
    return TerrainResult(heights, np.zeros(shape, np.int32), np.zeros(shape, bool), cell_size=(30.0, 30.0))


def test_region_brushes_paint_styles_and_water_and_undo(qtbot, window, cell_pos, drag):
    canvas, doc = window.canvas, window.document
    _show_all(window)
    canvas.size_spin.setValue(9)
    canvas.set_tool("style")
    with qtbot.waitSignal(canvas.notice) as blocker:  # no style yet: nothing painted, the user is told
        drag(canvas, [(50, 50), (50, 60)])
    assert "Regions panel" in blocker.args[0] and (doc.sketch.style == -1).all()
    spec = window.styles.add_style(GABON)
    assert canvas.current_style == spec.id and canvas.style_combo.currentText() == spec.name
    ridge = doc.sketch.ridge.copy()
    drag(canvas, [(40, 20), (40, 80), (40, 140)])
    assert (doc.sketch.style[40, 22:138] == spec.id).all() and (doc.sketch.style[100:] == -1).all()
    canvas.set_tool("water")
    drag(canvas, [(130, 20), (130, 140)])
    assert doc.sketch.water[130, 22:138].all() and not doc.sketch.water[:100].any()
    np.testing.assert_array_equal(doc.sketch.ridge, ridge)  # the strokes are untouched
    overlay = canvas.controls_overlay
    qtbot.waitUntil(lambda: overlay.regions.image[130, 80, 3] == 150, timeout=2000)
    assert overlay.regions.image[40, 80, :3].tolist() == list(spec.rgb)
    assert overlay.regions.image[80, 80, 3] == 0
    canvas.set_tool("water_erase")
    drag(canvas, [(130, 70), (130, 150)])
    assert doc.sketch.water[130, 22:60].all() and not doc.sketch.water[130, 80:].any()
    canvas.undo_action.trigger()
    assert doc.sketch.water[130, 22:138].all()
    canvas.undo_action.trigger()
    canvas.undo_action.trigger()
    assert not doc.sketch.has_water and (doc.sketch.style == -1).all()


def test_polylines_paint_regions_and_the_clear_buttons_empty_them(qtbot, window, cell_pos, drag):
    canvas, doc = window.canvas, window.document
    _show_all(window)
    spec = window.styles.add_style(GABON)
    canvas.set_tool("style")
    canvas.polyline_action.setChecked(True)
    _click(qtbot, canvas, cell_pos, (20, 20))
    qtbot.mouseDClick(canvas.view.viewport(), Qt.LeftButton, pos=cell_pos(canvas, 20, 140))
    assert (doc.sketch.style[20, 22:138] == spec.id).all()
    canvas.set_tool("water")
    _click(qtbot, canvas, cell_pos, (100, 20))
    qtbot.mouseDClick(canvas.view.viewport(), Qt.LeftButton, pos=cell_pos(canvas, 100, 140))
    assert doc.sketch.water[100, 22:138].all()
    window.styles.clear_water.click()
    assert not doc.sketch.has_water and (doc.sketch.style[20, 22:138] == spec.id).all()
    canvas.undo_action.trigger()  # clearing is one undo step
    assert doc.sketch.water[100, 22:138].all()
    canvas.polyline_action.setChecked(False)
    canvas.set_tool("select")
    drag(canvas, [(10, 10), (30, 30)])
    assert doc.selection.sum() == 21 * 21
    canvas.clear_selection_action.trigger()
    assert doc.selection is None


def test_regions_panel_edits_styles_water_and_height_range(qtbot, window):
    panel, doc = window.styles, window.document
    first = panel.add_style(GABON)
    second = panel.add_style(ExampleRef(builtin="himalaya"))
    assert panel.list.count() == 2 and panel.current_style == second.id and first.color != second.color
    panel.relief.setValue(0.4)
    assert doc.style(second.id).relief_scale == 0.4
    panel.base_auto.setChecked(False)
    panel.base.setValue(900)
    assert doc.style(second.id).base == 900
    panel.base_auto.setChecked(True)
    assert doc.style(second.id).base is None
    panel.name.setText("high peaks")
    panel.name.editingFinished.emit()
    assert doc.style(second.id).name == "high peaks" and "high peaks" in panel.list.item(1).text()
    panel.select_style(first.id)
    assert window.canvas.current_style == first.id  # picking a style in the list picks the brush's style
    panel.remove_current()
    assert [s.id for s in doc.styles] == [second.id] and window.canvas.style_combo.count() == 1

    panel.water_level.setValue(420.5)
    assert doc.water_level == 420.5
    assert not panel.level_from_terrain.isEnabled()
    doc.set_result(_ramp_result())
    assert panel.level_from_terrain.isEnabled()
    panel.level_from_terrain.click()
    assert doc.water_level == doc.suggested_water_level() and panel.water_level.value() == doc.water_level

    panel.range_check.setChecked(True)
    panel.range_low.setValue(100)
    panel.range_high.setValue(50)  # shown, not applied
    assert "top must lie above" in panel.error_label.text() and doc.height_range == (100.0, 1500.0)
    panel.range_high.setValue(2500)
    assert doc.height_range == (100.0, 2500.0) and panel.error_label.text() == ""
    panel.range_check.setChecked(False)
    assert doc.height_range is None


def test_adding_an_unreadable_dem_as_a_style_reports_it(qtbot, window, dialogs, tmp_path):
    bad = tmp_path / "broken.tif"
    bad.write_bytes(b"II*\x00garbage")
    with qtbot.waitSignal(window.styles.style_load_failed, timeout=10_000):
        window.styles.add_file(str(bad))
    assert window.document.styles == [] and "broken.tif" in dialogs.messages("critical")[0]


def test_pins_and_stamps_are_placed_by_clicking(qtbot, window, cell_pos, monkeypatch):
    canvas, doc, panel = window.canvas, window.document, window.pins_stamps
    _show_all(window)
    doc.set_result(_ramp_result())
    asked = []

    def answer(parent, title, label, value, *args):
        asked.append(value)
        return 1234.5, True

    monkeypatch.setattr(QInputDialog, "getDouble", answer)
    canvas.set_tool("pin")
    _click(qtbot, canvas, cell_pos, (30, 50))
    assert asked == [380.0]  # the terrain's height there is offered
    assert [(p.row, p.col, p.height) for p in doc.pins] == [(30, 50, 1234.5)]
    assert panel.pin_table.rowCount() == 1 and panel.pin_table.item(0, 2).text() == "1234.5"
    assert panel.pin_table.item(0, 3).text() == "–"  # no run has met it yet
    assert canvas.controls_overlay.pin_positions() == [(50.5, 30.5)]
    panel.pin_table.item(0, 2).setText("999")
    assert doc.pins[0].height == 999

    qtbot.waitUntil(lambda: panel.stamp_source is not None, timeout=10_000)
    ref, shape = panel.stamp_source
    assert ref == ExampleRef(builtin="st-helens") and shape == (460, 317)
    canvas.set_tool("stamp")
    _click(qtbot, canvas, cell_pos, (80, 90))
    (stamp,) = doc.stamps
    assert stamp.center == (80.0, 90.0) and stamp.example == ref and stamp.scale == 0.14
    assert panel.current_stamp == 0 and panel.scale.value() == 0.14
    panel.rotation.setValue(45)
    panel.scale.setValue(0.2)
    assert (doc.stamps[0].rotation, doc.stamps[0].scale) == (45.0, 0.2)
    x, y = canvas.controls_overlay.stamp_outline()
    finite = np.isfinite(x)
    assert finite.sum() == 5 and abs(np.nanmean(x[finite][:4]) - 90.5) < 1e-6
    panel.remove_current_stamp()
    panel.pin_table.selectRow(0)
    panel.remove_current_pin()
    assert doc.stamps == [] and doc.pins == [] and np.isfinite(canvas.controls_overlay.stamp_outline()[0]).sum() == 0


def test_a_styled_run_with_water_pins_and_a_stamp(qtbot, window, tmp_path):
    doc, panel = window.document, window.pins_stamps
    style = doc.add_style(GABON, relief_scale=0.5)
    doc.sketch.draw_polyline([(0, 120), (159, 120)], "style", radius=30, style=style.id)
    doc.sketch.draw_polyline([(150, 0), (150, 70)], "water", radius=6)
    doc.set_water_level(350)
    doc.add_pin(60, 40, 900)
    qtbot.waitUntil(lambda: panel.stamp_source is not None, timeout=10_000)
    window.pin_stamp_requests.place_stamp(100.0, 100.0)
    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], order="strict",
                           timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    result = doc.result
    assert result.shape == (160, 160) and np.isfinite(result.heights).all()
    (error,) = result.pin_errors
    assert (error.row, error.col, error.target) == (60, 40, 900.0) and abs(error.error) < 1.0
    assert abs(result.heights[60, 40] - 900) < 1.0
    assert result.heights[doc.sketch.water].max() <= 350 + 1e-3
    assert panel.pin_table.item(0, 3).text() == f"{error.error:+.2f}"
    assert "% of the terrain's height range" in panel.pin_summary.text()
    # Everything survives a save and reopen through the window.
    path = tmp_path / "styled.tsproj"
    assert window.file_controller.save_to(path)
    window.files.new_project()
    assert doc.styles == [] and window.styles.list.count() == 0
    assert window.files.open_project(str(path))
    assert [s.id for s in doc.styles] == [style.id] and window.styles.list.count() == 1
    assert panel.pin_table.rowCount() == 1 and panel.pin_table.item(0, 3).text() == f"{error.error:+.2f}"
    assert len(doc.stamps) == 1 and doc.sketch.has_water and doc.water_level == 350
    assert window.canvas.style_combo.count() == 1


def test_resynthesis_changes_only_the_selection(qtbot, window, cell_pos, dialogs, drag):
    doc = window.document
    _show_all(window)
    window.actions.resynthesize.trigger()  # nothing to change yet
    assert "synthesize one first" in dialogs.messages("critical")[-1]
    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], order="strict",
                           timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    before = doc.result
    window.actions.resynthesize.trigger()
    assert "nothing is selected" in dialogs.messages("critical")[-1]

    window.canvas.set_tool("select")
    drag(window.canvas, [(40, 50), (70, 80), (100, 110)])
    selection = doc.selection.copy()
    assert selection.sum() == 61 * 61 and selection[40, 50] and selection[100, 110] and not selection[39, 50]
    window.canvas.set_tool("select_brush")
    window.canvas.size_spin.setValue(5)
    drag(window.canvas, [(130, 20), (130, 40)])
    selection = doc.selection.copy()
    assert selection[130, 20:41].all() and selection.sum() > 61 * 61
    overlay = window.canvas.controls_overlay
    qtbot.waitUntil(lambda: overlay.selection.image is not None and overlay.selection.image[130, 30, 3] > 0,
                    timeout=2000)

    finished = []
    window.synthesis.finished.connect(finished.append)
    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], order="strict",
                           timeout=RUN_TIMEOUT_MS):
        window.actions.resynthesize.trigger()
    after = doc.result
    assert after is not before
    np.testing.assert_array_equal(finished[0].selection, selection)
    outside = ~selection
    assert np.array_equal(after.heights[outside].view(np.uint32), before.heights[outside].view(np.uint32))
    assert not np.array_equal(after.heights[selection], before.heights[selection])
    assert after.seed != before.seed and doc.params.seed == before.seed
    np.testing.assert_array_equal(window.heightmap.heights, after.heights)
    assert "Re-synthesized" in window.statusBar().currentMessage()

    # Cancelled half-way, the terrain stays as it was.
    with qtbot.waitSignal(window.synthesis.run_started, timeout=RUN_TIMEOUT_MS):
        window.actions.resynthesize.trigger()
    with qtbot.waitSignal(window.synthesis.cancelled, timeout=RUN_TIMEOUT_MS):
        window.cancel_synthesis()
    assert doc.result is after
    np.testing.assert_array_equal(window.heightmap.heights, after.heights)
    qtbot.waitUntil(lambda: not window.synthesis.running, timeout=5000)


def test_variations_run_off_the_gui_thread_and_one_can_be_used(qtbot, window, monkeypatch, record_property):
    doc = window.document
    monkeypatch.setattr(QInputDialog, "getInt", lambda *args, **kwargs: (2, True))
    ticks = []
    timer = QTimer(interval=10)
    timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
    timer.start()
    arrived = []
    window.variations.variation_made.connect(lambda i, terrain: arrived.append(i))
    with qtbot.waitSignal(window.variations.finished, timeout=RUN_TIMEOUT_MS) as blocker:
        window.actions.variations.trigger()
    timer.stop()
    max_gap_ms = float(np.diff(ticks).max() * 1000)
    record_property("variations_max_event_loop_gap_ms", round(max_gap_ms, 1))
    assert max_gap_ms < 200
    terrains = blocker.args[0]
    dialog = window.variations_dialog
    assert sorted(arrived) == [0, 1] and len(terrains) == 2 and len(set(dialog.seeds)) == 2
    assert not np.array_equal(terrains[0].heights, terrains[1].heights)
    for i, seed in enumerate(dialog.seeds):
        assert not dialog.thumbnails[i].pixmap().isNull() and dialog.use_buttons[i].isEnabled()
        assert terrains[i].seed == seed and terrains[i].shape == (160, 160)
    assert "2 variations made" in dialog.status.text()
    with qtbot.waitSignal(window.heightmap.result_shown, timeout=10_000):
        qtbot.mouseClick(dialog.use_buttons[1], Qt.LeftButton)
    assert doc.result is terrains[1] and doc.params.seed == dialog.seeds[1]
    assert not dialog.isVisible()
    # The seed reproduces the variation.
    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], order="strict",
                           timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    np.testing.assert_array_equal(doc.result.heights, terrains[1].heights)


def test_closing_the_variations_dialog_cancels_the_batch(qtbot, window):
    before = window.document.result
    with qtbot.waitSignal(window.variations.cancelled, timeout=RUN_TIMEOUT_MS):
        window.make_variations(2)
        window.variations_dialog.reject()
    qtbot.waitUntil(lambda: not window.variations.running, timeout=30_000)
    assert window.document.result is before and window.variations_dialog.status.text() == "Cancelled"
    assert window.actions.variations.text() == "Make variations…"


def test_a_stamp_dem_from_a_file_and_an_unreadable_one(qtbot, window, dialogs, tmp_path):
    from terrasynth_core.heightfield import HeightField
    from terrasynth_core.io import save_dem

    panel = window.pins_stamps
    qtbot.waitUntil(lambda: panel.stamp_source is not None, timeout=10_000)
    bad = tmp_path / "broken.tif"
    bad.write_bytes(b"II*\x00garbage")
    with qtbot.waitSignal(panel.stamp_source_failed, timeout=10_000):
        panel.set_stamp_source(ExampleRef(path=str(bad)))
    assert "broken.tif" in dialogs.messages("critical")[-1]
    assert panel.stamp_source[0] == ExampleRef(builtin="st-helens")  # back to the default
    assert all(panel.source.itemData(i) != ExampleRef(path=str(bad)) for i in range(panel.source.count()))
    assert panel.source.count() == len(builtin_refs()) + 1  # the built-ins and "DEM file…", no duplicate
    good = tmp_path / "cone.asc"
    rr, cc = np.mgrid[:60, :90]
    save_dem(HeightField((2000 - 10 * np.hypot(rr - 30, cc - 45)).astype(np.float32), cell_size=(30.0, 30.0)), good)
    with qtbot.waitSignal(panel.stamp_source_ready, timeout=10_000):
        panel.set_stamp_source(ExampleRef(path=str(good)))
    assert panel.stamp_source == (ExampleRef(path=str(good)), (60, 90))
    assert panel.source_label.text() == "60 x 90 cells"
    window.pin_stamp_requests.place_stamp(50.0, 60.0)
    assert window.document.stamps[0].example.path == str(good) and window.document.stamps[0].scale == 0.71
