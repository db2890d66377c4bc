"""*File > Render large...*: the current project rendered at a world size
as tiles on Dask, in the background, with a progress bar and cancel."""

from __future__ import annotations

import os
from pathlib import Path

from PySide6.QtWidgets import (QComboBox, QDialog, QDialogButtonBox, QFileDialog, QFormLayout, QHBoxLayout, QLabel,
                               QLineEdit, QProgressBar, QPushButton, QSpinBox, QVBoxLayout, QWidget)

from terrasynth_core.export import PRESETS
from terrasynth_core.export.engines import MAX_TILES

from ..controllers import LargeRenderController

#: Largest side the dialog offers, cells.
MAX_SIDE = 65_536


class LargeRenderDialog(QDialog):
    """Size, tile, workers and output file of a tiled render (and an
    engine's files beside it), and its progress.

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
        # Also for an engine: its files beside the GeoTIFF, read from it
        # window by window (as 'synth --tile --engine' writes them).
        self.engine = QComboBox(toolTip="Also write the terrain for an engine or tool, into a folder beside the "
                                        "GeoTIFF (OUTNAME_PRESET), once the GeoTIFF is written")
        self.engine.addItem("GeoTIFF only", None)
        for preset in PRESETS.values():
            self.engine.addItem(preset.title, preset.name)
        self.engine_tiles = QSpinBox(minimum=1, maximum=MAX_TILES, value=1, enabled=False,
                                     toolTip="K x K engine tiles named _x{i}_y{j} (Unreal, Unity)")
        self.engine.currentIndexChanged.connect(self._engine_chosen)
        engine_row = QHBoxLayout()
        engine_row.addWidget(self.engine)
        engine_row.addWidget(QLabel("tiles a side"))
        engine_row.addWidget(self.engine_tiles)
        form = QFormLayout()
        form.addRow("Rows", self.rows)
        form.addRow("Columns", self.cols)
        form.addRow("Tile", self.tile)
        form.addRow("Workers", self.workers)
        form.addRow("GeoTIFF", where)
        form.addRow("Also for", engine_row)
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
        self._engine_phase = False
        for signal, slot in ((controller.started, self._started), (controller.tile_finished, self._tile_finished),
                             (controller.engine_started, self._engine_started),
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

    def _engine_chosen(self) -> None:
        name = self.engine.currentData()
        self.engine_tiles.setEnabled(name is not None and PRESETS[name].tiles)
        if not self.engine_tiles.isEnabled():
            self.engine_tiles.setValue(1)

    def start(self) -> None:
        """Start the render with the values shown."""
        self.controller.render((self.rows.value(), self.cols.value()), self.tile.value(), self.workers.value(),
                               Path(self.out.text()), engine=self.engine.currentData(),
                               engine_tiles=self.engine_tiles.value())

    # -- the controller's signals -----------------------------------------------------------
    def _started(self) -> None:
        self._engine_phase = False
        self.progress.setRange(0, 0)  # busy until the first tile (the landform pass runs first)
        self.status.setText("Shaping the landforms over the whole map…")

    def _engine_started(self, preset: str) -> None:
        self._engine_phase = True
        self.progress.setRange(0, 0)
        self.status.setText(f"GeoTIFF written; writing the {PRESETS[preset].title} files…")

    def _tile_finished(self, done: int, total: int) -> None:
        self.progress.setRange(0, total)
        self.progress.setValue(done)
        self.status.setText(f"{done} of {total} tiles")

    def _finished(self, rendered) -> None:
        self.progress.setRange(0, 1)
        self.progress.setValue(1)
        result = rendered.result
        text = f"Wrote {result.path}: {result.shape[0]}x{result.shape[1]} in {result.seconds:.0f} s"
        if rendered.engine is not None:
            text += f"; for {PRESETS[rendered.engine.preset].title}: {rendered.engine.summary()}"
        self.status.setText(text)

    def _failed(self, message: str) -> None:
        self.progress.setRange(0, 1)
        self.progress.setValue(0)
        self.status.setText(f"Stopped: {message}")

    def _cancelled(self) -> None:
        self.progress.setRange(0, 1)
        if self._engine_phase:
            self.status.setText("Cancelled: the GeoTIFF is written; the engine's files were not kept")
        else:
            self.status.setText("Cancelled; the finished tiles are kept, and the same render continues from them")

    def _running(self, running: bool) -> None:
        self.render_button.setEnabled(not running)
        self.cancel_button.setEnabled(running)
        for widget in (self.rows, self.cols, self.tile, self.workers, self.out, self.engine):
            widget.setEnabled(not running)
        if not running:
            self._engine_chosen()
        else:
            self.engine_tiles.setEnabled(False)

    def reject(self) -> None:
        """Closing the dialog cancels a running render."""
        if self.controller.running:
            self.controller.cancel()
        super().reject()
