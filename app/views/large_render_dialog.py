"""*File > Render large...*: the current project rendered at a world size
as tiles on Dask, in the background, with a progress bar and cancel."""

from __future__ import annotations

import os
from pathlib import Path

from PySide6.QtWidgets import (QDialog, QDialogButtonBox, QFileDialog, QFormLayout, QHBoxLayout, QLabel, QLineEdit,
                               QProgressBar, QPushButton, QSpinBox, QVBoxLayout, QWidget)

from ..controllers import LargeRenderController

#: Largest side the dialog offers, cells.
MAX_SIDE = 65_536


class LargeRenderDialog(QDialog):
    """Size, tile, workers and output file of a tiled render, and its progress.

    Parameters
    ----------
    controller : LargeRenderController
    default_out : str
        The output file first proposed.
    """

    def __init__(self, controller: LargeRenderController, default_out: str, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Render large")
        self.controller = controller
        self.rows = self._spin(4096, 96, MAX_SIDE, "Output rows (cells)")
        self.cols = self._spin(4096, 96, MAX_SIDE, "Output columns (cells)")
        self.tile = self._spin(1024, 96, MAX_SIDE, "Tile side (cells): at least three patches")
        self.workers = self._spin(os.cpu_count() or 1, 1, 256, "Local Dask worker processes (one core each)")
        self.out = QLineEdit(default_out)
        browse = QPushButton("Browse…")
        browse.clicked.connect(self._browse)
        where = QHBoxLayout()
        where.addWidget(self.out)
        where.addWidget(browse)
        form = QFormLayout()
        form.addRow("Rows", self.rows)
        form.addRow("Columns", self.cols)
        form.addRow("Tile", self.tile)
        form.addRow("Workers", self.workers)
        form.addRow("GeoTIFF", where)
        self.progress = QProgressBar()
        self.progress.setRange(0, 1)
        self.progress.setValue(0)
        self.status = QLabel("Renders the project (sketch, examples, styles, water, stamps and pins) tiled on Dask "
                             "to a GeoTIFF; valleys drain once the tiles are done. A cancelled render keeps its tiles "
                             "for the next.", wordWrap=True)
        self.buttons = QDialogButtonBox(QDialogButtonBox.Close)
        self.render_button = self.buttons.addButton("Render", QDialogButtonBox.AcceptRole)
        self.cancel_button = self.buttons.addButton("Cancel render", QDialogButtonBox.ActionRole)
        self.cancel_button.setEnabled(False)
        self.render_button.clicked.connect(self.start)
        self.cancel_button.clicked.connect(controller.cancel)
        self.buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addLayout(form)
        layout.addWidget(self.progress)
        layout.addWidget(self.status)
        layout.addWidget(self.buttons)
        for signal, slot in ((controller.started, self._started), (controller.tile_finished, self._tile_finished),
                             (controller.finished, self._finished), (controller.failed, self._failed),
                             (controller.cancelled, self._cancelled), (controller.running_changed, self._running)):
            signal.connect(slot)

    def _spin(self, value: int, lo: int, hi: int, tip: str) -> QSpinBox:
        spin = QSpinBox(minimum=lo, maximum=hi, value=value, toolTip=tip)
        spin.setSingleStep(256 if hi == MAX_SIDE else 1)
        return spin

    def _browse(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Render large to", self.out.text(), "GeoTIFF (*.tif *.tiff)")
        if path:
            self.out.setText(path)

    def start(self) -> None:
        """Start the render with the values shown."""
        self.controller.render((self.rows.value(), self.cols.value()), self.tile.value(), self.workers.value(),
                               Path(self.out.text()))

    # -- the controller's signals -----------------------------------------------------------
    def _started(self) -> None:
        self.progress.setRange(0, 0)  # busy until the first tile (the landform pass runs first)
        self.status.setText("Shaping the landforms over the whole map…")

    def _tile_finished(self, done: int, total: int) -> None:
        self.progress.setRange(0, total)
        self.progress.setValue(done)
        self.status.setText(f"{done} of {total} tiles")

    def _finished(self, result) -> None:
        self.progress.setRange(0, 1)
        self.progress.setValue(1)
        self.status.setText(f"Wrote {result.path}: {result.shape[0]}x{result.shape[1]} in {result.seconds:.0f} s")

    def _failed(self, message: str) -> None:
        self.progress.setRange(0, 1)
        self.progress.setValue(0)
        self.status.setText(f"Not rendered: {message}")

    def _cancelled(self) -> None:
        self.progress.setRange(0, 1)
        self.status.setText("Cancelled; the finished tiles are kept, and the same render continues from them")

    def _running(self, running: bool) -> None:
        self.render_button.setEnabled(not running)
        self.cancel_button.setEnabled(running)
        for widget in (self.rows, self.cols, self.tile, self.workers, self.out):
            widget.setEnabled(not running)

    def reject(self) -> None:
        """Closing the dialog cancels a running render."""
        if self.controller.running:
            self.controller.cancel()
        super().reject()
