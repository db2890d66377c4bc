"""The Pin and Stamp tools' clicks: ask a pin's height, place the chosen stamp."""

from __future__ import annotations

from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import QInputDialog, QWidget

from terrasynth_core.errors import TerraSynthError

from ..model import Document, StampSpec, fitting_scale
from .pin_stamp_panel import PinStampPanel
from .style_panel import HEIGHT_LIMITS


class PinStampRequests(QObject):
    """Turns clicks on the sketch into pins and stamps of the document.

    Parameters
    ----------
    window : QWidget
        Parent of the height dialog.
    document : Document
    panel : PinStampPanel
        Holds the stamp DEM the Stamp tool places.

    Signals
    -------
    stamp_placed()
    status(str, int)
        A message for the status bar and how many ms to show it.
    error(str, str)
        A title and a message for an error dialog.
    """

    stamp_placed = Signal()
    status = Signal(str, int)
    error = Signal(str, str)

    def __init__(self, window: QWidget, document: Document, panel: PinStampPanel) -> None:
        super().__init__(window)
        self.window = window
        self.document = document
        self.panel = panel

    def add_pin_at(self, row: int, col: int) -> None:
        """Ask the height for a pin at ``(row, col)`` (the terrain's height
        there by default) and add it."""
        doc = self.document
        result = doc.result
        if result is not None and result.shape == doc.output_shape:
            default = float(result.heights[row, col])
        elif doc.height_range is not None:
            default = sum(doc.height_range) / 2
        else:
            default = 0.0
        height, ok = QInputDialog.getDouble(self.window, "Elevation pin", f"Height of cell ({row}, {col}) in metres:",
                                            round(default, 1), *HEIGHT_LIMITS, 1)
        if not ok:
            return
        try:
            doc.add_pin(row, col, height)
        except TerraSynthError as exc:
            self.error.emit("Cannot add the pin", str(exc))

    def place_stamp(self, row: float, col: float) -> None:
        """Place the stamp DEM chosen in the panel centred on ``(row, col)``."""
        source = self.panel.stamp_source
        if source is None:
            self.status.emit("Choose the DEM to stamp in the Pins and stamps panel first "
                             "(or wait until it is read)", 10_000)
            return
        ref, shape = source
        try:
            self.document.add_stamp(StampSpec(ref, (row, col), shape,
                                              scale=fitting_scale(shape, self.document.output_shape)))
        except TerraSynthError as exc:
            self.error.emit("Cannot place the stamp", str(exc))
            return
        self.stamp_placed.emit()
