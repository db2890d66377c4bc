"""The sketch canvas: paint ridges and valleys, draw polylines, erase, zoom and pan.

Left button paints with the current tool; Shift+click draws a straight line
from the end of the last stroke; in polyline mode clicks add vertices and a
double-click or Enter finishes the line (Esc drops it).  The wheel zooms and
the middle button pans.  The feature graph the synthesis will follow
(ridges, valleys, branch points and endpoints) can be overlaid; it is
recomputed off the GUI thread when the strokes settle.

Given the document, the canvas also paints style regions and water with
the same brushes, selects cells for re-synthesis (a dragged rectangle,
Shift adds; or a brush, Ctrl removes) and places elevation pins and stamps:
a click there is reported by signal, and the window asks for the details.
"""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QEvent, QObject, QPointF, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QActionGroup, QColor, QKeySequence, QPen
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDoubleSpinBox, QGraphicsEllipseItem, QGraphicsRectItem,
                               QLabel, QSpinBox, QToolBar, QVBoxLayout, QWidget)

from ..controllers import FeatureGraphController
from ..model import SketchGraph
from ..model.document import Document
from ..model.sketch_layers import TOOLS, Sketch
from .controls_overlay import ControlsOverlay
from .feature_overlay import FeatureGraphOverlay, legend_text
from .overlay_widgets import note_label, pin_overlay
from .style_panel import swatch

#: Delay after the last edit before the feature graph is recomputed, in ms.
GRAPH_DELAY_MS = 400
#: Coalescing delay of image refreshes while painting, in ms (about 60/s).
REFRESH_MS = 16
#: Tools that act on the document rather than paint the sketch.
DOCUMENT_TOOLS = ("select", "select_brush", "pin", "stamp")


class SketchCanvas(QWidget):
    """Editor of a :class:`~terrasynth_app.model.Sketch`.

    Parameters
    ----------
    sketch : Sketch
        The document's sketch; the canvas follows its ``changed`` event.
    document : Document, optional
        The document owning ``sketch``; with it the canvas gets the style,
        water, selection, pin and stamp tools and draws them.

    Signals
    -------
    feature_graph_updated(object)
        The overlay's new ``FeatureMaps`` after a background recompute.
    pin_requested(int, int)
        The pin tool clicked output cell ``(row, col)``.
    stamp_requested(float, float)
        The stamp tool clicked the cell ``(row, col)``.
    notice(str)
        Something the user should read (e.g. why a tool did nothing).
    hovered(int, int)
        The mouse is over cell ``(row, col)``; ``(-1, -1)`` off the sketch.
    """

    feature_graph_updated = Signal(object)
    pin_requested = Signal(int, int)
    stamp_requested = Signal(float, float)
    notice = Signal(str)
    hovered = Signal(int, int)

    def __init__(self, sketch: Sketch, parent: QWidget | None = None, *, document: Document | None = None,
                 graphs: FeatureGraphController | None = None) -> None:
        super().__init__(parent)
        self.sketch = sketch
        self.document = document
        self.graphs = graphs if graphs is not None else FeatureGraphController(
            SketchGraph(sketch), delay_ms=GRAPH_DELAY_MS, parent=self)
        self._drag: str | None = None  # tool of the drag in progress
        self._rect_start: tuple[float, float] | None = None
        self._stroking = False
        self._last_point: tuple[float, float] | None = None
        self._poly_points: list[tuple[float, float]] = []
        self._rgb = sketch.to_rgb()

        self.view = pg.GraphicsView()
        self.view_box = pg.ViewBox(invertY=True, lockAspect=True, enableMenu=False)
        self.view.setCentralItem(self.view_box)
        self.view.setBackground((70, 70, 70))
        self.image = pg.ImageItem()
        self.image.setImage(self._rgb, autoLevels=False, levels=None)
        self.view_box.addItem(self.image)
        self.overlay = FeatureGraphOverlay(self.view_box)
        self._poly_preview = pg.PlotCurveItem(pen=pg.mkPen((30, 30, 30), width=1, style=Qt.DashLine))
        self._poly_preview.setZValue(30)
        self.view_box.addItem(self._poly_preview)
        self._cursor = QGraphicsEllipseItem()
        pen = QPen(QColor(20, 20, 20))
        pen.setCosmetic(True)
        self._cursor.setPen(pen)
        self._cursor.setZValue(40)
        self._cursor.setVisible(False)
        self.view_box.addItem(self._cursor)
        self._rubber_band = QGraphicsRectItem()
        pen = QPen(QColor(200, 150, 0), 1.5, Qt.DashLine)
        pen.setCosmetic(True)
        self._rubber_band.setPen(pen)
        self._rubber_band.setZValue(40)
        self._rubber_band.setVisible(False)
        self.view_box.addItem(self._rubber_band)
        self.controls_overlay = ControlsOverlay(self.view_box, document) if document is not None else None
        self.view_box.autoRange(padding=0.02)

        self._build_toolbar()
        self.region_bars = self._build_region_bars() if document is not None else []
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.toolbar)
        for bar in self.region_bars:
            layout.addWidget(bar)
        layout.addWidget(self.options_bar)
        layout.addWidget(self.view, 1)
        # Floats over the image: showing it must not move the canvas under the brush.
        self.legend = pin_overlay(note_label(legend_text()), self.view, "bottom_left")
        self.legend.setVisible(False)

        self._refresh_timer = QTimer(self, singleShot=True, interval=REFRESH_MS)
        self._refresh_timer.timeout.connect(self._refresh_image)
        self.graphs.ready.connect(self._graph_ready)
        self.graphs.failed.connect(self._graph_failed)

        self.view.viewport().installEventFilter(self)
        self.view.installEventFilter(self)
        self.view.viewport().setMouseTracking(True)
        sketch.changed.connect(self._sketch_changed)
        sketch.history_changed.connect(self._update_history_actions)
        self._update_history_actions()
        if document is not None:
            document.changed.connect(self._document_changed)

    # -- toolbar --------------------------------------------------------------------
    def _build_toolbar(self) -> None:
        self.toolbar = QToolBar("Sketch tools")
        self.toolbar.setToolButtonStyle(Qt.ToolButtonTextOnly)
        self.tool_group = QActionGroup(self)
        self.tool_actions: dict[str, QAction] = {}
        for tool, text, tip in (
            ("ridge", "Ridge", "Paint ridges (red)"),
            ("valley", "Valley", "Paint valleys (blue)"),
            ("erase", "Eraser", "Erase ridges and valleys"),
        ):
            action = QAction(text, self, checkable=True, toolTip=tip)
            self.tool_group.addAction(action)
            self.toolbar.addAction(action)
            self.tool_actions[tool] = action
        self.tool_actions["ridge"].setChecked(True)
        self.polyline_action = QAction("Polyline", self, checkable=True,
                                       toolTip="Click vertices; double-click or Enter finishes, Esc cancels")
        self.polyline_action.toggled.connect(lambda _on: self.cancel_polyline())
        self.toolbar.addAction(self.polyline_action)
        self.toolbar.addSeparator()

        self.size_spin = QSpinBox(minimum=1, maximum=200, value=9, suffix=" px")
        self.size_spin.setToolTip("Brush diameter in sketch cells")
        self.hardness_spin = QDoubleSpinBox(minimum=0.0, maximum=1.0, singleStep=0.1, value=0.8, decimals=2)
        self.hardness_spin.setToolTip("Share of the brush radius painted at full strength; "
                                      "the rest fades out (0 = soft, 1 = hard)")
        self.options_bar = QToolBar("Brush options")
        self.options_bar.addWidget(QLabel(" Size "))
        self.options_bar.addWidget(self.size_spin)
        self.options_bar.addWidget(QLabel(" Hardness "))
        self.options_bar.addWidget(self.hardness_spin)
        self.options_bar.addSeparator()

        self.undo_action = QAction("Undo", self, shortcut=QKeySequence.Undo, toolTip="Undo the last stroke (Ctrl+Z)")
        self.undo_action.triggered.connect(self.sketch.undo)
        self.redo_action = QAction("Redo", self, toolTip="Redo the stroke undone (Ctrl+Shift+Z)")
        self.redo_action.setShortcuts([QKeySequence("Ctrl+Shift+Z"), QKeySequence("Ctrl+Y")])
        self.redo_action.triggered.connect(self.sketch.redo)
        self.clear_action = QAction("Clear", self, toolTip="Remove every stroke (undoable)")
        self.clear_action.triggered.connect(self.sketch.clear)
        self.fit_action = QAction("Fit", self, toolTip="Zoom to the whole sketch")
        self.fit_action.triggered.connect(lambda: self.view_box.autoRange(padding=0.02))
        for action in (self.undo_action, self.redo_action, self.clear_action, self.fit_action):
            self.toolbar.addAction(action)
        self.graph_check = QCheckBox("Feature graph")
        self.graph_check.setToolTip("Overlay the ridge and valley graph the synthesis follows, "
                                    "with branch points and endpoints")
        self.graph_check.toggled.connect(self._graph_toggled)
        self.options_bar.addWidget(self.graph_check)

    def _build_region_bars(self) -> list[QToolBar]:
        """Two rows: the region brushes, then selection, pins and stamps."""
        regions = QToolBar("Region tools")
        marks = QToolBar("Selection, pins and stamps")
        self.style_combo = QComboBox(minimumContentsLength=10)
        self.style_combo.setSizeAdjustPolicy(QComboBox.AdjustToMinimumContentsLengthWithIcon)
        self.style_combo.setToolTip("The style the Style brush paints (add styles in the Regions panel)")
        self.clear_selection_action = QAction("Clear selection", self, toolTip="Select nothing")
        self.clear_selection_action.triggered.connect(self.document.clear_selection)
        for bar, tool, text, tip in (
            (regions, "style", "Style", "Paint the chosen terrain style"),
            (regions, "style_erase", "Unstyle", "Erase style regions: back to the plain examples"),
            (regions, "water", "Water", "Paint sea, lakes and rivers (level in the Regions panel)"),
            (regions, "water_erase", "Dry", "Erase water"),
            (marks, "select", "Select", "Drag a rectangle to select cells for re-synthesis (Shift adds)"),
            (marks, "select_brush", "Select brush", "Paint cells into the selection (Ctrl removes them)"),
            (marks, "pin", "Pin", "Click to pin the terrain's height at a cell"),
            (marks, "stamp", "Stamp", "Click to place the stamp DEM chosen in the Pins and stamps panel"),
        ):
            action = QAction(text, self, checkable=True, toolTip=tip)
            self.tool_group.addAction(action)
            self.tool_actions[tool] = action
            bar.addAction(action)
            if tool == "style":
                bar.addWidget(self.style_combo)
            elif tool == "select_brush":
                bar.addAction(self.clear_selection_action)
                bar.addSeparator()
        for bar in (regions, marks):
            bar.setToolButtonStyle(Qt.ToolButtonTextOnly)
        self._known_styles: set[int] = set()
        self._update_style_combo()
        return [regions, marks]

    # -- tool state ----------------------------------------------------------------------
    @property
    def tool(self) -> str:
        for tool, action in self.tool_actions.items():
            if action.isChecked():
                return tool
        return "ridge"

    def set_tool(self, tool: str) -> None:
        self.tool_actions[tool].setChecked(True)

    @property
    def current_style(self) -> int | None:
        """Id of the style the Style brush paints, None when there is none."""
        if self.document is None or self.style_combo.currentIndex() < 0:
            return None
        return self.style_combo.currentData()

    def set_current_style(self, style_id: int) -> None:
        self.style_combo.setCurrentIndex(self.style_combo.findData(style_id))

    def _update_style_combo(self) -> None:
        styles = self.document.styles
        current = self.current_style
        new = [s.id for s in styles if s.id not in self._known_styles]
        self._known_styles = {s.id for s in styles}
        self.style_combo.blockSignals(True)
        self.style_combo.clear()
        for spec in styles:
            self.style_combo.addItem(swatch(spec.color, 14), spec.name, spec.id)
        # A style just added is the one the user wants to paint next.
        chosen = new[-1] if new else current
        index = self.style_combo.findData(chosen) if chosen is not None else -1
        self.style_combo.setCurrentIndex(index if index >= 0 else (0 if styles else -1))
        self.style_combo.blockSignals(False)

    def _document_changed(self, what: str) -> None:
        if what == "styles":
            self._update_style_combo()

    @property
    def brush_radius(self) -> float:
        return self.size_spin.value() / 2.0

    @property
    def polyline_points(self) -> list[tuple[float, float]]:
        return list(self._poly_points)

    # -- mouse and keys -----------------------------------------------------------------
    def cell_at(self, widget_pos: QPointF) -> tuple[float, float]:
        """``(row, col)`` in sketch cells under a viewport position."""
        scene = self.view.mapToScene(widget_pos.toPoint())
        point = self.view_box.mapSceneToView(scene)
        # Pixel (i, j) covers [j, j+1] x [i, i+1]; its centre is cell (i, j).
        return point.y() - 0.5, point.x() - 0.5

    def _hover(self, cell: tuple[float, float]) -> None:
        row, col = (int(np.floor(v + 0.5)) for v in cell)
        rows, cols = self.sketch.shape
        self.hovered.emit(*((row, col) if 0 <= row < rows and 0 <= col < cols else (-1, -1)))

    def eventFilter(self, obj: QObject, event: QEvent) -> bool:
        kind = event.type()
        if obj is self.view.viewport():
            if kind == QEvent.MouseButtonPress and event.button() == Qt.LeftButton:
                self._press(self.cell_at(event.position()), event.modifiers())
                return True
            if kind == QEvent.MouseButtonDblClick and event.button() == Qt.LeftButton:
                if self.polyline_action.isChecked():
                    self._add_poly_point(self.cell_at(event.position()))
                    self.finish_polyline()
                return True
            if kind == QEvent.MouseMove:
                cell = self.cell_at(event.position())
                self._hover(cell)
                self._move(cell, event.modifiers())
                return self._stroking or self._drag is not None
            if kind == QEvent.MouseButtonRelease and event.button() == Qt.LeftButton:
                self._release(self.cell_at(event.position()), event.modifiers())
                return True
            if kind == QEvent.Leave:
                self._cursor.setVisible(False)
                self.hovered.emit(-1, -1)
        elif obj is self.view and kind == QEvent.KeyPress:
            if event.key() in (Qt.Key_Return, Qt.Key_Enter) and self._poly_points:
                self.finish_polyline()
                return True
            if event.key() == Qt.Key_Escape and self._poly_points:
                self.cancel_polyline()
                return True
        return super().eventFilter(obj, event)

    def _brush_options(self) -> dict | None:
        """Keyword arguments of the current sketch brush; None (and a notice)
        when the Style brush has no style to paint."""
        options = dict(radius=self.brush_radius, hardness=self.hardness_spin.value())
        if self.tool == "style":
            if self.current_style is None:
                self.notice.emit("Add a style in the Regions panel before painting styles")
                return None
            options["style"] = self.current_style
        return options

    def _press(self, cell: tuple[float, float], modifiers) -> None:
        self.view.setFocus()
        tool = self.tool
        if tool in DOCUMENT_TOOLS:
            self._press_document_tool(tool, cell, modifiers)
            return
        options = self._brush_options()
        if options is None:
            return
        if self.polyline_action.isChecked():
            self._add_poly_point(cell)
            return
        if modifiers & Qt.ShiftModifier and self._last_point is not None:
            self.sketch.draw_polyline([self._last_point, cell], tool, **options)
            self._last_point = cell
            return
        self.sketch.begin_stroke(tool, *cell, **options)
        self._stroking = True

    def _press_document_tool(self, tool: str, cell: tuple[float, float], modifiers) -> None:
        rows, cols = self.sketch.shape
        row, col = int(round(cell[0])), int(round(cell[1]))
        inside = 0 <= row < rows and 0 <= col < cols
        if tool == "pin":
            if inside:
                self.pin_requested.emit(row, col)
        elif tool == "stamp":
            if inside:
                self.stamp_requested.emit(float(row), float(col))
        elif tool == "select":
            self._drag = tool
            self._rect_start = cell
            self._show_rubber_band(cell)
        else:
            self._drag = tool
            self._last_point = cell
            self.document.paint_selection(cell, cell, radius=self.brush_radius,
                                          add=not modifiers & Qt.ControlModifier)

    def _move(self, cell: tuple[float, float], modifiers=Qt.NoModifier) -> None:
        r = self.brush_radius
        self._cursor.setRect(cell[1] + 0.5 - r, cell[0] + 0.5 - r, 2 * r, 2 * r)
        self._cursor.setVisible(self.tool not in ("select", "pin", "stamp"))
        if self._stroking:
            self.sketch.stroke_to(*cell)
        elif self._drag == "select":
            self._show_rubber_band(cell)
        elif self._drag == "select_brush":
            self.document.paint_selection(self._last_point, cell, radius=r, add=not modifiers & Qt.ControlModifier)
            self._last_point = cell
        elif self._poly_points:
            self._show_poly_preview(cell)

    def _release(self, cell: tuple[float, float], modifiers=Qt.NoModifier) -> None:
        drag, self._drag = self._drag, None
        if drag == "select":
            self._rubber_band.setVisible(False)
            (r0, r1), (c0, c1) = _cell_span(self._rect_start[0], cell[0]), _cell_span(self._rect_start[1], cell[1])
            self.document.select_rect(r0, r1, c0, c1, add=bool(modifiers & Qt.ShiftModifier))
            return
        if drag == "select_brush":
            self._last_point = None
            return
        if not self._stroking:
            return
        self.sketch.stroke_to(*cell)
        self.sketch.end_stroke()
        self._stroking = False
        self._last_point = cell

    def _show_rubber_band(self, cell: tuple[float, float]) -> None:
        (r0, r1), (c0, c1) = _cell_span(self._rect_start[0], cell[0]), _cell_span(self._rect_start[1], cell[1])
        self._rubber_band.setRect(c0, r0, c1 - c0, r1 - r0)
        self._rubber_band.setVisible(True)

    # -- polyline -----------------------------------------------------------------------
    def _add_poly_point(self, cell: tuple[float, float]) -> None:
        if not self._poly_points or np.hypot(*np.subtract(cell, self._poly_points[-1])) > 0.5:
            self._poly_points.append(cell)
        self._show_poly_preview(None)

    def _show_poly_preview(self, hover: tuple[float, float] | None) -> None:
        pts = self._poly_points + ([hover] if hover is not None else [])
        if not pts:
            self._poly_preview.setData([], [])
            return
        arr = np.asarray(pts, dtype=float)
        self._poly_preview.setData(arr[:, 1] + 0.5, arr[:, 0] + 0.5)

    def finish_polyline(self) -> None:
        """Draw the polyline clicked so far as one stroke."""
        points, self._poly_points = self._poly_points, []
        self._poly_preview.setData([], [])
        options = self._brush_options() if points and self.tool in TOOLS else None
        if options is not None:
            self.sketch.draw_polyline(points, self.tool, **options)
            self._last_point = points[-1]

    def cancel_polyline(self) -> None:
        self._poly_points = []
        self._poly_preview.setData([], [])

    # -- model events ---------------------------------------------------------------------
    def _sketch_changed(self, bbox) -> None:
        if bbox is None:
            reshaped = self._rgb.shape[:2] != self.sketch.shape
            self._rgb = self.sketch.to_rgb()
            self._refresh_image()
            if reshaped:
                self.view_box.autoRange(padding=0.02)
        else:
            r0, r1, c0, c1 = bbox
            self._rgb[r0:r1, c0:c1] = self.sketch.to_rgb(bbox)
            if not self._refresh_timer.isActive():
                self._refresh_timer.start()

    def _refresh_image(self) -> None:
        self.image.setImage(self._rgb, autoLevels=False, levels=None)

    def _update_history_actions(self) -> None:
        self.undo_action.setEnabled(self.sketch.can_undo)
        self.redo_action.setEnabled(self.sketch.can_redo)

    # -- feature graph overlay --------------------------------------------------------------
    def _graph_toggled(self, on: bool) -> None:
        self.overlay.set_visible(on)
        self.legend.setVisible(on)
        self.graphs.set_wanted(on)

    def _graph_ready(self, maps) -> None:
        self.overlay.set_maps(maps)
        self.feature_graph_updated.emit(maps)

    def _graph_failed(self, message: str) -> None:
        self.legend.setText(f"Feature graph unavailable: {message}")


def _cell_span(a: float, b: float) -> tuple[int, int]:
    """Half-open range of the cells from coordinate ``a`` to ``b`` (both
    included; cell ``i`` covers ``[i - 0.5, i + 0.5)``)."""
    lo, hi = min(a, b), max(a, b)
    return int(np.floor(lo + 0.5)), int(np.floor(hi + 0.5)) + 1
