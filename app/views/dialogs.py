"""Small dialogs of the main window."""

from __future__ import annotations

from PySide6.QtWidgets import QDialog, QDialogButtonBox, QFormLayout, QSpinBox, QWidget

from ..model.sketch_layers import MAX_SIDE


class NewSketchDialog(QDialog):
    """Asks the size of a new, empty sketch (= the output terrain's size)."""

    def __init__(self, shape: tuple[int, int], parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("New sketch")
        self.rows = QSpinBox(minimum=16, maximum=MAX_SIDE, value=shape[0], suffix=" cells")
        self.cols = QSpinBox(minimum=16, maximum=MAX_SIDE, value=shape[1], suffix=" cells")
        form = QFormLayout(self)
        form.addRow("Rows (north-south)", self.rows)
        form.addRow("Columns (east-west)", self.cols)
        buttons = QDialogButtonBox(QDialogButtonBox.Ok | QDialogButtonBox.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)

    @property
    def shape(self) -> tuple[int, int]:
        return self.rows.value(), self.cols.value()
