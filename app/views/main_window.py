"""The main window: sketch, examples, parameters, live 2D and 3D terrain.

The window lays the views out and wires them to the controllers: the
document holds the state, the panels translate user actions into document
edits, :class:`~terrasynth_app.controllers.SynthesisController` and
:class:`~terrasynth_app.controllers.VariationsController` run the core off
the GUI thread, :class:`~terrasynth_app.controllers.FilesController` and
:class:`~terrasynth_app.controllers.AutosaveController` read and write
files.  Every error a controller reports lands in a dialog and the status
bar; a failed or cancelled run leaves the previous result and the sketch as
they were.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from PySide6.QtCore import QSettings, Qt, QTimer, Signal
from PySide6.QtWidgets import (QDockWidget, QFileDialog, QFrame, QInputDialog, QMainWindow, QMessageBox, QScrollArea,
                               QSplitter, QTabWidget)

from ..controllers import (AUTOSAVE_MS, AutosaveController, FeatureGraphController, FilesController,
                           LargeRenderController, LiveController, SynthesisController, VariationsController)
from ..model import Document, RecoveryStore, SketchGraph, TerrainGraph
from ..model.readout import cell_readout
from ..model.water_check import document_drowning
from .example_panel import ExamplePanel
from .file_actions import APP_NAME, FileActions
from .heightmap_view import HeightmapView
from .linked_views import ViewLink
from .main_actions import MainActions
from .params_panel import ParamsPanel
from .pin_stamp_panel import PinStampPanel
from .pin_stamp_requests import PinStampRequests
from .run_status import ElidingStatusBar, RunStatus
from .sketch_canvas import GRAPH_DELAY_MS, SketchCanvas
from .style_panel import StylePanel
from .terrain_view_3d import TerrainView3D
from .large_render_dialog import LargeRenderDialog
from .variations_dialog import VariationsDialog

log = logging.getLogger(__name__)

#: Coalescing delay of water redraws while water is painted, in ms.
WATER_REFRESH_MS = 100
#: Variations a batch may have.
VARIATION_COUNTS = (2, 8)


class MainWindow(QMainWindow):
    """TerraSynth's main window.

    Parameters
    ----------
    document : Document, optional
        Default: the built-in default example and sketch, ready to run.
    settings : QSettings, optional
        Where recent files are kept; default the user's TerraSynth settings.
    recovery : RecoveryStore or None, optional
        Autosave target; None disables autosave.
    autosave_ms : int
        Autosave period.

    Attributes
    ----------
    synthesis, variations, live, file_controller, autosave
        The controllers.
    files : FileActions
        The File menu's actions, dialogs included.
    actions : MainActions
    """

    #: A file was exported; carries its path.
    export_finished = Signal(str)
    #: A built-in example map became the document; carries its key.
    example_map_opened = Signal(str)

    def __init__(self, document: Document | None = None, *, settings: QSettings | None = None,
                 recovery: RecoveryStore | None = None, autosave_ms: int = AUTOSAVE_MS) -> None:
        super().__init__()
        self.document = document if document is not None else Document.default()
        doc = self.document
        self.synthesis = SynthesisController(doc, self)
        self.variations = VariationsController(doc, self)
        self.live = LiveController(doc, self.synthesis, self)
        self.file_controller = FilesController(doc, settings if settings is not None else QSettings(APP_NAME, APP_NAME),
                                               self.synthesis, recovery, self)
        self.autosave = AutosaveController(doc, recovery, interval_ms=autosave_ms, parent=self)
        sketch_graph = FeatureGraphController(SketchGraph(doc.sketch), delay_ms=GRAPH_DELAY_MS, parent=self)
        terrain_graph = FeatureGraphController(TerrainGraph(doc), parent=self)
        self.variations_dialog: VariationsDialog | None = None
        #: File > Render large...: the document tiled on Dask (its dialog made on first use).
        self.large_render = LargeRenderController(doc, self)
        self.large_render_dialog: LargeRenderDialog | None = None
        self.resize(1500, 900)

        self.canvas = SketchCanvas(doc.sketch, document=doc, graphs=sketch_graph)
        self.heightmap = HeightmapView(terrain_graph)
        self.view3d = TerrainView3D()
        self.result_tabs = QTabWidget()
        self.result_tabs.addTab(self.heightmap, "2D terrain")
        self.result_tabs.addTab(self.view3d, "3D terrain")
        splitter = QSplitter(Qt.Horizontal)
        splitter.addWidget(self.canvas)
        splitter.addWidget(self.result_tabs)
        splitter.setSizes([650, 650])
        self.setCentralWidget(splitter)

        self.examples = ExamplePanel(doc)
        self.params = ParamsPanel(doc)
        self.styles = StylePanel(doc)
        self.pins_stamps = PinStampPanel(doc)
        self.docks = self._build_docks()
        self.setStatusBar(ElidingStatusBar())
        self.run_status = RunStatus(self.statusBar(), self.synthesis, doc)
        self.view_link = ViewLink(self.canvas.view_box, self.heightmap.view_box)
        self._water_timer = QTimer(self, singleShot=True, interval=WATER_REFRESH_MS)
        self._water_timer.timeout.connect(self._show_water)
        self.files = FileActions(self, doc, self.file_controller, self.autosave)
        self.pin_stamp_requests = PinStampRequests(self, doc, self.pins_stamps)
        self.actions = MainActions(self)
        self._connect()
        self._update_title()
        self.heightmap.show_result(doc.result)
        self.view3d.show_result(doc.result)
        self._show_water()
        self.view_link.set_enabled(self.heightmap.link_check.isChecked())

    def _build_docks(self) -> dict[str, QDockWidget]:
        docks: dict[str, QDockWidget] = {}
        for title, widget, name in (("Examples", self.examples, "examples_dock"),
                                    ("Parameters", self.params, "params_dock"),
                                    ("Regions", self.styles, "regions_dock"),
                                    ("Pins and stamps", self.pins_stamps, "pins_stamps_dock")):
            dock = QDockWidget(title, self)
            dock.setObjectName(name)
            if widget in (self.styles, self.pins_stamps):
                # Tall panels scroll rather than make the window taller than the screen.
                widget = QScrollArea(widget=widget, widgetResizable=True, frameShape=QFrame.NoFrame)
            dock.setWidget(widget)
            dock.setFeatures(QDockWidget.DockWidgetMovable | QDockWidget.DockWidgetFloatable)
            docks[name] = dock
        self.addDockWidget(Qt.LeftDockWidgetArea, docks["examples_dock"])
        self.addDockWidget(Qt.LeftDockWidgetArea, docks["params_dock"])
        # The control panels share the examples' and parameters' places, as tabs.
        self.tabifyDockWidget(docks["examples_dock"], docks["regions_dock"])
        self.tabifyDockWidget(docks["params_dock"], docks["pins_stamps_dock"])
        docks["examples_dock"].raise_()
        docks["params_dock"].raise_()
        return docks

    def _connect(self) -> None:
        for source in (self.synthesis, self.variations, self.live, self.file_controller, self.autosave,
                       self.pin_stamp_requests, self.large_render):
            source.status.connect(self.show_status)
            source.error.connect(self.report_error)
        for message in (self.examples.load_failed, self.styles.style_load_failed,
                        self.pins_stamps.stamp_source_failed):
            message.connect(lambda text: self.report_error("Cannot read DEM", text))
        self.examples.item_unreadable.connect(lambda text: self.show_status(text, 30_000))
        self.canvas.notice.connect(lambda text: self.show_status(text, 10_000))
        self.styles.style_selected.connect(self.canvas.set_current_style)
        # A DEM read in the background may change the run's cell size (the finest).
        self.examples.info_loaded.connect(lambda _info: self.params.show_output())
        self.examples.info_loaded.connect(lambda _info: self.styles.show_style_texts())
        self.canvas.pin_requested.connect(self.pin_stamp_requests.add_pin_at)
        self.canvas.stamp_requested.connect(self.pin_stamp_requests.place_stamp)
        self.pin_stamp_requests.stamp_placed.connect(self.docks["pins_stamps_dock"].raise_)

        s = self.synthesis
        s.running_changed.connect(self.actions.cancel.setEnabled)
        s.run_started.connect(self._begin_run)
        s.patch_placed.connect(self.heightmap.paste_patch)
        s.patch_placed.connect(self.view3d.paste_patch)
        s.landform_preview.connect(self.heightmap.paste_patch)
        s.landform_preview.connect(self.view3d.paste_patch)
        s.failed.connect(self._show_document_result)
        s.cancelled.connect(self._show_document_result)

        v = self.variations
        v.started.connect(self._open_variations_dialog)
        v.running_changed.connect(
            lambda running: self.actions.variations.setText("Making variations…" if running else "Make variations…"))
        # Heavy work of their own: the live preparation gives them the cores.
        v.started.connect(lambda _seeds: self.live.stop_preparation())
        self.large_render.started.connect(self.live.stop_preparation)

        self.heightmap.hovered.connect(self._hovered)
        self.canvas.hovered.connect(self._hovered)
        self.heightmap.water_fix_requested.connect(self.lower_water_level)
        self.heightmap.link_check.toggled.connect(self.view_link.set_enabled)
        self.heightmap.connected_water_check.toggled.connect(lambda _on: self._show_water())
        self.document.sketch.changed.connect(lambda _bbox: self._water_timer.start())

        self.file_controller.example_map_opened.connect(self._example_map_opened)
        self.file_controller.export_finished.connect(self.export_finished)
        self.document.changed.connect(self._document_changed)

    # -- synthesis and variations --------------------------------------------------------------
    def synthesize(self) -> None:
        """Start a run with the document as it is now (cancelling a running one)."""
        self.synthesis.synthesize()

    def cancel_synthesis(self) -> None:
        self.synthesis.cancel()

    def _begin_run(self, info) -> None:
        for view in (self.heightmap, self.view3d):
            view.begin_run(info.shape, cell_size=info.cell_size, vrange=info.vrange, base=info.base)

    def _show_document_result(self, *_args) -> None:
        self.heightmap.show_result(self.document.result)
        self.view3d.show_result(self.document.result)
        self._show_water()

    # -- water, hover ----------------------------------------------------------------------------
    def _show_water(self) -> None:
        """Draw the water at the document's level in both views and warn
        about land below it (only with painted water: the engine touches
        nothing otherwise)."""
        doc = self.document
        level = doc.water_level if doc.sketch.has_water else None
        painted = np.asarray(doc.sketch.water) if self.heightmap.connected_water_check.isChecked() else None
        self.heightmap.set_water(level, document_drowning(doc), painted=painted)
        self.view3d.set_water_level(level, painted=painted)

    def lower_water_level(self) -> None:
        """The banner's fix: the highest level that drowns no land of the
        current terrain, then a new run with it."""
        drowning = document_drowning(self.document)
        if drowning is None:
            return
        self.document.set_water_level(drowning.safe_level)
        self.show_status(f"Water level lowered to {drowning.safe_level:g} m; synthesizing again", 10_000)
        self.synthesize()

    def _hovered(self, row: int, col: int) -> None:
        self.run_status.show_readout(cell_readout(self.document, row, col) if row >= 0 else None)

    def make_variations(self, count: int | None = None) -> None:
        """Make ``count`` variations with new seeds (asked when None) and show them as they come."""
        if count is None:
            count, ok = QInputDialog.getInt(self, "Make variations", "How many variations?", 4, *VARIATION_COUNTS)
            if not ok:
                return
        self.variations.make(count)

    def _open_variations_dialog(self, seeds) -> None:
        if self.variations_dialog is not None:
            self.variations_dialog.close()  # cancels its batch, if still running
            self.variations_dialog.deleteLater()  # and stops following the controller
        self.variations_dialog = VariationsDialog(seeds, self)
        self.variations_dialog.follow(self.variations)
        self.variations_dialog.show()

    def render_large(self) -> LargeRenderDialog:
        """Show the *Render large* dialog (one per window)."""
        if self.large_render_dialog is None:
            self.large_render_dialog = LargeRenderDialog(self.large_render, str(Path.home() / "terrain_large.tif"),
                                                         self)
        self.large_render_dialog.show()
        self.large_render_dialog.raise_()
        return self.large_render_dialog

    # -- export and screenshots -----------------------------------------------------------------
    def export_terrain(self) -> None:
        self.files.export_terrain(screenshot=self.save_screenshot)

    def save_screenshot(self, path: str | None = None) -> None:
        """Save the 3D view as a PNG (the 3D tab is shown to start it)."""
        self.result_tabs.setCurrentWidget(self.view3d)
        if not self.view3d.start():
            self.report_error("No 3D view", self.view3d.unavailable_reason)
            return
        if path is None:
            path, _ = QFileDialog.getSaveFileName(self, "Save 3D screenshot", "terrain_3d.png", "PNG (*.png)")
            if not path:
                return
        try:
            self.view3d.screenshot(path)
        except (OSError, RuntimeError) as exc:
            self.report_error("Cannot save screenshot", str(exc))
            return
        self.show_status(f"Saved {path}", 5000)

    # -- messages -------------------------------------------------------------------------------
    def show_status(self, message: str, msecs: int = 0) -> None:
        self.statusBar().showMessage(message, msecs)

    def report_error(self, title: str, message: str) -> None:
        """Show an error in the status bar and a dialog."""
        log.info("%s: %s", title, message)
        self.statusBar().showMessage(message, 30_000)
        QMessageBox.critical(self, title, message)

    # -- document events ------------------------------------------------------------------------
    def _document_changed(self, what: str) -> None:
        if what == "result":
            self._show_document_result()
        elif what == "water_level":
            self._show_water()
        elif what in ("path", "dirty"):
            self._update_title()

    def _update_title(self) -> None:
        self.setWindowTitle(f"{APP_NAME} - {self.document.title}[*]")
        self.setWindowModified(self.document.dirty)

    def _example_map_opened(self, key: str) -> None:
        self.docks["regions_dock"].raise_()
        self.example_map_opened.emit(key)

    # -- closing --------------------------------------------------------------------------------
    def closeEvent(self, event) -> None:
        if not self.files.maybe_save():
            event.ignore()
            return
        self.autosave.stop()
        self.synthesis.wait()
        self.live.wait()
        self.variations.wait()
        self.large_render.wait()
        self.autosave.discard()
        if self.view3d.plotter is not None:
            self.view3d.plotter.close()
        event.accept()
