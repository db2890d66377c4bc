"""Drawing the artist controls over the sketch: style regions and water,
the re-synthesis selection, elevation pins and stamp outlines."""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QTimer, Qt

from ..model.document import Document

#: How selected cells are tinted: RGBA.
SELECTION_RGBA = (255, 215, 0, 80)
#: Coalescing delay of region and selection refreshes while painting, in ms.
REFRESH_MS = 16
_PIN_STYLE = dict(symbol="t", size=13, brush=pg.mkBrush(250, 250, 250), pen=pg.mkPen((20, 20, 20), width=1.5))
_STAMP_PEN = pg.mkPen((230, 90, 0), width=2, style=Qt.DashLine)


class ControlsOverlay:
    """Items over a sketch image showing a document's controls; follows its events.

    Parameters
    ----------
    view_box : pg.ViewBox
        Box whose sketch image has cell ``(row, col)`` covering
        ``[col, col+1] x [row, row+1]``.
    document : Document
    """

    def __init__(self, view_box: pg.ViewBox, document: Document) -> None:
        self.document = document
        self.regions = pg.ImageItem()
        self.selection = pg.ImageItem()
        self.stamps = pg.PlotCurveItem(pen=_STAMP_PEN, connect="finite")
        self.pins = pg.ScatterPlotItem(pxMode=True)
        self._view_box = view_box
        self._pin_labels: list[pg.TextItem] = []
        for z, item in ((5, self.regions), (6, self.selection), (21, self.stamps), (22, self.pins)):
            item.setZValue(z)
            view_box.addItem(item)
        self._rgba: np.ndarray | None = None
        self._colors: dict[int, tuple[int, int, int]] = {}
        # Owned by the view box, so a redraw still pending when the window
        # closes dies with the images it would draw into.
        self._refresh_timer = QTimer(view_box, singleShot=True, interval=REFRESH_MS)
        self._refresh_timer.timeout.connect(self._refresh_regions)
        # A selection brush changes the selection on every mouse move.
        self._selection_timer = QTimer(view_box, singleShot=True, interval=REFRESH_MS)
        self._selection_timer.timeout.connect(self._draw_selection)
        self.redraw()
        document.changed.connect(self._document_changed)
        document.sketch.changed.connect(self._sketch_changed)

    def redraw(self) -> None:
        """Draw everything again from the document."""
        self._colors = {s.id: s.rgb for s in self.document.styles}
        self._rgba = self.document.sketch.regions_rgba(self._colors)
        self._refresh_regions()
        self._draw_selection()
        self._draw_pins()
        self._draw_stamps()

    def pin_positions(self) -> list[tuple[float, float]]:
        """Scene ``(x, y)`` of each pin marker, in document order."""
        return [tuple(spot.pos()) for spot in self.pins.points()]

    def stamp_outline(self) -> tuple[np.ndarray, np.ndarray]:
        """The x and y the stamp outlines are drawn through (NaN between stamps)."""
        x, y = self.stamps.getData()
        return (np.array([]), np.array([])) if x is None else (x, y)

    # -- events ---------------------------------------------------------------------------
    def _document_changed(self, what: str) -> None:
        if what == "styles":
            self._colors = {s.id: s.rgb for s in self.document.styles}
            self._rgba = self.document.sketch.regions_rgba(self._colors)
            self._refresh_regions()
        elif what == "selection" and not self._selection_timer.isActive():
            self._selection_timer.start()
        elif what == "pins":
            self._draw_pins()
        elif what in ("stamps", "params", "examples", "styles"):  # (the cell size may change)
            self._draw_stamps()

    def _sketch_changed(self, bbox) -> None:
        sketch = self.document.sketch
        if bbox is None or self._rgba is None or self._rgba.shape[:2] != sketch.shape:
            self._rgba = sketch.regions_rgba(self._colors)
            self._refresh_regions()
            return
        r0, r1, c0, c1 = bbox
        self._rgba[r0:r1, c0:c1] = sketch.regions_rgba(self._colors, bbox)
        if not self._refresh_timer.isActive():
            self._refresh_timer.start()

    # -- drawing ----------------------------------------------------------------------------
    def _refresh_regions(self) -> None:
        self.regions.setImage(self._rgba, autoLevels=False, levels=None)

    def _draw_selection(self) -> None:
        mask = self.document.selection
        if mask is None:
            self.selection.clear()
            return
        rgba = np.zeros(mask.shape + (4,), np.uint8)
        rgba[mask] = SELECTION_RGBA
        self.selection.setImage(rgba, autoLevels=False, levels=None)

    def _draw_pins(self) -> None:
        for label in self._pin_labels:
            self._view_box.removeItem(label)
        self._pin_labels = []
        pins = self.document.pins
        self.pins.setData([dict(pos=(p.col + 0.5, p.row + 0.5), **_PIN_STYLE) for p in pins])
        for number, pin in enumerate(pins, start=1):
            label = pg.TextItem(str(number), color=(20, 20, 20), anchor=(-0.3, 1.1))
            label.setPos(pin.col + 0.5, pin.row + 0.5)
            label.setZValue(23)
            self._view_box.addItem(label)
            self._pin_labels.append(label)

    def _draw_stamps(self) -> None:
        xs, ys = [], []
        cell = self.document.cell_size()
        for stamp in self.document.stamps:
            corners = stamp.footprint(cell)
            xs += [corners[:, 1] + 0.5, [np.nan]]
            ys += [corners[:, 0] + 0.5, [np.nan]]
        if not xs:
            self.stamps.setData([], [])
            return
        self.stamps.setData(np.concatenate(xs), np.concatenate(ys))
