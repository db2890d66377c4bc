"""Variations side by side: one hillshaded thumbnail per seed, filled in as
each variation finishes; "Use this one" makes it the current terrain."""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QDialog, QDialogButtonBox, QGridLayout, QLabel, QPushButton, QVBoxLayout, QWidget

from terrasynth_core.pictures import thumbnail

from ..controllers import VariationsController
from ..model.result import TerrainResult
from .example_panel import rgba_pixmap

#: Thumbnail side, pixels.
THUMB_SIDE = 200
#: Thumbnails per row.
COLUMNS = 4


class VariationsDialog(QDialog):
    """Shows the variations of one batch as they arrive.

    Parameters
    ----------
    seeds : sequence of int
        The batch's seeds, in order.

    Signals
    -------
    chosen(int, object)
        "Use this one" was pressed: the seed and its :class:`TerrainResult`.
    cancel_requested()
        The dialog was closed (or a variation used) while the batch runs.
    """

    chosen = Signal(int, object)
    cancel_requested = Signal()

    def __init__(self, seeds, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Variations")
        self.seeds = [int(s) for s in seeds]
        self.results: dict[int, TerrainResult] = {}
        self.thumbnails: list[QLabel] = []
        self.use_buttons: list[QPushButton] = []
        grid = QGridLayout()
        for i, seed in enumerate(self.seeds):
            picture = QLabel("making…", alignment=Qt.AlignCenter)
            picture.setFixedSize(THUMB_SIDE, THUMB_SIDE)
            picture.setStyleSheet("background: #303030; color: #dddddd")
            caption = QLabel(f"seed {seed}", alignment=Qt.AlignCenter)
            button = QPushButton("Use this one", enabled=False)
            button.setToolTip(f"Make this variation the current terrain (and {seed} the seed)")
            button.clicked.connect(lambda _=False, i=i: self.use(i))
            cell = QVBoxLayout()
            cell.addWidget(picture)
            cell.addWidget(caption)
            cell.addWidget(button)
            grid.addLayout(cell, i // COLUMNS, i % COLUMNS)
            self.thumbnails.append(picture)
            self.use_buttons.append(button)
        self.status = QLabel(f"Making {len(self.seeds)} variations…", wordWrap=True)
        self.buttons = QDialogButtonBox(QDialogButtonBox.Cancel)
        self.buttons.rejected.connect(self.reject)
        layout = QVBoxLayout(self)
        layout.addLayout(grid)
        layout.addWidget(self.status)
        layout.addWidget(self.buttons)
        self._running = True

    def follow(self, variations: VariationsController) -> None:
        """Show the batch ``variations`` is making; "Use this one" and
        closing act on it."""
        for signal, slot in ((self.chosen, variations.use), (self.cancel_requested, variations.cancel),
                             (variations.variation_made, self.show_result), (variations.finished, self._batch_finished),
                             (variations.failed, self._batch_failed), (variations.cancelled, self._batch_cancelled)):
            signal.connect(slot)

    def _batch_finished(self, terrains) -> None:
        self.finish(f"{len(terrains)} variations made: pick one")

    def _batch_failed(self, message: str) -> None:
        self.finish(f"Failed: {message}")

    def _batch_cancelled(self) -> None:
        self.finish("Cancelled")

    def show_result(self, index: int, result: TerrainResult) -> None:
        """Variation ``index`` arrived: show its thumbnail and let it be used."""
        self.results[index] = result
        self.thumbnails[index].setPixmap(rgba_pixmap(thumbnail(result.heights, cell_size=result.cell_size,
                                                               side=THUMB_SIDE)))
        self.use_buttons[index].setEnabled(True)
        self.status.setText(f"{len(self.results)} of {len(self.seeds)} variations made")

    def finish(self, message: str) -> None:
        """The batch is over (done, failed or cancelled): say so; Close closes."""
        self._running = False
        self.status.setText(message)
        self.buttons.setStandardButtons(QDialogButtonBox.Close)
        for i, label in enumerate(self.thumbnails):
            if i not in self.results:
                label.setText("not made")

    def use(self, index: int) -> None:
        """Make variation ``index`` the current terrain and close (the
        variations not made yet are dropped)."""
        if self._running:
            self.cancel_requested.emit()
        self.chosen.emit(self.seeds[index], self.results[index])
        self.accept()

    def reject(self) -> None:
        # Cancel, Escape and the window's close button all end here.
        if self._running:
            self.cancel_requested.emit()
        super().reject()
