"""Files: projects, recent files, example maps, sketch PNGs, imports and export.

Every method takes a path the view already asked for; slow reads and
writes go to the thread pool.  Errors and notices come back as signals for
the window to show.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PySide6.QtCore import QObject, QSettings, Signal

from terrasynth_core.errors import TerraSynthError
from terrasynth_core.features import read_sketch, save_sketch

from ..model import (EXAMPLE_MAPS, Document, RecoveryStore, TerrainResult, dem_file_feature_layers,
                     example_map_document, export_for_engine_preset, export_masks, export_terrain, load_project, save_project, style_layer_from_png,
                     water_layer_from_png)
from ..workers import run_in_background
from .synthesis import SynthesisController

RECENT_KEY = "recent_files"
MAX_RECENT = 8


class FilesController(QObject):
    """Reads and writes the document's files.

    Parameters
    ----------
    document : Document
    settings : QSettings
        Where the recent files are kept.
    synthesis : SynthesisController
        Its run is cancelled when another document replaces this one.
    recovery : RecoveryStore or None
        Discarded after a clean save.

    Signals
    -------
    recent_changed(object)
        The recent files, newest first (a list of paths).
    example_map_opened(str)
        A built-in example map became the document; carries its key.
    export_finished(str)
        A file was exported; carries its path.
    status(str, int)
        A message for the status bar and how many ms to show it (0: until replaced).
    error(str, str)
        A title and a message for an error dialog.
    """

    recent_changed = Signal(object)
    example_map_opened = Signal(str)
    export_finished = Signal(str)
    status = Signal(str, int)
    error = Signal(str, str)

    def __init__(self, document: Document, settings: QSettings, synthesis: SynthesisController,
                 recovery: RecoveryStore | None = None, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.document = document
        self.settings = settings
        self.synthesis = synthesis
        self.recovery = recovery

    # -- projects ------------------------------------------------------------------------
    def new_project(self) -> None:
        self._replace_document(Document.default())

    def open_project(self, path: str) -> bool:
        try:
            loaded = load_project(path)
        except TerraSynthError as exc:
            self.error.emit("Cannot open project", str(exc))
            return False
        self._replace_document(loaded)
        self._add_recent(path)
        self.status.emit(f"Opened {path}", 5000)
        return True

    def save_to(self, path) -> bool:
        """Write the project to ``path``; False (and :attr:`error`) on failure."""
        try:
            save_project(self.document, path)
        except TerraSynthError as exc:
            self.error.emit("Cannot save project", str(exc))
            return False
        if self.recovery is not None:
            self.recovery.discard()
        self._add_recent(str(path))
        self.status.emit(f"Saved {path}", 5000)
        return True

    def open_example_map(self, key: str) -> None:
        """Make the built-in map ``key`` the document; it is read on the
        thread pool and :attr:`example_map_opened` follows."""
        self.status.emit(f"Reading the {EXAMPLE_MAPS[key]} example map…", 0)
        run_in_background(lambda: (key, example_map_document(key)), self._example_map_read,
                          self._example_map_failed)

    def _example_map_read(self, value) -> None:
        key, document = value
        self._replace_document(document)
        self.status.emit(f"Opened the {EXAMPLE_MAPS[key]} example map: press Synthesize", 10_000)
        self.example_map_opened.emit(key)

    def _example_map_failed(self, message: str) -> None:
        self.error.emit("Cannot open the example map", message)

    def _replace_document(self, other: Document) -> None:
        self.synthesis.runner.cancel()
        self.document.assign(other)

    # -- recent files ----------------------------------------------------------------------
    def recent_files(self) -> list[str]:
        value = self.settings.value(RECENT_KEY, [])
        if isinstance(value, str):  # QSettings returns a lone string for a one-item list
            value = [value]
        return [str(v) for v in value or []]

    def _add_recent(self, path: str) -> None:
        path = str(Path(path).resolve())
        files = [path] + [p for p in self.recent_files() if p != path]
        self.settings.setValue(RECENT_KEY, files[:MAX_RECENT])
        self.recent_changed.emit(self.recent_files())

    # -- sketch files and imports ------------------------------------------------------------
    def new_sketch(self, shape: tuple[int, int]) -> None:
        self.document.sketch.replace(np.zeros(shape, np.uint8), np.zeros(shape, np.uint8))

    def open_sketch(self, path: str) -> None:
        try:
            # Replacing checks the app's side limit too (a 16000x4000 sketch
            # passes the reader's pixel limit): both errors keep the sketch.
            self.document.sketch.replace_with_map(read_sketch(path))
        except TerraSynthError as exc:
            self.error.emit("Cannot open sketch", str(exc))
            return
        self.status.emit(f"Opened sketch {path}", 5000)

    def save_sketch(self, path: str) -> None:
        try:
            save_sketch(self.document.sketch.to_sketch_map(), path)
        except TerraSynthError as exc:
            self.error.emit("Cannot save sketch", str(exc))
            return
        self.status.emit(f"Saved sketch {path}", 5000)

    def import_dem_features(self, path: str) -> None:
        """Trace a DEM's ridges and valleys into the sketch (on the thread pool; one undo step)."""
        shape = self.document.sketch.shape
        self.status.emit(f"Tracing ridges and valleys of {path}…", 0)
        run_in_background(lambda: dem_file_feature_layers(path, shape), self._features_imported,
                          self._features_failed)

    def _features_imported(self, layers) -> None:
        self.document.sketch.replace(*layers)
        self.status.emit("Imported the DEM's ridges and valleys as a sketch (undo reverts)", 8000)

    def _features_failed(self, message: str) -> None:
        self.error.emit("Cannot import DEM features", message)

    def import_style_regions(self, path: str) -> None:
        """Replace the style layer with a style-region PNG (one undo step)."""
        doc = self.document
        try:
            layer = style_layer_from_png(path, doc.styles, doc.output_shape)
        except TerraSynthError as exc:
            self.error.emit("Cannot import style regions", str(exc))
            return
        doc.sketch.replace_regions(style=layer)
        unstyled = float((layer < 0).mean())
        self.status.emit(
            f"Imported style regions from {path}" + (f"; {100 * unstyled:.0f} % of the cells match no style's "
                                                     "colour and use the plain examples" if unstyled else ""),
            10_000)

    def import_water_mask(self, path: str) -> None:
        """Replace the water layer with a water-mask PNG (one undo step)."""
        try:
            layer = water_layer_from_png(path, self.document.output_shape)
        except TerraSynthError as exc:
            self.error.emit("Cannot import water mask", str(exc))
            return
        self.document.sketch.replace_regions(water=layer)
        self.status.emit(f"Imported the water mask {path}: {100 * layer.mean():.0f} % water", 10_000)

    # -- export -------------------------------------------------------------------------------
    def export(self, result: TerrainResult, path: str, **options) -> None:
        """Write ``result`` to ``path`` on the thread pool (``options`` as for
        :func:`~terrasynth_app.model.export_terrain`)."""
        self.status.emit(f"Exporting {path}…", 0)
        run_in_background(lambda: str(export_terrain(result, path, **options)), self._exported,
                          self._export_failed)

    def export_preset(self, result: TerrainResult, preset: str, folder: str, **options) -> None:
        """Write ``result`` for an engine (``preset`` a key of
        :data:`terrasynth_core.export.PRESETS`) or, with ``preset ==
        "masks"``, its masks, into ``folder`` on the thread pool; the status
        bar shows the numbers to type into the engine."""
        self.status.emit(f"Exporting for {preset} into {folder}…", 0)
        if preset == "masks":
            # Copies taken here: the user may paint on while the pool thread works.
            water, style_ids = np.array(self.document.sketch.water), np.array(self.document.sketch.style)
            job = lambda: export_masks(result, folder, water=water, style_ids=style_ids, **options)  # noqa: E731
        else:
            job = lambda: export_for_engine_preset(result, preset, folder, **options)  # noqa: E731
        run_in_background(job, self._preset_exported, self._export_failed)

    def _preset_exported(self, summary: str) -> None:
        self.status.emit(summary, 0)
        self.export_finished.emit(summary)

    def _exported(self, path: str) -> None:
        self.status.emit(f"Exported {path}", 8000)
        self.export_finished.emit(path)

    def _export_failed(self, message: str) -> None:
        self.error.emit("Export failed", message)
