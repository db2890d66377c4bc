"""What the result views show an artist (issue 15): water and the drowning
warning, one colour ramp with a legend and a hover readout, a layout that
does not jump, linked sketch and terrain views, and status that follows
every change of the terrain."""

import numpy as np
import pytest
from PySide6.QtCore import QPoint, QRect, Qt
from PySide6.QtWidgets import QApplication

from terrasynth_core.pictures import TERRAIN_LUT, shaded_relief, terrain_colours
from terrasynth_app.model import TerrainResult
from terrasynth_app.model.water_check import document_drowning
from terrasynth_app.views.heightmap_view import PLACEHOLDER
from terrasynth_app.views.linked_views import view_state

RUN_TIMEOUT_MS = 90_000


def settle():
    """Let posted layout requests and resizes run (no timers, no sleeping)."""
    for _ in range(3):
        QApplication.sendPostedEvents()
        QApplication.processEvents()


def run(qtbot, window):
    with qtbot.waitSignals([window.synthesis.finished, window.heightmap.result_shown], timeout=RUN_TIMEOUT_MS):
        window.synthesize()


def window_rect(widget, window) -> QRect:
    return QRect(widget.mapTo(window, QPoint(0, 0)), widget.size())


def fake_terrain(shape=(160, 160)) -> TerrainResult:
    """A bowl: low in the middle, 100 m at the middle, 900 m at the corners."""
    rows, cols = np.mgrid[:shape[0], :shape[1]]
    r = np.hypot(rows - shape[0] / 2, cols - shape[1] / 2)
    heights = (100.0 + 800.0 * (r / r.max()) ** 2).astype(np.float32)
    return TerrainResult(heights, np.zeros(shape, np.int32), np.zeros(shape, bool), cell_size=(30.0, 30.0))


@pytest.fixture
def lake_window(window):
    """The small document with a lake painted in the middle of a bowl terrain."""
    water = np.zeros((160, 160), bool)
    water[70:90, 70:90] = True
    window.document.sketch.replace_regions(water=water)
    window.document.set_result(fake_terrain())
    settle()
    return window


# -- 1, 2: water and the drowning warning ---------------------------------------------------------
def test_water_is_drawn_blue_by_depth_and_follows_the_level_live(lake_window):
    view, doc = lake_window.heightmap, lake_window.document
    doc.set_water_level(float(doc.result.heights[80, 80]) + 1.0)  # just over the lake's floor
    few = view.water_cells()
    assert few > 0
    doc.set_water_level(400.0)
    many = view.water_cells()
    expected = int((doc.result.heights < 400.0).sum())
    assert many == expected > few  # every cell below the level, redrawn at once
    rgba = view.water_image.image
    centre, shore = rgba[80, 80], rgba[np.nonzero(rgba[:, 80, 3])[0][0], 80]
    assert centre[2] > centre[0] + 50 and centre[3] > 200  # blue, nearly opaque
    assert shore[:3].min() > 200  # the shoreline is drawn light
    # Deeper is darker: the middle of the bowl against a cell near the shore.
    near_shore = rgba[np.nonzero(rgba[:, 80, 3])[0][0] + 3, 80]
    assert centre[:3].sum() < near_shore[:3].sum()
    # The legend marks the level.
    assert view.height_legend.isVisible() and view.height_legend.water_level == 400.0


def test_land_below_the_level_raises_a_banner_whose_fix_leaves_no_land_drowned(qtbot, lake_window):
    window, view, doc = lake_window, lake_window.heightmap, lake_window.document
    run(qtbot, window)  # a real terrain with its lake at the level (0 m)
    assert not view.banner.isVisible() and view.water_cells() >= 400
    doc.set_water_level(500.0)  # raised: floods far beyond the painted lake, as "From terrain" can
    drowning = document_drowning(doc)
    assert view.banner.isVisible() and drowning is not None
    text = view.banner.label.text()
    assert f"{drowning.share:.1%}" in text and "500 m" in text and str(drowning.cells) in text
    # Inside the result view, across its top, not cut: it wraps instead.
    banner = window_rect(view.banner, window)
    assert window_rect(view.view, window).contains(banner)
    assert view.banner.label.heightForWidth(view.banner.label.width()) <= view.banner.label.height()
    # One click: the level goes down to the highest that drowns no land, and a run starts.
    with qtbot.waitSignals([window.synthesis.run_started, window.synthesis.finished], timeout=RUN_TIMEOUT_MS):
        qtbot.mouseClick(view.banner.fix_buttons[0], Qt.LeftButton)
        assert doc.water_level == drowning.safe_level
    settle()
    assert document_drowning(doc) is None and not view.banner.isVisible()
    assert view.water_cells() > 0  # the painted lake is below the new level


def test_the_banners_other_fix_draws_only_water_connected_to_the_painted_water(qtbot, window):
    """Two basins, water painted in the western one only: the eastern one
    is below the level but no water reaches it."""
    rows, cols = np.mgrid[:160, :160]
    heights = (500.0 - 400.0 * np.exp(-((rows - 80) ** 2 + (cols - 40) ** 2) / 400.0)
               - 400.0 * np.exp(-((rows - 80) ** 2 + (cols - 120) ** 2) / 400.0)).astype(np.float32)
    water = np.zeros((160, 160), bool)
    water[75:85, 35:45] = True
    doc, view = window.document, window.heightmap
    doc.sketch.replace_regions(water=water)
    doc.set_result(TerrainResult(heights, np.zeros((160, 160), np.int32), np.zeros((160, 160), bool),
                                 cell_size=(30.0, 30.0)))
    doc.set_water_level(300.0)
    settle()
    both = view.water_cells()
    assert both == int((heights < 300).sum()) and view.banner.isVisible()
    qtbot.mouseClick(view.banner.fix_buttons[1], Qt.LeftButton)
    assert view.connected_water_check.isChecked()
    drawn = view.water_image.image[..., 3] > 0
    assert drawn[80, 40] and not drawn[80, 120] and view.water_cells() == pytest.approx(both / 2, abs=2)
    # Still said, since another program's water plane would cover the basin.
    assert view.banner.isVisible() and "drawn dry" in view.banner.label.text()
    assert not view.banner.fix_buttons[1].isVisible()
    view.connected_water_check.setChecked(False)
    assert view.water_cells() == both


def test_without_painted_water_nothing_is_drawn_as_water(window):
    window.document.set_result(fake_terrain())
    window.document.set_water_level(5000.0)
    assert window.heightmap.water_cells() == 0 and not window.heightmap.banner.isVisible()
    assert window.view3d.water_level is None


# -- 3: one ramp, legend, readout ----------------------------------------------------------------
def test_the_legend_shows_the_views_height_range_in_metres_and_the_readout_the_cell(qtbot, lake_window, cell_pos):
    window, view = lake_window, lake_window.heightmap
    legend = view.height_legend
    assert legend.isVisible() and legend.vrange == (float(window.document.result.heights.min()),
                                                     float(window.document.result.heights.max()))
    ticks = legend.ticks()
    assert len(ticks) >= 3 and all(legend.vrange[0] <= t <= legend.vrange[1] for t in ticks)
    # The legend floats in the result view's corner.
    assert window_rect(view.view, window).contains(window_rect(legend, window))
    # The 2D image is the one ramp over that very range, under a hillshade.
    result = window.document.result
    assert np.array_equal(view._rgba, shaded_relief(result.heights, cell_size=result.cell_size,
                                                    vrange=legend.vrange))
    assert np.array_equal(terrain_colours(np.array([[legend.vrange[1]]]), vrange=legend.vrange)[0, 0],
                          TERRAIN_LUT[255])
    # Hovering a cell tells its row, column, height, slope and water.
    window.document.set_water_level(300.0)
    qtbot.mouseMove(view.view.viewport(), cell_pos(view, 40, 80))
    text = window.run_status.readout.text()
    height = float(window.document.result.heights[40, 80])
    assert text.startswith("row 40, col 80: ") and f"{height:.1f} m" in text and "slope" in text
    assert "under water" not in text if height >= 300 else "under water" in text
    # The sketch canvas tells the same of its cells (e.g. where a pin will go).
    qtbot.mouseMove(window.canvas.view.viewport(), cell_pos(window.canvas, 100, 30))
    assert window.run_status.readout.text().startswith(
        f"row 100, col 30: {float(window.document.result.heights[100, 30]):.1f} m")


# -- 4: layout that stays put ---------------------------------------------------------------------
def test_tabs_overlays_banner_and_long_texts_do_not_move_the_views(qtbot, lake_window):
    window, view = lake_window, lake_window.heightmap
    settle()

    def geometry():
        return (window_rect(window.canvas.view, window), window_rect(view.view, window),
                window_rect(window.result_tabs, window),
                [window_rect(check, window) for check in view.overlay_checks.values()],
                window_rect(window.run_status.progress, window))

    before = geometry()
    # The splitter's halves stay even: nothing in the result panel sets a
    # large minimum width.
    canvas_width, result_width = window.canvas.width(), window.result_tabs.width()
    assert abs(canvas_width - result_width) <= 0.1 * (canvas_width + result_width)
    # The 3D tab's long notice (as on software OpenGL), then back to 2D.
    window.view3d.notice.setText("Live 3D off: a frame takes 63 ms with this OpenGL; the terrain shows when a "
                                 "run ends." * 3)
    window.result_tabs.setCurrentWidget(window.view3d)
    settle()
    assert window_rect(window.canvas.view, window) == before[0]
    assert window_rect(window.result_tabs, window) == before[2]
    window.result_tabs.setCurrentWidget(view)
    settle()
    assert geometry() == before
    # Overlays with legends, the canvas's graph overlay, the warning banner.
    for name in view.overlay_checks:
        view.set_overlay(name, True)
        settle()
        assert geometry() == before, name
    assert view.legend.isVisible()
    window.canvas.graph_check.setChecked(True)
    settle()
    assert window.canvas.legend.isVisible() and geometry() == before
    window.document.set_water_level(600.0)
    settle()
    assert view.banner.isVisible() and geometry() == before
    # Long status texts elide in their fixed places, side by side in the window.
    status = window.run_status
    status.stage_label.setText("Placing feature patches " * 10)
    status.readout.setText("row 1, col 2: " + "x" * 400)
    settle()
    assert geometry() == before
    assert status.stage_label.shown_text().endswith("…") and status.readout.shown_text().endswith("…")
    places = [window_rect(w, window) for w in (status.readout, status.stage_label, status.progress,
                                                 status.time_label)]
    assert all(window.rect().contains(r) for r in places)
    assert all(a.right() < b.left() for a, b in zip(places, places[1:]))  # in order, none overlapping
    # A long message ends in "…" before them, and its tooltip holds all of it.
    message = "Synthesized 768 x 1024 cells of 90 m in 17.8 s - 29099 land cells lie below the water level " * 3
    window.show_status(message)
    bar = window.statusBar()
    assert bar.currentMessage() == message and bar.toolTip() == message
    assert bar.shown_message().endswith("…") and bar.message_rect().right() < places[0].left()


def test_the_placeholder_is_whole_at_any_window_size(window):
    window.document.set_result(None)
    view = window.heightmap
    for width in (1500, 900):
        window.resize(width, 700)
        settle()
        assert view.placeholder.isVisible() and view.placeholder.text() == PLACEHOLDER
        label = window_rect(view.placeholder, window)
        assert window_rect(view.view, window).contains(label)
        assert view.placeholder.heightForWidth(view.placeholder.width()) <= view.placeholder.height()


# -- 5: linked views ------------------------------------------------------------------------------
def wheel(view, cell, steps: int, viewport_pos) -> None:
    """Turn the mouse wheel ``steps`` notches over ``cell`` (row, col) of
    ``view`` (``viewport_pos``: the ``cell_pos`` fixture)."""
    from PySide6.QtCore import QPointF
    from PySide6.QtGui import QWheelEvent

    pos = QPointF(viewport_pos(view, *cell))
    event = QWheelEvent(pos, QPointF(view.view.viewport().mapToGlobal(pos.toPoint())), QPoint(0, 0),
                        QPoint(0, 120 * steps), Qt.NoButton, Qt.NoModifier, Qt.NoScrollPhase, False)
    QApplication.sendEvent(view.view.viewport(), event)
    settle()  # the box applies a new range on its next update


def test_the_sketch_and_the_terrain_zoom_and_pan_together(lake_window, cell_pos):
    window = lake_window
    canvas, view = window.canvas.view_box, window.heightmap.view_box
    assert view_state(canvas) == pytest.approx(view_state(view), rel=1e-3)
    canvas.setRange(xRange=(40, 80), yRange=(100, 140), padding=0)  # e.g. Fit, or a script
    assert view_state(canvas) == pytest.approx(view_state(view), rel=1e-3)
    # Zooming the terrain with the wheel zooms the sketch.
    before = view_state(canvas)[2]
    wheel(window.heightmap, (120, 60), 3, cell_pos)
    assert view_state(canvas)[2] < before * 0.9
    assert view_state(canvas) == pytest.approx(view_state(view), rel=1e-3)
    # Behind the 3D tab and back: still in line, the sketch untouched.
    held = view_state(canvas)
    window.result_tabs.setCurrentWidget(window.view3d)
    settle()
    window.result_tabs.setCurrentWidget(window.heightmap)
    settle()
    assert view_state(canvas) == pytest.approx(held, rel=1e-3)
    assert view_state(view) == pytest.approx(held, rel=1e-3)
    # Unlinked, each zooms alone; relinked, the last one zoomed leads.
    window.heightmap.link_check.setChecked(False)
    wheel(window.canvas, (120, 60), -2, cell_pos)
    assert view_state(canvas)[2] != pytest.approx(view_state(view)[2], rel=1e-3)
    window.heightmap.link_check.setChecked(True)
    assert view_state(view) == pytest.approx(view_state(canvas), rel=1e-3)


# -- 6: status follows every change ---------------------------------------------------------------
def test_progress_and_time_clear_on_a_variation_a_project_and_a_new_run(qtbot, window, tmp_path):
    status = window.run_status
    assert status.progress.text() == ""  # idle: no count (not Qt's "0 / 100")
    run(qtbot, window)
    assert status.progress.value() == status.progress.maximum() > 0
    n = status.progress.maximum()
    assert status.progress.text() == f"{n} / {n} patches"
    assert status.time_label.text().endswith(" s") and status.stage_label.text() == "Done"
    window.variations.use(7, fake_terrain())  # a variation chosen
    assert status.progress.value() == 0 and status.time_label.text() == "" and status.stage_label.text() == "Ready"
    assert status.progress.text() == ""
    run(qtbot, window)
    path = tmp_path / "p.tsproj"
    assert window.file_controller.save_to(path)
    assert status.time_label.text() != ""
    assert window.file_controller.open_project(str(path))  # a project opened
    assert status.progress.value() == 0 and status.time_label.text() == "" and status.stage_label.text() == "Ready"
    run(qtbot, window)
    with qtbot.waitSignals([window.synthesis.run_started, window.synthesis.finished], timeout=RUN_TIMEOUT_MS):
        window.synthesize()  # a new run: no count or time of the last one
        assert status.time_label.text() == "" and status.stage_label.text() == "Reading examples…"
        assert status.progress.maximum() == 0  # busy until the patch count is known


def test_a_live_run_recolours_the_patches_pasted_since_the_last_tick_in_one_go(qtbot, window):
    # Shading each patch as it came let a burst of queued patches hold the
    # event loop; the view pastes heights at once and recolours on its tick.
    from types import SimpleNamespace

    view = window.heightmap
    terrain = fake_terrain((96, 96)).heights
    view.begin_run((96, 96), cell_size=(30.0, 30.0), vrange=(100.0, 900.0))
    blank = view._rgba.copy()
    for bbox in ((0, 32, 0, 32), (0, 32, 24, 56), (64, 96, 64, 96)):  # two neighbours and one far away
        r0, r1, c0, c1 = bbox
        view.paste_patch(SimpleNamespace(bbox=bbox, heights=terrain[r0:r1, c0:c1]))
    assert np.array_equal(view._rgba, blank)  # nothing shaded yet
    assert len(view._unshaded) == 2  # the neighbours in one window, the far patch in another
    with qtbot.waitSignal(view.refreshed, timeout=5_000):
        pass
    placed = np.isfinite(view.heights)
    expected = shaded_relief(view.heights, cell_size=(30.0, 30.0), vrange=(100.0, 900.0))
    assert np.array_equal(view._rgba[placed], expected[placed])
    assert not view._rgba[~placed, 3].any()  # transparent where nothing was placed
    view.end_run()


def test_patches_along_a_diagonal_are_not_recoloured_with_the_map_between_them():
    from terrasynth_app.views.heightmap_view import _joined

    windows = []
    for k in range(10):
        windows = _joined(windows, (30 * k, 30 * k + 32, 30 * k, 30 * k + 32))
    shaded = sum((w[1] - w[0]) * (w[3] - w[2]) for w in windows)
    assert shaded <= 2 * 10 * 32 * 32  # (joining window to window, it grew to the whole 302x302 diagonal)
    assert sum(w[4] for w in windows) == 10 * 32 * 32
