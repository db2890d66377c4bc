"""Painting through the canvas with real mouse events, undo and redo."""

import numpy as np
from PySide6.QtCore import Qt

from terrasynth_app.model import Sketch
from terrasynth_app.views.sketch_canvas import SketchCanvas


def _canvas(qtbot, shape=(100, 100)):
    canvas = SketchCanvas(Sketch.blank(shape))
    canvas.resize(600, 600)
    qtbot.addWidget(canvas)
    canvas.show()
    qtbot.waitExposed(canvas)
    canvas.view_box.autoRange(padding=0)
    return canvas


def test_mouse_strokes_paint_and_undo_redo_one_stroke_at_a_time(qtbot, cell_pos, drag):
    canvas = _canvas(qtbot)
    sketch = canvas.sketch
    canvas.size_spin.setValue(5)
    drag(canvas, [(20, 10), (20, 40), (20, 80)])
    ridge_after_first = sketch.ridge.copy()
    assert ridge_after_first[20, 12:78].min() >= 200  # a continuous stroke along row 20
    assert ridge_after_first[50:].max() == 0
    canvas.set_tool("valley")
    drag(canvas, [(60, 50), (90, 50)])
    assert sketch.valley[62:88, 50].min() >= 200
    assert canvas.undo_action.isEnabled() and not canvas.redo_action.isEnabled()

    canvas.undo_action.trigger()
    assert sketch.valley.max() == 0
    np.testing.assert_array_equal(sketch.ridge, ridge_after_first)
    canvas.undo_action.trigger()
    assert sketch.ridge.max() == 0 and not canvas.undo_action.isEnabled()
    canvas.redo_action.trigger()
    np.testing.assert_array_equal(sketch.ridge, ridge_after_first)
    assert canvas.redo_action.isEnabled()


def test_keyboard_shortcuts_undo_and_redo(qtbot, cell_pos, drag):
    canvas = _canvas(qtbot)
    drag(canvas, [(50, 10), (50, 90)])
    painted = canvas.sketch.ridge.copy()
    with qtbot.waitActive(canvas):
        canvas.activateWindow()
    canvas.view.setFocus()
    qtbot.keyClick(canvas.view, Qt.Key_Z, Qt.ControlModifier)
    assert canvas.sketch.ridge.max() == 0
    qtbot.keyClick(canvas.view, Qt.Key_Z, Qt.ControlModifier | Qt.ShiftModifier)
    np.testing.assert_array_equal(canvas.sketch.ridge, painted)


def test_the_image_on_screen_follows_the_strokes(qtbot, cell_pos, drag):
    canvas = _canvas(qtbot)
    drag(canvas, [(30, 30), (30, 60)])
    qtbot.waitUntil(lambda: canvas.image.image[30, 45].tolist() == [255, 0, 0], timeout=2000)
    assert canvas.image.image[80, 80].tolist() == [255, 255, 255]


def test_eraser_and_shift_click_straight_line(qtbot, cell_pos, drag):
    canvas = _canvas(qtbot)
    canvas.size_spin.setValue(3)
    drag(canvas, [(10, 10), (10, 11)])
    # Shift+click: a straight line from the end of the last stroke.
    viewport = canvas.view.viewport()
    qtbot.mouseClick(viewport, Qt.LeftButton, Qt.ShiftModifier, cell_pos(canvas, 90, 90))
    diag = canvas.sketch.ridge[np.arange(15, 85), np.arange(15, 85)]
    assert diag.min() >= 200
    canvas.set_tool("erase")
    canvas.size_spin.setValue(30)
    drag(canvas, [(50, 50), (50, 51)])
    assert canvas.sketch.ridge[45:55, 45:55].max() == 0
    assert canvas.sketch.ridge[85, 85] >= 200


def test_polyline_tool_draws_one_undoable_line(qtbot, cell_pos):
    canvas = _canvas(qtbot)
    canvas.set_tool("valley")
    canvas.polyline_action.setChecked(True)
    viewport = canvas.view.viewport()
    for cell in [(10, 10), (10, 80)]:
        qtbot.mouseClick(viewport, Qt.LeftButton, pos=cell_pos(canvas, *cell))
    assert len(canvas.polyline_points) == 2 and canvas.sketch.valley.max() == 0  # not drawn yet
    qtbot.mouseDClick(viewport, Qt.LeftButton, pos=cell_pos(canvas, 80, 80))
    valley = canvas.sketch.valley
    assert valley[10, 12:78].min() >= 200 and valley[12:78, 80].min() >= 200
    assert canvas.polyline_points == []
    canvas.undo_action.trigger()
    assert canvas.sketch.valley.max() == 0 and not canvas.sketch.can_undo
    # Escape drops a polyline in progress.
    qtbot.mouseClick(viewport, Qt.LeftButton, pos=cell_pos(canvas, 50, 50))
    canvas.view.setFocus()
    qtbot.keyClick(canvas.view, Qt.Key_Escape)
    assert canvas.polyline_points == []


def test_feature_graph_overlay_shows_node_types(qtbot):
    sketch = Sketch.blank((120, 120))
    # A Y: one branch point, three endpoints.
    sketch.draw_polyline([(10, 60), (60, 60), (110, 20)], "ridge", radius=2, hardness=1.0)
    sketch.draw_polyline([(60, 60), (110, 100)], "ridge", radius=2, hardness=1.0)
    canvas = SketchCanvas(sketch)
    qtbot.addWidget(canvas)
    with qtbot.waitSignal(canvas.feature_graph_updated, timeout=10_000) as blocker:
        canvas.graph_check.setChecked(True)
    maps = blocker.args[0]
    assert maps.ridges.count("branch") == 1 and maps.ridges.count("end") == 3
    assert canvas.overlay.node_count() == {"branch": 1, "end": 3}
    # An edit recomputes the graph once the strokes settle.
    with qtbot.waitSignal(canvas.feature_graph_updated, timeout=10_000) as blocker:
        sketch.clear()
    assert not blocker.args[0].ridges.paths
