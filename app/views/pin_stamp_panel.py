"""The Pins and stamps panel: elevation pins with how well the last run met
them, and stamps (DEMs placed as they are) with their rotation and scale.

Pins and stamps are placed by clicking the sketch with the Pin and Stamp
tools; here they are listed, edited and removed.  The stamp DEM for the
next click is chosen here and read on the thread pool (its size sets the
stamp's footprint).
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (QAbstractItemView, QComboBox, QDoubleSpinBox, QFormLayout, QGroupBox,
                               QHeaderView, QLabel, QPushButton, QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget)

from terrasynth_core.controls.options import STAMP_SCALE_RANGE
from terrasynth_core.errors import TerraSynthError

from ..model.document import Document
from ..model.example_library import ExampleRef, builtin_refs
from ..workers import run_in_background
from .panel_widgets import apply_edit, ask_dem_file, error_label

#: The built-in stamp offered first: the paper's Mount Doom.
DEFAULT_STAMP = "st-helens"
_PIN_COLUMNS = ("#", "Cell", "Height (m)", "Error (m)", "Error (%)")
_STAMP_COLUMNS = ("#", "Centre", "Rotation", "Scale", "DEM")


def pin_error_rows(document: Document) -> list[tuple[float, float] | None]:
    """Per pin of ``document``: (error in metres, error in % of the terrain's
    height range) from the last run, or None when that run had no such pin
    (added or changed since)."""
    result = document.result
    errors = {} if result is None else {(e.row, e.col, e.target): e.error for e in result.pin_errors}
    relief = result.relief if result is not None else 0.0
    rows = []
    for pin in document.pins:
        error = errors.get((pin.row, pin.col, pin.height))
        rows.append(None if error is None else (error, 100.0 * error / relief if relief > 0 else 0.0))
    return rows


def _shape_of(ref: ExampleRef) -> tuple[ExampleRef, tuple[int, int]]:
    return ref, ref.load().shape


class PinStampPanel(QWidget):
    """Lists and edits the document's pins and stamps.

    Signals
    -------
    stamp_source_ready(object)
        The chosen stamp DEM (an ExampleRef) was read; stamps can be placed.
    stamp_source_failed(str)
        The chosen stamp DEM cannot be read.
    """

    stamp_source_ready = Signal(object)
    stamp_source_failed = Signal(str)

    def __init__(self, document: Document, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.document = document
        self._syncing = False
        self._source_shapes: dict[ExampleRef, tuple[int, int]] = {}
        self._stamp_count = len(document.stamps)

        self.pin_table = _table(_PIN_COLUMNS)
        self.pin_table.itemChanged.connect(self._pin_item_changed)
        self.pin_table.itemSelectionChanged.connect(self._update_buttons)
        self.remove_pin_button = QPushButton("Remove pin")
        self.remove_pin_button.clicked.connect(self.remove_current_pin)
        self.pin_summary = QLabel(wordWrap=True)
        pins_box = QGroupBox("Elevation pins")
        pins_layout = QVBoxLayout(pins_box)
        pins_layout.addWidget(QLabel("Click the sketch with the Pin tool to add one; double-click a height "
                                     "to change it.", wordWrap=True))
        pins_layout.addWidget(self.pin_table, 1)
        pins_layout.addWidget(self.pin_summary)
        pins_layout.addWidget(self.remove_pin_button)

        self.source = QComboBox()
        self.source.setToolTip("The DEM the Stamp tool places")
        for ref in builtin_refs():
            self.source.addItem(ref.label, ref)
        self.source.addItem("DEM file…", None)
        self.source.activated.connect(self._source_activated)
        self.source_label = QLabel()
        self.stamp_table = _table(_STAMP_COLUMNS)
        self.stamp_table.itemSelectionChanged.connect(self._stamp_selected)
        self.rotation = QDoubleSpinBox(minimum=-360.0, maximum=360.0, singleStep=5.0, decimals=1, suffix=" °")
        self.rotation.setToolTip("Degrees, counter-clockwise on screen")
        self.rotation.valueChanged.connect(lambda v: self._edit_stamp(rotation=v))
        self.scale = QDoubleSpinBox(minimum=STAMP_SCALE_RANGE[0], maximum=STAMP_SCALE_RANGE[1], singleStep=0.05,
                                    decimals=2, prefix="x ")
        self.scale.setToolTip("Footprint scale of the DEM on the output grid; its heights are not scaled")
        self.scale.valueChanged.connect(lambda v: self._edit_stamp(scale=v))
        self.remove_stamp_button = QPushButton("Remove stamp")
        self.remove_stamp_button.clicked.connect(self.remove_current_stamp)
        source_form = QFormLayout()
        source_form.addRow("DEM to place", self.source)
        source_form.addRow("", self.source_label)
        edit_form = QFormLayout()
        edit_form.addRow("Rotation", self.rotation)
        edit_form.addRow("Scale", self.scale)
        stamps_box = QGroupBox("Stamps")
        stamps_layout = QVBoxLayout(stamps_box)
        stamps_layout.addLayout(source_form)
        stamps_layout.addWidget(self.stamp_table, 1)
        stamps_layout.addLayout(edit_form)
        stamps_layout.addWidget(self.remove_stamp_button)
        self.error_label = error_label()

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(pins_box, 1)
        layout.addWidget(stamps_box, 1)
        layout.addWidget(self.error_label)

        self._show_pins()
        self._show_stamps()
        document.changed.connect(self._document_changed)
        self.set_stamp_source(ExampleRef(builtin=DEFAULT_STAMP))

    # -- stamp source ------------------------------------------------------------------------------
    @property
    def stamp_source(self) -> tuple[ExampleRef, tuple[int, int]] | None:
        """The DEM the Stamp tool places and its size, None until it is read."""
        ref = self.source.currentData()
        shape = self._source_shapes.get(ref)
        return None if ref is None or shape is None else (ref, shape)

    def set_stamp_source(self, ref: ExampleRef) -> None:
        """Choose the DEM to place (a file is added to the list); read it in the background."""
        index = self._index_of(ref)
        if index < 0:
            self.source.insertItem(self.source.count() - 1, ref.label, ref)
            index = self.source.count() - 2
        self.source.setCurrentIndex(index)
        if ref in self._source_shapes:
            self._show_source()
            self.stamp_source_ready.emit(ref)
            return
        self.source_label.setText("reading…")
        run_in_background(lambda: _shape_of(ref), self._source_read, self._source_failed)

    def _index_of(self, ref: ExampleRef) -> int:
        # Not QComboBox.findData: it compares Python objects by identity.
        for index in range(self.source.count()):
            if self.source.itemData(index) == ref:
                return index
        return -1

    def _source_activated(self, index: int) -> None:
        ref = self.source.itemData(index)
        if ref is not None:
            self.set_stamp_source(ref)
            return
        path = ask_dem_file(self, "DEM to stamp")
        if path is not None:
            self.set_stamp_source(ExampleRef(path=path))
        else:
            self._show_source()

    def _source_read(self, value) -> None:
        ref, shape = value
        self._source_shapes[ref] = shape
        self._show_source()
        self.stamp_source_ready.emit(ref)

    def _source_failed(self, message: str) -> None:
        # Drop the unreadable file from the list and fall back to the default.
        ref = self.source.currentData()
        if ref is not None and ref.path is not None and ref.path in message:
            self.source.removeItem(self.source.currentIndex())
            self.source.setCurrentIndex(self._index_of(ExampleRef(builtin=DEFAULT_STAMP)))
        self._show_source()
        self.stamp_source_failed.emit(message)

    def _show_source(self) -> None:
        source = self.stamp_source
        self.source_label.setText("" if source is None else f"{source[1][0]} x {source[1][1]} cells")

    # -- pins ----------------------------------------------------------------------------------------
    def remove_current_pin(self) -> None:
        row = self.pin_table.currentRow()
        if 0 <= row < len(self.document.pins):
            self.document.remove_pin(row)

    def _pin_item_changed(self, item: QTableWidgetItem) -> None:
        if self._syncing or item.column() != 2:
            return
        try:
            self.document.update_pin(item.row(), float(item.text()))
        except (ValueError, TerraSynthError):
            self.error_label.setText(f"pin height {item.text()!r}: expected a number of metres")
            self._show_pins()
            return
        self.error_label.clear()

    def _show_pins(self) -> None:
        pins = self.document.pins
        errors = pin_error_rows(self.document)
        self._syncing = True
        self.pin_table.setRowCount(len(pins))
        for i, (pin, error) in enumerate(zip(pins, errors)):
            cells = [str(i + 1), f"{pin.row}, {pin.col}", f"{pin.height:g}",
                     "–" if error is None else f"{error[0]:+.2f}", "–" if error is None else f"{error[1]:+.2f}"]
            for column, text in enumerate(cells):
                item = QTableWidgetItem(text)
                flags = Qt.ItemIsSelectable | Qt.ItemIsEnabled
                if column == 2:
                    flags |= Qt.ItemIsEditable
                item.setFlags(flags)
                self.pin_table.setItem(i, column, item)
        self._syncing = False
        known = [e for e in errors if e is not None]
        if known:
            worst = max(known, key=lambda e: abs(e[0]))
            self.pin_summary.setText(f"Largest miss after the last run: {worst[0]:+.2f} m "
                                     f"({worst[1]:+.2f} % of the terrain's height range)")
        else:
            self.pin_summary.setText("Errors appear after a run." if pins else "")
        self._update_buttons()

    # -- stamps -------------------------------------------------------------------------------------
    @property
    def current_stamp(self) -> int | None:
        row = self.stamp_table.currentRow()
        return row if 0 <= row < len(self.document.stamps) else None

    def select_stamp(self, index: int) -> None:
        self.stamp_table.selectRow(index)

    def remove_current_stamp(self) -> None:
        index = self.current_stamp
        if index is not None:
            self.document.remove_stamp(index)

    def _edit_stamp(self, **changes) -> None:
        index = self.current_stamp
        if not self._syncing and index is not None:
            apply_edit(self.error_label, lambda: self.document.update_stamp(index, **changes))

    def _stamp_selected(self) -> None:
        index = self.current_stamp
        self._syncing = True
        if index is not None:
            stamp = self.document.stamps[index]
            self.rotation.setValue(stamp.rotation)
            self.scale.setValue(stamp.scale)
        self._syncing = False
        self._update_buttons()

    def _show_stamps(self) -> None:
        current = self.current_stamp
        stamps = self.document.stamps
        self._syncing = True
        self.stamp_table.setRowCount(len(stamps))
        for i, stamp in enumerate(stamps):
            cells = [str(i + 1), f"{stamp.center[0]:g}, {stamp.center[1]:g}", f"{stamp.rotation:g}°",
                     f"x{stamp.scale:g}", stamp.example.label]
            for column, text in enumerate(cells):
                item = QTableWidgetItem(text)
                item.setFlags(Qt.ItemIsSelectable | Qt.ItemIsEnabled)
                self.stamp_table.setItem(i, column, item)
        self._syncing = False
        # A stamp just placed is the one to adjust next.
        added = len(stamps) > self._stamp_count
        self._stamp_count = len(stamps)
        if stamps:
            self.select_stamp(len(stamps) - 1 if added or current is None else min(current, len(stamps) - 1))
        self._stamp_selected()

    def _update_buttons(self) -> None:
        self.remove_pin_button.setEnabled(0 <= self.pin_table.currentRow() < len(self.document.pins))
        has_stamp = self.current_stamp is not None
        for widget in (self.rotation, self.scale, self.remove_stamp_button):
            widget.setEnabled(has_stamp)

    # -- document events --------------------------------------------------------------------------------
    def _document_changed(self, what: str) -> None:
        if what in ("pins", "result"):
            self._show_pins()
        elif what == "stamps":
            self._show_stamps()


def _table(columns: tuple[str, ...]) -> QTableWidget:
    table = QTableWidget(0, len(columns))
    table.setHorizontalHeaderLabels(list(columns))
    table.verticalHeader().setVisible(False)
    table.setSelectionBehavior(QAbstractItemView.SelectRows)
    table.setSelectionMode(QAbstractItemView.SingleSelection)
    table.setEditTriggers(QAbstractItemView.DoubleClicked | QAbstractItemView.EditKeyPressed)
    table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeToContents)
    table.horizontalHeader().setStretchLastSection(True)
    table.setMinimumHeight(90)
    return table
