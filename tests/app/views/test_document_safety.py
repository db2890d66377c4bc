"""Issue 13, finding 9 through the GUI: removing a style is undoable, pins and
stamps follow a resized sketch (and undo puts them back), and a project keeps
the result's georeference and the selection."""

import numpy as np
from PySide6.QtCore import Qt

from terrasynth_app.model import ExampleRef, StampSpec

RUN_TIMEOUT_MS = 90_000
GABON = ExampleRef(builtin="gabon-plateau", crop=(0, 300, 0, 300))


def test_removing_a_style_is_undone_and_redone(qtbot, window):
    doc, panel, canvas = window.document, window.styles, window.canvas
    first = panel.add_style(GABON)
    second = panel.add_style(ExampleRef(builtin="himalaya"))
    doc.sketch.draw_polyline([(0, 40), (159, 40)], "style", radius=10, style=second.id)
    painted = doc.sketch.style.copy()
    panel.select_style(first.id)
    qtbot.mouseClick(panel.remove_button, Qt.LeftButton)
    assert [s.id for s in doc.styles] == [second.id]
    assert canvas.undo_action.isEnabled()
    canvas.undo_action.trigger()
    assert doc.styles == [first, second]  # back at its place, same id, colour and example
    assert panel.list.count() == 2
    np.testing.assert_array_equal(doc.sketch.style, painted)
    canvas.redo_action.trigger()
    assert doc.styles == [second]
    # Undo goes on through the strokes before the removal, in order.
    canvas.undo_action.trigger()
    canvas.undo_action.trigger()
    assert doc.styles == [first, second] and (doc.sketch.style == -1).all()


def test_pins_and_stamps_follow_a_new_sketch_size_and_undo(qtbot, window, monkeypatch):
    from terrasynth_app.views.dialogs import NewSketchDialog

    doc, canvas = window.document, window.canvas
    doc.add_pin(80, 40, 500.0)
    doc.add_pin(159, 0, 700.0)
    doc.add_stamp(StampSpec(ExampleRef(builtin="st-helens"), (40.0, 120.0), (460, 317), rotation=30, scale=0.1))

    def choose_size(dialog):
        dialog.rows.setValue(320)
        dialog.cols.setValue(320)
        return True

    monkeypatch.setattr(NewSketchDialog, "exec", choose_size)
    window.files.new_sketch()
    assert doc.sketch.shape == (320, 320)
    # Cell centres map as (i + 0.5) * 2 - 0.5; the stamp's footprint doubles.
    assert [(p.row, p.col, p.height) for p in doc.pins] == [(160, 80, 500.0), (318, 0, 700.0)]
    (stamp,) = doc.stamps
    assert stamp.center == (80.5, 240.5) and abs(stamp.scale - 0.2) < 1e-12 and stamp.rotation == 30
    assert window.pins_stamps.pin_table.item(0, 1).text() == "160, 80"
    canvas.undo_action.trigger()  # the resize and what it moved are one step
    assert doc.sketch.shape == (160, 160)
    assert [(p.row, p.col) for p in doc.pins] == [(80, 40), (159, 0)]
    assert doc.stamps[0].center == (40.0, 120.0) and doc.stamps[0].scale == 0.1
    canvas.redo_action.trigger()
    assert doc.sketch.shape == (320, 320) and doc.stamps[0].center == (80.5, 240.5)
    assert [(p.row, p.col) for p in doc.pins] == [(160, 80), (318, 0)]


def test_a_project_keeps_the_georeference_and_the_selection(qtbot, window, tmp_path):
    doc = window.document
    with qtbot.waitSignal(window.synthesis.finished, timeout=RUN_TIMEOUT_MS):
        window.synthesize()
    georef, cell = doc.result.georef, doc.result.cell_size
    assert georef is not None and cell is not None
    doc.select_rect(20, 60, 30, 90)
    selection = doc.selection.copy()
    path = tmp_path / "placed.tsproj"
    assert window.file_controller.save_to(path)
    window.files.new_project()
    assert doc.selection is None and doc.result is None
    assert window.files.open_project(str(path))
    assert doc.result.georef == georef and doc.result.georef.crs_wkt == georef.crs_wkt
    assert doc.result.cell_size == cell
    np.testing.assert_array_equal(doc.selection, selection)
    assert not doc.dirty
    # Re-synthesis works on the reopened selection at once.
    assert doc.resynthesis_request(seed=9).selection.sum() == 40 * 60


def test_a_sketch_too_long_for_the_canvas_is_one_error_and_keeps_the_sketch(qtbot, window, dialogs, tmp_path):
    """16000x2 pixels pass the reader's pixel limit but not the canvas's 8000-cell side."""
    from PIL import Image

    rgb = np.full((2, 16000, 3), 255, np.uint8)
    rgb[:, 100:200] = (255, 0, 0)
    Image.fromarray(rgb).save(tmp_path / "long.png")
    ridge = window.document.sketch.ridge.copy()
    window.files.open_sketch(str(tmp_path / "long.png"))
    [message] = dialogs.messages("critical")
    assert "8000" in message
    np.testing.assert_array_equal(window.document.sketch.ridge, ridge)
