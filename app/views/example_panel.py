"""The example library: built-in DEMs and the user's own, with thumbnails.

Checked items are the document's examples.  Loading a DEM to show its size,
resolution and thumbnail happens on the thread pool, so a slow file never
freezes the window; a file that cannot be read is reported and not added.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PySide6.QtCore import QSize, Qt, Signal
from PySide6.QtGui import QIcon, QImage, QPixmap
from PySide6.QtWidgets import (QListWidget, QListWidgetItem, QPushButton, QVBoxLayout,
                               QWidget)

from terrasynth_core.io import READ_EXTENSIONS
from terrasynth_core.pictures import thumbnail

from ..model.document import Document
from ..model.example_library import ExampleRef, builtin_refs, ground_cell_text
from ..workers import run_in_background
from .panel_widgets import ask_dem_file, hbox

THUMB_SIDE = 96
_REF_ROLE = Qt.UserRole + 1


@dataclass(frozen=True)
class ExampleInfo:
    """What the library shows of a loaded example."""

    ref: ExampleRef
    shape: tuple[int, int]
    cell_size: tuple[float, float] | None
    height_range: tuple[float, float]
    thumbnail: np.ndarray | None  # RGBA uint8, None when a thumbnail file exists


def describe(info: ExampleInfo, square: float | None = None) -> str:
    """Second line of an item: size, ground cell (dy x dx; ``square``: the
    run's cell size it is resampled to) and height range."""
    rows, cols = info.shape
    low, high = info.height_range
    return f"{rows} x {cols}, {ground_cell_text(info.cell_size, square)}, {low:.0f} to {high:.0f} m"


def load_info(ref: ExampleRef) -> ExampleInfo:
    """Read ``ref`` and make its library entry (runs on a pool thread)."""
    field = ref.load()
    thumb = None
    if ref.thumbnail_file is None:
        thumb = thumbnail(field.heights, cell_size=field.cell_size, side=THUMB_SIDE)
    return ExampleInfo(ref, field.shape, field.cell_size, (field.min, field.max), thumb)


def rgba_pixmap(rgba: np.ndarray) -> QPixmap:
    """A QPixmap of a uint8 (rows, cols, 4) array (copied)."""
    rgba = np.ascontiguousarray(rgba)
    rows, cols = rgba.shape[:2]
    image = QImage(rgba.data, cols, rows, 4 * cols, QImage.Format_RGBA8888)
    return QPixmap.fromImage(image.copy())


class ExamplePanel(QWidget):
    """List of example DEMs; the checked ones are the document's examples.

    Signals
    -------
    info_loaded(object)
        An :class:`ExampleInfo` arrived for an item.
    load_failed(str)
        A DEM the user added could not be read; the message names the file.
    item_unreadable(str)
        A DEM listed from the document (e.g. a project whose file moved)
        cannot be read; its item says so.
    """

    info_loaded = Signal(object)
    load_failed = Signal(str)
    item_unreadable = Signal(str)

    def __init__(self, document: Document, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.document = document
        self.infos: dict[ExampleRef, ExampleInfo] = {}
        self.list = QListWidget()
        self.list.setIconSize(QSize(THUMB_SIDE, THUMB_SIDE))
        self.list.setSpacing(2)
        self.list.setWordWrap(True)
        self.list.itemChanged.connect(self._item_changed)
        self.list.currentItemChanged.connect(lambda *_: self._update_buttons())
        self.add_button = QPushButton("Add DEM…")
        self.add_button.setToolTip("Add an example from a DEM file (" + " ".join(READ_EXTENSIONS) + ")")
        self.add_button.clicked.connect(self.choose_file)
        self.remove_button = QPushButton("Remove")
        self.remove_button.setToolTip("Remove the selected file from the library")
        self.remove_button.clicked.connect(self.remove_current)
        buttons = hbox(self.add_button, self.remove_button)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.list, 1)
        layout.addLayout(buttons)

        self._syncing = False
        for ref in builtin_refs():
            self._add_item(ref)
        self._sync_from_document()
        document.changed.connect(self._document_changed)
        self._update_buttons()

    # -- items ------------------------------------------------------------------------------
    def refs(self) -> list[ExampleRef]:
        return [self.list.item(i).data(_REF_ROLE) for i in range(self.list.count())]

    def item_for(self, ref: ExampleRef) -> QListWidgetItem | None:
        for i in range(self.list.count()):
            if self.list.item(i).data(_REF_ROLE) == ref:
                return self.list.item(i)
        return None

    def _add_item(self, ref: ExampleRef, *, checked: bool = False) -> QListWidgetItem:
        item = QListWidgetItem(f"{ref.label}\nloading…")
        item.setData(_REF_ROLE, ref)
        item.setFlags(item.flags() | Qt.ItemIsUserCheckable)
        item.setCheckState(Qt.Checked if checked else Qt.Unchecked)
        item.setToolTip(ref.description)
        if ref.thumbnail_file is not None:
            item.setIcon(QIcon(str(ref.thumbnail_file)))
        self._syncing = True
        self.list.addItem(item)
        self._syncing = False
        run_in_background(lambda: load_info(ref), self._info_ready, self._info_failed)
        return item

    def _info_ready(self, info: ExampleInfo) -> None:
        self.infos[info.ref] = info
        item = self.item_for(info.ref)
        if item is not None:
            self._syncing = True
            if info.thumbnail is not None:
                item.setIcon(QIcon(rgba_pixmap(info.thumbnail)))
            self._syncing = False
        self._show_cell_sizes()
        self.info_loaded.emit(info)

    def _info_failed(self, message: str) -> None:
        # Built-ins always load; a failing item is a user's file (added from a
        # project whose DEM moved, or a corrupt one): mark it, never crash.
        for ref in self.refs():
            if ref.path is not None and ref not in self.infos and ref.path in message:
                item = self.item_for(ref)
                self._syncing = True
                item.setText(f"{ref.label}\ncannot be read")
                item.setToolTip(message)
                self._syncing = False
        self.item_unreadable.emit(message)

    # -- user actions -----------------------------------------------------------------------------
    def choose_file(self) -> None:
        path = ask_dem_file(self, "Add a DEM", any_file=True)
        if path is not None:
            self.add_file(path)

    def add_file(self, path: str) -> None:
        """Read ``path`` in the background; add and select it if it is a valid DEM."""
        ref = ExampleRef(path=path)
        if self.item_for(ref) is not None:
            self.item_for(ref).setCheckState(Qt.Checked)
            return
        run_in_background(lambda: load_info(ref), self._file_ready, self.load_failed)

    def _file_ready(self, info: ExampleInfo) -> None:
        self.infos[info.ref] = info
        self._syncing = True
        item = QListWidgetItem(f"{info.ref.label}\n{describe(info, self.document.cell_size())}")
        item.setData(_REF_ROLE, info.ref)
        item.setFlags(item.flags() | Qt.ItemIsUserCheckable)
        item.setCheckState(Qt.Checked)
        item.setToolTip(info.ref.path)
        if info.thumbnail is not None:
            item.setIcon(QIcon(rgba_pixmap(info.thumbnail)))
        self.list.addItem(item)
        self.list.setCurrentItem(item)
        self._syncing = False
        self.document.add_example(info.ref)
        self.info_loaded.emit(info)

    def remove_current(self) -> None:
        item = self.list.currentItem()
        if item is None or item.data(_REF_ROLE).builtin is not None:
            return
        ref = item.data(_REF_ROLE)
        self.list.takeItem(self.list.row(item))
        self.document.remove_example(ref)

    def _update_buttons(self) -> None:
        item = self.list.currentItem()
        self.remove_button.setEnabled(item is not None and item.data(_REF_ROLE).builtin is None)

    # -- document sync ---------------------------------------------------------------------------
    def _item_changed(self, _item: QListWidgetItem) -> None:
        if self._syncing:
            return
        chosen = [self.list.item(i).data(_REF_ROLE) for i in range(self.list.count())
                  if self.list.item(i).checkState() == Qt.Checked]
        # Keep the document's order for examples already chosen, new ones last.
        current = [ref for ref in self.document.examples if ref in chosen]
        self.document.set_examples(current + [ref for ref in chosen if ref not in current])

    def _document_changed(self, what: str) -> None:
        if what == "examples":
            self._sync_from_document()
        if what in ("examples", "params", "styles", "stamps"):
            self._show_cell_sizes()

    def _show_cell_sizes(self) -> None:
        """Each loaded item's description; the chosen examples also say the
        square cell size the run resamples them to."""
        square = self.document.cell_size()
        chosen = self.document.examples
        self._syncing = True
        for i in range(self.list.count()):
            item = self.list.item(i)
            info = self.infos.get(item.data(_REF_ROLE))
            if info is not None:
                item.setText(f"{info.ref.label}\n{describe(info, square if info.ref in chosen else None)}")
        self._syncing = False

    def _sync_from_document(self) -> None:
        chosen = self.document.examples
        for ref in chosen:
            if self.item_for(ref) is None:
                self._add_item(ref)
        self._syncing = True
        for i in range(self.list.count()):
            item = self.list.item(i)
            item.setCheckState(Qt.Checked if item.data(_REF_ROLE) in chosen else Qt.Unchecked)
        self._syncing = False
