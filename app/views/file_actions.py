"""The File menu's side of the window: file dialogs, the unsaved-changes
question, the recent-files menu and the recovery offer.

Each action asks the user what it needs (a path, a size, whether to save)
and hands it to the :class:`~terrasynth_app.controllers.FilesController`
or :class:`~terrasynth_app.controllers.AutosaveController`.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QObject
from PySide6.QtWidgets import QFileDialog, QMenu, QMessageBox, QWidget

from ..controllers import AutosaveController, FilesController
from ..model import PROJECT_EXTENSION, Document
from .dialogs import NewSketchDialog
from .export_dialog import ExportDialog, PresetExportDialog
from .panel_widgets import ask_dem_file

APP_NAME = "TerraSynth"
_PROJECT_FILTER = f"TerraSynth projects (*{PROJECT_EXTENSION})"
_SKETCH_FILTER = "Sketch PNG (*.png)"


class FileActions(QObject):
    """What the File menu does, dialogs included.

    Parameters
    ----------
    window : QWidget
        Parent of the dialogs.
    document : Document
    files : FilesController
    autosave : AutosaveController
    """

    def __init__(self, window: QWidget, document: Document, files: FilesController,
                 autosave: AutosaveController) -> None:
        super().__init__(window)
        self.window = window
        self.document = document
        self.controller = files
        self.autosave = autosave
        self.recent_menu: QMenu | None = None
        files.recent_changed.connect(lambda _files: self.update_recent_menu())

    def _ask_open(self, title: str, file_filter: str) -> str | None:
        path, _ = QFileDialog.getOpenFileName(self.window, title, "", file_filter)
        return path or None

    def _ask_save(self, title: str, name: str, file_filter: str) -> str | None:
        path, _ = QFileDialog.getSaveFileName(self.window, title, name, file_filter)
        return path or None

    # -- projects ------------------------------------------------------------------------
    def maybe_save(self) -> bool:
        """Ask about unsaved changes; False when the user cancels."""
        if not self.document.dirty:
            return True
        answer = QMessageBox.question(
            self.window, APP_NAME, f"Save the changes to {self.document.title}?",
            QMessageBox.Save | QMessageBox.Discard | QMessageBox.Cancel, QMessageBox.Save)
        if answer == QMessageBox.Save:
            return self.save()
        return answer == QMessageBox.Discard

    def new_project(self) -> None:
        if self.maybe_save():
            self.controller.new_project()

    def open_project(self, path: str | None = None) -> bool:
        if not self.maybe_save():
            return False
        path = path or self._ask_open("Open project", _PROJECT_FILTER)
        return path is not None and self.controller.open_project(path)

    def open_example_map(self, key: str) -> None:
        """Make the built-in map ``key`` the document, after asking about unsaved changes."""
        if self.maybe_save():
            self.controller.open_example_map(key)

    def save(self) -> bool:
        if self.document.path is None:
            return self.save_as()
        return self.controller.save_to(self.document.path)

    def save_as(self) -> bool:
        path = self._ask_save("Save project", f"terrain{PROJECT_EXTENSION}", _PROJECT_FILTER)
        if path is None:
            return False
        if not path.endswith(PROJECT_EXTENSION):
            path += PROJECT_EXTENSION
        return self.controller.save_to(path)

    def update_recent_menu(self) -> None:
        """Fill :attr:`recent_menu` with the recent projects."""
        menu = self.recent_menu
        if menu is None:
            return
        menu.clear()
        files = self.controller.recent_files()
        for path in files:
            action = menu.addAction(Path(path).name)
            action.setToolTip(path)
            action.triggered.connect(lambda _=False, path=path: self.open_project(path))
        menu.setEnabled(bool(files))

    # -- sketches and imports ---------------------------------------------------------------
    def new_sketch(self) -> None:
        dialog = NewSketchDialog(self.document.sketch.shape, self.window)
        if dialog.exec():
            self.controller.new_sketch(dialog.shape)

    def open_sketch(self, path: str | None = None) -> None:
        path = path or self._ask_open("Open sketch", _SKETCH_FILTER)
        if path is not None:
            self.controller.open_sketch(path)

    def save_sketch(self, path: str | None = None) -> None:
        path = path or self._ask_save("Save sketch", "sketch.png", _SKETCH_FILTER)
        if path is not None:
            self.controller.save_sketch(path)

    def import_dem_features(self, path: str | None = None) -> None:
        path = path or ask_dem_file(self.window, "Import DEM features")
        if path is not None:
            self.controller.import_dem_features(path)

    def import_style_regions(self, path: str | None = None) -> None:
        path = path or self._ask_open("Import style regions", "Style regions (*.png)")
        if path is not None:
            self.controller.import_style_regions(path)

    def import_water_mask(self, path: str | None = None) -> None:
        path = path or self._ask_open("Import water mask", "Water mask (*.png)")
        if path is not None:
            self.controller.import_water_mask(path)

    # -- export --------------------------------------------------------------------------------
    def export_terrain(self, screenshot=None) -> None:
        """Ask for the export options and write the terrain; ``screenshot``
        is called when the dialog asks for a picture of the 3D view."""
        result = self.document.result
        if result is None:
            self.controller.error.emit("Nothing to export", "Synthesize a terrain first.")
            return
        folder = str(self.document.path.parent) if self.document.path is not None else ""
        dialog = ExportDialog(result.shape, directory=folder, parent=self.window)
        if screenshot is not None:
            dialog.screenshot_requested.connect(screenshot)
        if not dialog.exec():
            return
        options = dialog.options()
        self.controller.export(result, options.pop("path"), **options)

    def export_for(self, preset: str) -> None:
        """"Export for…" an engine preset or the masks: ask the folder and options, then write."""
        result = self.document.result
        if result is None:
            self.controller.error.emit("Nothing to export", "Synthesize a terrain first.")
            return
        folder = str(self.document.path.parent) if self.document.path is not None else ""
        dialog = PresetExportDialog(preset, result.shape, directory=folder, parent=self.window)
        if not dialog.exec():
            return
        options = dialog.options()
        self.controller.export_preset(result, preset, options.pop("folder"), **options)

    # -- recovery -------------------------------------------------------------------------------
    def offer_recovery(self) -> bool:
        """If a previous session left unsaved work, offer to restore it; True if restored."""
        what = self.autosave.recoverable()
        if what is None:
            return False
        answer = QMessageBox.question(self.window, APP_NAME, f"{what}.\nRecover it?",
                                      QMessageBox.Yes | QMessageBox.No, QMessageBox.Yes)
        if answer != QMessageBox.Yes:
            self.autosave.discard()
            return False
        return self.autosave.recover()
