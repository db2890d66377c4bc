"""The Regions panel: terrain styles to paint, the water level and the
height range of the output.

A style is an example DEM (built in or a file) with a colour, a relief
scale and an optional base level; the canvas's Style brush paints it.  A
DEM file is read on the thread pool before it becomes a style, so a file
that cannot be read is reported and never added.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QColor, QIcon, QPixmap
from PySide6.QtWidgets import (QCheckBox, QColorDialog, QDoubleSpinBox, QFormLayout, QGroupBox,
                               QLabel, QLineEdit, QListWidget, QListWidgetItem, QMenu, QPushButton,
                               QToolButton, QVBoxLayout, QWidget)

from ..model.control_specs import RELIEF_SCALE_RANGE, StyleSpec
from ..model.document import Document
from ..model.example_library import ExampleRef, builtin_refs, ground_cell_text
from ..workers import run_in_background
from .panel_widgets import apply_edit, ask_dem_file, error_label, hbox

_ID_ROLE = Qt.UserRole + 1
#: Heights the spin boxes accept, metres (below the Dead Sea shore to above Everest, with room).
HEIGHT_LIMITS = (-12_000.0, 12_000.0)


def swatch(color: str, side: int = 16) -> QIcon:
    """A square icon of one colour."""
    pixmap = QPixmap(side, side)
    pixmap.fill(QColor(color))
    return QIcon(pixmap)


def describe_style(spec: StyleSpec, square: float | None = None) -> str:
    """Second line of a style's item: its DEM and ground cell (once loaded;
    ``square``: the run's cell size), relief scale and base."""
    base = "base: example median" if spec.base is None else f"base {spec.base:g} m"
    cell = spec.example.loaded_cell_size()
    cell = "" if cell is None else f" ({ground_cell_text(cell, square)})"
    return f"{spec.example.label}{cell}, relief x{spec.relief_scale:g}, {base}"


def _checked_ref(ref: ExampleRef) -> ExampleRef:
    ref.load()  # raises with the file's name when it is not a readable DEM
    return ref


class StylePanel(QWidget):
    """Edits the document's styles, water level and height range.

    Signals
    -------
    style_selected(int)
        The user picked the style with this id in the list.
    style_load_failed(str)
        A DEM file chosen for a new style cannot be read; nothing was added.
    """

    style_selected = Signal(int)
    style_load_failed = Signal(str)

    def __init__(self, document: Document, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.document = document
        self._syncing = False

        self.list = QListWidget()
        self.list.setWordWrap(True)
        # Items take two or three lines: room for about three styles before
        # the list scrolls (the panel itself scrolls in its dock).
        self.list.setMinimumHeight(9 * self.list.fontMetrics().lineSpacing())
        self.list.currentItemChanged.connect(self._current_changed)
        self.add_button = QToolButton(text="Add style", popupMode=QToolButton.InstantPopup)
        self.add_button.setToolTip("A new style from a built-in example or a DEM file; paint it with the Style brush")
        menu = QMenu(self.add_button)
        for ref in builtin_refs():
            menu.addAction(ref.label).triggered.connect(lambda _=False, ref=ref: self.add_style(ref))
        menu.addSeparator()
        menu.addAction("DEM file…").triggered.connect(self.choose_file)
        self.add_button.setMenu(menu)
        self.remove_button = QPushButton("Remove")
        self.remove_button.setToolTip("Remove the style; its regions fall back to the plain examples")
        self.remove_button.clicked.connect(self.remove_current)
        buttons = hbox(self.add_button, self.remove_button)
        buttons.addStretch(1)

        self.name = QLineEdit()
        self.name.editingFinished.connect(lambda: self._edit(name=self.name.text().strip()))
        self.color_button = QPushButton("Colour…")
        self.color_button.setToolTip("How the style's regions are drawn on the sketch")
        self.color_button.clicked.connect(self.choose_color)
        self.relief = QDoubleSpinBox(minimum=RELIEF_SCALE_RANGE[0], maximum=RELIEF_SCALE_RANGE[1], singleStep=0.1,
                                     decimals=2, prefix="x ")
        self.relief.setToolTip("Multiplies the example's height variation about its median: "
                               "below 1 flattens the style, above 1 roughens it")
        self.relief.valueChanged.connect(lambda v: self._edit(relief_scale=v))
        self.base_auto = QCheckBox("example median")
        self.base = QDoubleSpinBox(minimum=HEIGHT_LIMITS[0], maximum=HEIGHT_LIMITS[1], decimals=0, suffix=" m")
        self.base.setToolTip("Level the style's terrain sits at; neighbouring regions meet smoothly")
        self.base_auto.toggled.connect(self._base_edited)
        self.base.valueChanged.connect(self._base_edited)
        base_row = hbox(self.base_auto, (self.base, 1))
        self.editor = QGroupBox("Selected style")
        form = QFormLayout(self.editor)
        form.addRow("Name", self.name)
        form.addRow("Colour", self.color_button)
        form.addRow("Relief", self.relief)
        form.addRow("Base", base_row)

        self.water_level = QDoubleSpinBox(minimum=HEIGHT_LIMITS[0], maximum=HEIGHT_LIMITS[1], decimals=1,
                                          suffix=" m")
        self.water_level.setToolTip("Height of the painted water's surface; land eases down to it at the shore")
        self.water_level.valueChanged.connect(self._water_level_edited)
        self.level_from_terrain = QPushButton("From terrain")
        self.level_from_terrain.setToolTip("The median height of the current terrain under the painted water "
                                           "(the 10th percentile of all heights when none is painted)")
        self.level_from_terrain.clicked.connect(self._suggest_level)
        self.clear_water = QPushButton("Clear water")
        self.clear_water.setToolTip("Erase all painted water (undoable)")
        self.clear_water.clicked.connect(self._clear_water)
        level_row = hbox((self.water_level, 1), self.level_from_terrain)
        water_box = QGroupBox("Water")
        water_form = QFormLayout(water_box)
        water_form.addRow("Level", level_row)
        water_form.addRow(self.clear_water)

        self.range_check = QCheckBox("Map the terrain onto")
        self.range_check.setToolTip("Scale the finished heights linearly to this range (before water and pins)")
        self.range_low = QDoubleSpinBox(minimum=HEIGHT_LIMITS[0], maximum=HEIGHT_LIMITS[1], decimals=0, suffix=" m")
        self.range_high = QDoubleSpinBox(minimum=HEIGHT_LIMITS[0], maximum=HEIGHT_LIMITS[1], decimals=0,
                                         suffix=" m", value=1500.0)
        self.range_check.toggled.connect(self._range_edited)
        self.range_low.valueChanged.connect(self._range_edited)
        self.range_high.valueChanged.connect(self._range_edited)
        range_row = hbox((self.range_low, 1), QLabel("to"), (self.range_high, 1))
        range_box = QGroupBox("Height range")
        range_layout = QVBoxLayout(range_box)
        range_layout.addWidget(self.range_check)
        range_layout.addLayout(range_row)
        self.error_label = error_label()

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.list, 1)
        layout.addLayout(buttons)
        layout.addWidget(self.editor)
        layout.addWidget(water_box)
        layout.addWidget(range_box)
        layout.addWidget(self.error_label)

        self._show_styles()
        self._show_water_level()
        self._show_range()
        self._update_level_button()
        document.changed.connect(self._document_changed)
        document.sketch.changed.connect(self._sketch_changed)

    # -- user actions ---------------------------------------------------------------------------
    def add_style(self, ref: ExampleRef) -> StyleSpec:
        """Add a style of a built-in (or already read) example and select it."""
        spec = self.document.add_style(ref)
        self.select_style(spec.id)
        return spec

    def choose_file(self) -> None:
        path = ask_dem_file(self, "DEM of the new style")
        if path is not None:
            self.add_file(path)

    def add_file(self, path: str) -> None:
        """Read ``path`` in the background; add it as a style if it is a valid DEM."""
        ref = ExampleRef(path=path)
        run_in_background(lambda: _checked_ref(ref), self._file_ready, self.style_load_failed)

    def _file_ready(self, ref: ExampleRef) -> None:
        self.add_style(ref)

    def remove_current(self) -> None:
        style_id = self.current_style
        if style_id is not None:
            self.document.remove_style(style_id)

    def choose_color(self) -> None:
        style_id = self.current_style
        if style_id is None:
            return
        color = QColorDialog.getColor(QColor(self.document.style(style_id).color), self, "Style colour")
        if color.isValid():
            self._edit(color=color.name())

    @property
    def current_style(self) -> int | None:
        item = self.list.currentItem()
        return None if item is None else item.data(_ID_ROLE)

    def select_style(self, style_id: int) -> None:
        for i in range(self.list.count()):
            if self.list.item(i).data(_ID_ROLE) == style_id:
                self.list.setCurrentRow(i)
                return

    # -- widgets to document ----------------------------------------------------------------------
    def _edit(self, **changes) -> None:
        style_id = self.current_style
        if not self._syncing and style_id is not None:
            apply_edit(self.error_label, lambda: self.document.update_style(style_id, **changes))

    def _base_edited(self) -> None:
        self.base.setEnabled(not self.base_auto.isChecked())
        self._edit(base=None if self.base_auto.isChecked() else self.base.value())

    def _water_level_edited(self, value: float) -> None:
        if not self._syncing:
            self.document.set_water_level(value)

    def _suggest_level(self) -> None:
        level = self.document.suggested_water_level()
        if level is not None:
            self.document.set_water_level(level)

    def _clear_water(self) -> None:
        if self.document.sketch.has_water:
            self.document.sketch.replace_regions(water=np.zeros(self.document.sketch.shape, bool))

    def _range_edited(self) -> None:
        if self._syncing:
            return
        on = self.range_check.isChecked()
        self.range_low.setEnabled(on)
        self.range_high.setEnabled(on)
        low, high = self.range_low.value(), self.range_high.value()
        if on and high <= low:
            self.error_label.setText(f"height range {low:g} to {high:g} m: the top must lie above the bottom")
            return
        self.error_label.clear()
        self.document.set_height_range((low, high) if on else None)

    def _current_changed(self, item: QListWidgetItem | None, _previous) -> None:
        self._show_editor()
        if item is not None and not self._syncing:
            self.style_selected.emit(item.data(_ID_ROLE))

    # -- document to widgets ----------------------------------------------------------------------
    def _document_changed(self, what: str) -> None:
        if what == "styles":
            self._show_styles()
        elif what in ("examples", "params", "stamps"):
            self.show_style_texts()
        elif what == "water_level":
            self._show_water_level()
        elif what == "height_range":
            self._show_range()
        elif what == "result":
            self._update_level_button()

    def _sketch_changed(self, bbox) -> None:
        if bbox is None:  # maybe resized: the terrain may no longer fit
            self._update_level_button()

    def _show_styles(self) -> None:
        current = self.current_style
        self._syncing = True
        self.list.clear()
        square = self.document.cell_size()
        for spec in self.document.styles:
            item = QListWidgetItem(swatch(spec.color), f"{spec.name}\n{describe_style(spec, square)}")
            item.setData(_ID_ROLE, spec.id)
            item.setToolTip(spec.example.path or spec.example.label)
            self.list.addItem(item)
        self._syncing = False
        if current is not None:
            self.select_style(current)
        if self.list.currentItem() is None and self.list.count():
            self.list.setCurrentRow(self.list.count() - 1)
        self._show_editor()

    def show_style_texts(self) -> None:
        """The items' descriptions again: the run's cell size may have changed."""
        square = self.document.cell_size()
        specs = {spec.id: spec for spec in self.document.styles}
        self._syncing = True
        for i in range(self.list.count()):
            item = self.list.item(i)
            spec = specs.get(item.data(_ID_ROLE))
            if spec is not None:  # (a stale item: the styles' own event rebuilds the list)
                item.setText(f"{spec.name}\n{describe_style(spec, square)}")
        self._syncing = False

    def _show_editor(self) -> None:
        style_id = self.current_style
        self.editor.setEnabled(style_id is not None)
        self.remove_button.setEnabled(style_id is not None)
        if style_id is None:
            return
        spec = self.document.style(style_id)
        self._syncing = True
        try:
            self.name.setText(spec.name)
            self.color_button.setIcon(swatch(spec.color))
            self.relief.setValue(spec.relief_scale)
            self.base_auto.setChecked(spec.base is None)
            self.base.setEnabled(spec.base is not None)
            if spec.base is not None:
                self.base.setValue(spec.base)
        finally:
            self._syncing = False

    def _show_water_level(self) -> None:
        self._syncing = True
        self.water_level.setValue(self.document.water_level)
        self._syncing = False

    def _show_range(self) -> None:
        height_range = self.document.height_range
        self._syncing = True
        try:
            self.range_check.setChecked(height_range is not None)
            if height_range is not None:
                self.range_low.setValue(height_range[0])
                self.range_high.setValue(height_range[1])
            self.range_low.setEnabled(height_range is not None)
            self.range_high.setEnabled(height_range is not None)
        finally:
            self._syncing = False

    def _update_level_button(self) -> None:
        result = self.document.result
        self.level_from_terrain.setEnabled(result is not None and result.shape == self.document.output_shape)
