"""The main window: sketch, examples, parameters, live 2D and 3D terrain.

The window only wires things together: the document holds the state, the
panels translate user actions into document edits, and a
:class:`~terrasynth_app.workers.SynthesisRunner` runs the core off the GUI
thread.  Every error a worker reports lands in a dialog and the status bar;
a failed or cancelled run leaves the previous result and the sketch as they
were.  A re-synthesis of the selection runs the same way and replaces the
terrain only when it finishes; variations run in worker processes behind a
:class:`~terrasynth_app.workers.VariationsRunner` and are shown in a dialog.
"""

from __future__ import annotations

import logging
import secrets
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from PySide6.QtCore import QSettings, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import (QDockWidget, QFileDialog, QFrame, QInputDialog, QLabel, QMainWindow, QMessageBox,
                               QProgressBar, QScrollArea, QSplitter, QTabWidget)

from terrasynth_core.errors import TerraSynthError
from terrasynth_core.features import read_sketch, save_sketch
from terrasynth_core.io import READ_EXTENSIONS, load_dem
from terrasynth_core.pictures import height_range

from ..model.controls import StampSpec, fitting_scale
from ..model.dem_features import dem_feature_layers
from ..model.document import Document, SynthesisRequest
from ..model.example_maps import EXAMPLE_MAPS, example_map_document
from ..model.export import export_terrain
from ..model.project import PROJECT_EXTENSION, load_project, save_project
from ..model.recovery import RecoveryStore
from ..model.region_maps import style_layer_from_png, water_layer_from_png
from ..model.result import TerrainResult
from ..workers import SynthesisRunner, VariationsRunner, run_in_background
from .dialogs import NewSketchDialog
from .example_panel import ExamplePanel
from .export_dialog import ExportDialog
from .heightmap_view import HeightmapView
from .params_panel import MAX_SEED, ParamsPanel
from .pin_stamp_panel import PinStampPanel
from .sketch_canvas import SketchCanvas
from .style_panel import HEIGHT_LIMITS, StylePanel
from .terrain_view_3d import TerrainView3D
from .variations_dialog import VariationsDialog

log = logging.getLogger(__name__)

APP_NAME = "TerraSynth"
#: Autosave period while there are unsaved changes, in ms.
AUTOSAVE_MS = 30_000
#: Shortest period between progress bar updates, in ms.
PROGRESS_MS = 100
RECENT_KEY = "recent_files"
MAX_RECENT = 8
_PROJECT_FILTER = f"TerraSynth projects (*{PROJECT_EXTENSION})"
#: Variations a batch may have.
VARIATION_COUNTS = (2, 8)


@dataclass(frozen=True, eq=False)
class RunInfo:
    """What the views need before the first patch arrives (made on the worker)."""

    shape: tuple[int, int]
    cell_size: tuple[float, float] | None
    vrange: tuple[float, float]
    base: np.ndarray | None = None  # the terrain a re-synthesis starts from


def run_info(request: SynthesisRequest) -> RunInfo:
    """Cell size of the first example and the colour range of the run: the
    terrain being re-synthesized, or the examples' and styles' joint height
    range."""
    fields = request.source_fields()
    if request.previous is not None:
        return RunInfo(request.shape, fields[0].cell_size, height_range(request.previous), request.previous)
    low = min([f.min for f in fields] + [s.base for s in request.styles if s.base is not None])
    high = max([f.max for f in fields] + [s.base for s in request.styles if s.base is not None])
    # Patches are shifted to match their neighbours, so the output may leave
    # the examples' range a little; a margin keeps its tints from clipping.
    margin = 0.1 * (high - low)
    return RunInfo(request.shape, fields[0].cell_size, (low - margin, high + margin))


def new_seeds(count: int) -> list[int]:
    """``count`` distinct random seeds the seed box can show."""
    seeds: list[int] = []
    while len(seeds) < count:
        seed = secrets.randbelow(MAX_SEED + 1)
        if seed not in seeds:
            seeds.append(seed)
    return seeds


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

    Signals
    -------
    export_finished(str)
        A file was exported; carries its path.
    example_map_opened(str)
        A built-in example map became the document; carries its key.
    """

    export_finished = Signal(str)
    example_map_opened = Signal(str)

    def __init__(self, document: Document | None = None, *, settings: QSettings | None = None,
                 recovery: RecoveryStore | None = None, autosave_ms: int = AUTOSAVE_MS) -> None:
        super().__init__()
        self.document = document if document is not None else Document.default()
        self.settings = settings if settings is not None else QSettings(APP_NAME, APP_NAME)
        self.recovery = recovery
        self.runner = SynthesisRunner(self)
        self.variations_runner = VariationsRunner(self)
        self.variations_dialog: VariationsDialog | None = None
        self._run_info: RunInfo | None = None
        self._run_started = 0.0
        self._progress: tuple[int, int] | None = None  # (done, total) not shown yet
        self._progress_timer = QTimer(self, singleShot=True, interval=PROGRESS_MS)
        self._progress_timer.timeout.connect(self._show_progress)
        self._autosaved_generation = -1
        self.resize(1500, 900)

        self.canvas = SketchCanvas(self.document.sketch, document=self.document)
        self.heightmap = HeightmapView()
        self.view3d = TerrainView3D()
        self.result_tabs = QTabWidget()
        self.result_tabs.addTab(self.heightmap, "2D terrain")
        self.result_tabs.addTab(self.view3d, "3D terrain")
        splitter = QSplitter(Qt.Horizontal)
        splitter.addWidget(self.canvas)
        splitter.addWidget(self.result_tabs)
        splitter.setSizes([650, 650])
        self.setCentralWidget(splitter)

        self.examples = ExamplePanel(self.document)
        self.params = ParamsPanel(self.document)
        self.styles = StylePanel(self.document)
        self.pins_stamps = PinStampPanel(self.document)
        self.docks: dict[str, QDockWidget] = {}
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
            self.docks[name] = dock
        self.addDockWidget(Qt.LeftDockWidgetArea, self.docks["examples_dock"])
        self.addDockWidget(Qt.LeftDockWidgetArea, self.docks["params_dock"])
        # The control panels share the examples' and parameters' places, as tabs.
        self.tabifyDockWidget(self.docks["examples_dock"], self.docks["regions_dock"])
        self.tabifyDockWidget(self.docks["params_dock"], self.docks["pins_stamps_dock"])
        self.docks["examples_dock"].raise_()
        self.docks["params_dock"].raise_()

        self.stage_label = QLabel("Ready")
        self.progress = QProgressBar(maximumWidth=260, textVisible=True)
        self.progress.setFormat("%v / %m patches")
        self.progress.setValue(0)
        self.time_label = QLabel("")
        self.statusBar().addPermanentWidget(self.stage_label)
        self.statusBar().addPermanentWidget(self.progress)
        self.statusBar().addPermanentWidget(self.time_label)

        self._build_actions()
        self._connect_runner()
        self._connect_variations()
        self.document.changed.connect(self._document_changed)
        self.examples.load_failed.connect(self._example_failed)
        self.examples.item_unreadable.connect(self._example_unreadable)
        self.styles.style_selected.connect(self.canvas.set_current_style)
        self.styles.style_load_failed.connect(self._example_failed)
        self.pins_stamps.stamp_source_failed.connect(self._example_failed)
        self.canvas.pin_requested.connect(self.add_pin_at)
        self.canvas.stamp_requested.connect(self.place_stamp)
        self.canvas.notice.connect(lambda message: self.statusBar().showMessage(message, 10_000))
        self._update_title()
        self.heightmap.show_result(self.document.result)
        self.view3d.show_result(self.document.result)

        self._autosave_timer = QTimer(self, interval=autosave_ms)
        self._autosave_timer.timeout.connect(self.autosave)
        if self.recovery is not None:
            self._autosave_timer.start()

    # -- actions and menus ------------------------------------------------------------------------
    def _action(self, text: str, slot, *, shortcut=None, tip: str = "") -> QAction:
        action = QAction(text, self, toolTip=tip or text, statusTip=tip)
        if shortcut is not None:
            action.setShortcut(shortcut)
        action.triggered.connect(slot)
        return action

    def _build_actions(self) -> None:
        self.synthesize_action = self._action("Synthesize", self.synthesize, shortcut=QKeySequence("Ctrl+R"),
                                              tip="Synthesize a terrain from the sketch and examples (Ctrl+R)")
        self.cancel_action = self._action("Cancel", self.cancel_synthesis, tip="Stop the running synthesis")
        self.cancel_action.setEnabled(False)
        self.randomize_action = self._action("Randomize seed", self.params.randomize_seed,
                                             tip="Pick a new random seed")
        self.resynthesize_action = self._action(
            "Re-synthesize selection", self.resynthesize_selection, shortcut=QKeySequence("Ctrl+Shift+R"),
            tip="Synthesize the selected cells again with a new seed; the rest of the terrain stays as it is")
        self.variations_action = self._action("Make variations…", lambda: self.make_variations(),
                                              tip="Synthesize several terrains with different seeds and pick one")
        self.export_action = self._action("Export terrain…", self.export_terrain, shortcut=QKeySequence("Ctrl+E"),
                                          tip="Write the terrain as a DEM or a mesh")
        new_project = self._action("New project", self.new_project, shortcut=QKeySequence.New)
        open_project = self._action("Open project…", lambda: self.open_project(), shortcut=QKeySequence.Open)
        self.save_action = self._action("Save project", self.save, shortcut=QKeySequence.Save)
        save_as = self._action("Save project as…", self.save_as, shortcut=QKeySequence.SaveAs)
        new_sketch = self._action("New sketch…", self.new_sketch, tip="Start an empty sketch of a chosen size")
        open_sketch = self._action("Open sketch PNG…", lambda: self.open_sketch(),
                                   tip="Red strokes are ridges, blue strokes valleys")
        save_sketch_action = self._action("Save sketch PNG…", lambda: self.save_sketch())
        import_features = self._action("Import DEM features as sketch…", lambda: self.import_dem_features(),
                                       tip="Trace the ridges and valleys of a DEM into the sketch")
        import_styles = self._action("Import style regions PNG…", lambda: self.import_style_regions(),
                                     tip="Paint the style layer from a PNG with one flat colour per style: each "
                                         "colour goes to the style of the nearest colour")
        import_water = self._action("Import water mask PNG…", lambda: self.import_water_mask(),
                                    tip="Paint the water layer from a PNG: dark paint on a light ground is water")
        self.example_map_actions = {
            key: self._action(title, lambda _=False, key=key: self.open_example_map(key),
                              tip=f"Open the built-in {title} map: styles, water, stamp and pins, "
                                  "ready to synthesize")
            for key, title in EXAMPLE_MAPS.items()}
        quit_action = self._action("Quit", self.close, shortcut=QKeySequence.Quit)

        file_menu = self.menuBar().addMenu("&File")
        for action in (new_project, open_project):
            file_menu.addAction(action)
        self.recent_menu = file_menu.addMenu("Open recent")
        self._update_recent_menu()
        file_menu.addMenu("Open example map").addActions(list(self.example_map_actions.values()))
        file_menu.addActions([self.save_action, save_as])
        file_menu.addSeparator()
        file_menu.addActions([new_sketch, open_sketch, save_sketch_action, import_features])
        file_menu.addActions([import_styles, import_water])
        file_menu.addSeparator()
        file_menu.addAction(self.export_action)
        file_menu.addSeparator()
        file_menu.addAction(quit_action)

        edit_menu = self.menuBar().addMenu("&Edit")
        edit_menu.addActions([self.canvas.undo_action, self.canvas.redo_action, self.canvas.clear_action])
        synth_menu = self.menuBar().addMenu("&Synthesis")
        synth_menu.addActions([self.synthesize_action, self.cancel_action, self.randomize_action])
        synth_menu.addSeparator()
        synth_menu.addActions([self.resynthesize_action, self.variations_action])

        toolbar = self.addToolBar("Main")
        toolbar.setObjectName("main_toolbar")
        toolbar.addActions([self.synthesize_action, self.cancel_action, self.randomize_action,
                            self.resynthesize_action, self.variations_action, self.export_action])

    # -- synthesis ------------------------------------------------------------------------------------
    def _connect_runner(self) -> None:
        r = self.runner
        r.session_ready.connect(self._session_ready)
        r.stage_started.connect(self._stage_started)
        r.patch_placed.connect(self._patch_placed)
        r.synthesis_finished.connect(self._synthesis_finished)
        r.synthesis_failed.connect(self._synthesis_failed)
        r.synthesis_cancelled.connect(self._synthesis_cancelled)
        r.running_changed.connect(self._running_changed)

    def synthesize(self) -> None:
        """Start a run with the document as it is now (cancelling a running one)."""
        try:
            request = self.document.synthesis_request()
        except TerraSynthError as exc:
            self.report_error("Cannot synthesize", str(exc))
            return
        self._start(request)

    def resynthesize_selection(self) -> None:
        """Synthesize the selected cells again with a new random seed; the
        new terrain replaces the current one when (and only if) it finishes."""
        try:
            request = self.document.resynthesis_request(seed=new_seeds(1)[0])
        except TerraSynthError as exc:
            self.report_error("Cannot re-synthesize", str(exc))
            return
        self._start(request)

    def _start(self, request: SynthesisRequest) -> None:
        self.stage_label.setText("Reading examples…")
        self.progress.setRange(0, 0)  # busy until the first stage says how many patches
        self.time_label.clear()
        self.runner.start(request.make_session, lambda: run_info(request))

    def cancel_synthesis(self) -> None:
        self.runner.cancel()
        self.stage_label.setText("Cancelling…")

    def _session_ready(self, info: RunInfo) -> None:
        self._run_info = info
        self._run_started = time.perf_counter()
        self.heightmap.begin_run(info.shape, cell_size=info.cell_size, vrange=info.vrange, base=info.base)
        self.view3d.begin_run(info.shape, cell_size=info.cell_size, vrange=info.vrange, base=info.base)

    def _stage_started(self, stage: str, total: int) -> None:
        names = {"analyse": "Analysing the sketch", "features": "Placing feature patches",
                 "fill": "Filling the rest", "finish": "Finishing"}
        self.stage_label.setText(names.get(stage, stage))

    def _patch_placed(self, event) -> None:
        self.heightmap.paste_patch(event)
        self.view3d.paste_patch(event)
        self._progress = (event.index + 1, event.total)
        if not self._progress_timer.isActive():
            self._progress_timer.start()

    def _show_progress(self) -> None:
        # QProgressBar.setValue repaints at once; with an OpenGL widget in the
        # window every repaint composites the whole window, so progress is
        # shown at most PROGRESS_MS apart rather than once per patch.
        if self._progress is None:
            return
        done, total = self._progress
        self._progress = None
        self.progress.setRange(0, max(total, done))
        self.progress.setValue(done)
        elapsed = time.perf_counter() - self._run_started
        left = elapsed / done * max(total - done, 0)
        self.time_label.setText(f"about {left:.0f} s left" if left >= 1 else "almost done")

    def _synthesis_finished(self, result) -> None:
        self._progress_timer.stop()
        self._progress = None
        cell_size = self._run_info.cell_size if self._run_info is not None else None
        terrain = TerrainResult.from_synthesis(result, cell_size=cell_size)
        self.progress.setValue(self.progress.maximum())
        self.time_label.setText(f"{result.total_seconds:.1f} s")
        self.document.set_result(terrain)
        warnings = "; ".join(result.warnings)
        self.stage_label.setText("Done")
        what = (f"Re-synthesized {int(result.selection.sum())} cells (seed {result.params.seed})"
                if result.selection is not None else f"Synthesized {terrain.shape[0]} x {terrain.shape[1]}")
        self.statusBar().showMessage(f"{what} in {result.total_seconds:.1f} s"
                                     + (f" - {warnings}" if warnings else ""), 20_000)

    def _synthesis_failed(self, message: str) -> None:
        self.stage_label.setText("Failed")
        self._restore_result()
        self.report_error("Synthesis failed", message)

    def _synthesis_cancelled(self) -> None:
        self.stage_label.setText("Cancelled")
        self.statusBar().showMessage("Synthesis cancelled; the previous terrain is shown", 10_000)
        self._restore_result()

    def _restore_result(self) -> None:
        self._progress_timer.stop()
        self._progress = None
        self.progress.setRange(0, 1)
        self.progress.setValue(0)
        self.time_label.clear()
        self.heightmap.show_result(self.document.result)
        self.view3d.show_result(self.document.result)

    def _running_changed(self, running: bool) -> None:
        self.cancel_action.setEnabled(running)

    # -- variations -----------------------------------------------------------------------------------
    def make_variations(self, count: int | None = None) -> None:
        """Make ``count`` variations with new seeds (asked when None) and show them as they come."""
        if count is None:
            count, ok = QInputDialog.getInt(self, "Make variations", "How many variations?", 4, *VARIATION_COUNTS)
            if not ok:
                return
        try:
            request = self.document.synthesis_request()
        except TerraSynthError as exc:
            self.report_error("Cannot make variations", str(exc))
            return
        seeds = new_seeds(count)
        if self.variations_dialog is not None:
            self.variations_dialog.close()
        dialog = VariationsDialog(seeds, self)
        dialog.chosen.connect(self.use_variation)
        dialog.cancel_requested.connect(self.variations_runner.cancel)
        self.variations_dialog = dialog
        self.variations_runner.start(
            lambda progress, cancel: request.make_variations(seeds, progress=progress, cancel=cancel))
        dialog.show()
        self.statusBar().showMessage(f"Making {count} variations…")

    def use_variation(self, seed: int, terrain: TerrainResult) -> None:
        """Make a variation the current terrain and its seed the document's."""
        self.document.set_params(replace(self.document.params, seed=seed))
        self.document.set_result(terrain)
        self.statusBar().showMessage(f"Using the variation with seed {seed}", 10_000)

    def _connect_variations(self) -> None:
        r = self.variations_runner
        r.variation_finished.connect(self._variation_finished)
        r.variations_finished.connect(self._variations_finished)
        r.variations_failed.connect(self._variations_failed)
        r.variations_cancelled.connect(self._variations_cancelled)
        r.running_changed.connect(self._variations_running_changed)

    def _variation_finished(self, index: int, terrain: TerrainResult) -> None:
        if self.variations_dialog is not None:
            self.variations_dialog.show_result(index, terrain)

    def _variations_finished(self, terrains) -> None:
        if self.variations_dialog is not None:
            self.variations_dialog.finish(f"{len(terrains)} variations made: pick one")
        self.statusBar().showMessage(f"{len(terrains)} variations made", 10_000)

    def _variations_failed(self, message: str) -> None:
        if self.variations_dialog is not None:
            self.variations_dialog.finish(f"Failed: {message}")
        self.report_error("Variations failed", message)

    def _variations_cancelled(self) -> None:
        if self.variations_dialog is not None:
            self.variations_dialog.finish("Cancelled")
        self.statusBar().showMessage("Variations cancelled", 10_000)

    def _variations_running_changed(self, running: bool) -> None:
        self.variations_action.setText("Making variations…" if running else "Make variations…")

    # -- pins and stamps ---------------------------------------------------------------------------------
    def add_pin_at(self, row: int, col: int) -> None:
        """Ask the height for a pin at ``(row, col)`` (the terrain's height
        there by default) and add it."""
        result = self.document.result
        if result is not None and result.shape == self.document.output_shape:
            default = float(result.heights[row, col])
        elif self.document.height_range is not None:
            default = sum(self.document.height_range) / 2
        else:
            default = 0.0
        height, ok = QInputDialog.getDouble(self, "Elevation pin", f"Height of cell ({row}, {col}) in metres:",
                                            round(default, 1), *HEIGHT_LIMITS, 1)
        if not ok:
            return
        try:
            self.document.add_pin(row, col, height)
        except TerraSynthError as exc:
            self.report_error("Cannot add the pin", str(exc))

    def place_stamp(self, row: float, col: float) -> None:
        """Place the stamp DEM chosen in the Pins and stamps panel centred on ``(row, col)``."""
        source = self.pins_stamps.stamp_source
        if source is None:
            self.statusBar().showMessage("Choose the DEM to stamp in the Pins and stamps panel first "
                                         "(or wait until it is read)", 10_000)
            return
        ref, shape = source
        try:
            self.document.add_stamp(StampSpec(ref, (row, col), shape,
                                              scale=fitting_scale(shape, self.document.output_shape)))
        except TerraSynthError as exc:
            self.report_error("Cannot place the stamp", str(exc))
            return
        self.docks["pins_stamps_dock"].raise_()

    # -- errors ------------------------------------------------------------------------------------------
    def report_error(self, title: str, message: str) -> None:
        """Show an error in the status bar and a dialog."""
        log.info("%s: %s", title, message)
        self.statusBar().showMessage(message, 30_000)
        QMessageBox.critical(self, title, message)

    def _example_failed(self, message: str) -> None:
        self.report_error("Cannot read DEM", message)

    def _example_unreadable(self, message: str) -> None:
        self.statusBar().showMessage(message, 30_000)

    # -- document events -------------------------------------------------------------------------------
    def _document_changed(self, what: str) -> None:
        if what == "result":
            self.heightmap.show_result(self.document.result)
            self.view3d.show_result(self.document.result)
        elif what in ("path", "dirty"):
            self._update_title()

    def _update_title(self) -> None:
        self.setWindowTitle(f"{APP_NAME} - {self.document.title}[*]")
        self.setWindowModified(self.document.dirty)

    # -- sketch files -------------------------------------------------------------------------------------
    def new_sketch(self) -> None:
        dialog = NewSketchDialog(self.document.sketch.shape, self)
        if dialog.exec():
            shape = dialog.shape
            self.document.sketch.replace(np.zeros(shape, np.uint8), np.zeros(shape, np.uint8))

    def open_sketch(self, path: str | None = None) -> None:
        if path is None:
            path, _ = QFileDialog.getOpenFileName(self, "Open sketch", "", "Sketch PNG (*.png)")
            if not path:
                return
        try:
            sketch_map = read_sketch(path)
        except TerraSynthError as exc:
            self.report_error("Cannot open sketch", str(exc))
            return
        self.document.sketch.replace_with_map(sketch_map)
        self.statusBar().showMessage(f"Opened sketch {path}", 5000)

    def save_sketch(self, path: str | None = None) -> None:
        if path is None:
            path, _ = QFileDialog.getSaveFileName(self, "Save sketch", "sketch.png", "Sketch PNG (*.png)")
            if not path:
                return
        try:
            save_sketch(self.document.sketch.to_sketch_map(), path)
        except TerraSynthError as exc:
            self.report_error("Cannot save sketch", str(exc))
            return
        self.statusBar().showMessage(f"Saved sketch {path}", 5000)

    def import_dem_features(self, path: str | None = None) -> None:
        if path is None:
            patterns = " ".join(f"*{ext}" for ext in READ_EXTENSIONS)
            path, _ = QFileDialog.getOpenFileName(self, "Import DEM features", "", f"DEM files ({patterns})")
            if not path:
                return
        shape = self.document.sketch.shape
        self.statusBar().showMessage(f"Tracing ridges and valleys of {path}…")
        run_in_background(lambda: dem_feature_layers(load_dem(path), shape), self._features_imported,
                          self._features_import_failed)

    def _features_imported(self, layers) -> None:
        self.document.sketch.replace(*layers)
        self.statusBar().showMessage("Imported the DEM's ridges and valleys as a sketch (undo reverts)", 8000)

    def _features_import_failed(self, message: str) -> None:
        self.report_error("Cannot import DEM features", message)

    # -- region maps -------------------------------------------------------------------------------------
    def import_style_regions(self, path: str | None = None) -> None:
        """Replace the style layer with a style-region PNG (one undo step)."""
        if path is None:
            path, _ = QFileDialog.getOpenFileName(self, "Import style regions", "", "Style regions (*.png)")
            if not path:
                return
        doc = self.document
        try:
            layer = style_layer_from_png(path, doc.styles, doc.output_shape)
        except TerraSynthError as exc:
            self.report_error("Cannot import style regions", str(exc))
            return
        doc.sketch.replace_regions(style=layer)
        unstyled = float((layer < 0).mean())
        self.statusBar().showMessage(
            f"Imported style regions from {path}" + (f"; {100 * unstyled:.0f} % of the cells match no style's "
                                                     "colour and use the plain examples" if unstyled else ""),
            10_000)

    def import_water_mask(self, path: str | None = None) -> None:
        """Replace the water layer with a water-mask PNG (one undo step)."""
        if path is None:
            path, _ = QFileDialog.getOpenFileName(self, "Import water mask", "", "Water mask (*.png)")
            if not path:
                return
        try:
            layer = water_layer_from_png(path, self.document.output_shape)
        except TerraSynthError as exc:
            self.report_error("Cannot import water mask", str(exc))
            return
        self.document.sketch.replace_regions(water=layer)
        self.statusBar().showMessage(f"Imported the water mask {path}: {100 * layer.mean():.0f} % water", 10_000)

    # -- projects ---------------------------------------------------------------------------------------
    def maybe_save(self) -> bool:
        """Ask about unsaved changes; False when the user cancels."""
        if not self.document.dirty:
            return True
        answer = QMessageBox.question(
            self, APP_NAME, f"Save the changes to {self.document.title}?",
            QMessageBox.Save | QMessageBox.Discard | QMessageBox.Cancel, QMessageBox.Save)
        if answer == QMessageBox.Save:
            return self.save()
        return answer == QMessageBox.Discard

    def new_project(self) -> None:
        if self.maybe_save():
            self.runner.cancel()
            self.document.assign(Document.default())

    def open_example_map(self, key: str) -> None:
        """Make the built-in map ``key`` the document (after asking about
        unsaved changes); it is read on the thread pool and
        :attr:`example_map_opened` follows."""
        if not self.maybe_save():
            return
        self.statusBar().showMessage(f"Reading the {EXAMPLE_MAPS[key]} example map…")
        run_in_background(lambda: (key, example_map_document(key)), self._example_map_read,
                          self._example_map_failed)

    def _example_map_read(self, value) -> None:
        key, document = value
        self.runner.cancel()
        self.document.assign(document)
        self.docks["regions_dock"].raise_()
        self.statusBar().showMessage(f"Opened the {EXAMPLE_MAPS[key]} example map: press Synthesize", 10_000)
        self.example_map_opened.emit(key)

    def _example_map_failed(self, message: str) -> None:
        self.report_error("Cannot open the example map", message)

    def open_project(self, path: str | None = None) -> bool:
        if not self.maybe_save():
            return False
        if path is None:
            path, _ = QFileDialog.getOpenFileName(self, "Open project", "", _PROJECT_FILTER)
            if not path:
                return False
        try:
            loaded = load_project(path)
        except TerraSynthError as exc:
            self.report_error("Cannot open project", str(exc))
            return False
        self.runner.cancel()
        self.document.assign(loaded)
        self._add_recent(path)
        self.statusBar().showMessage(f"Opened {path}", 5000)
        return True

    def save(self) -> bool:
        if self.document.path is None:
            return self.save_as()
        return self.save_to(self.document.path)

    def save_as(self) -> bool:
        path, _ = QFileDialog.getSaveFileName(self, "Save project", f"terrain{PROJECT_EXTENSION}", _PROJECT_FILTER)
        if not path:
            return False
        if not path.endswith(PROJECT_EXTENSION):
            path += PROJECT_EXTENSION
        return self.save_to(path)

    def save_to(self, path) -> bool:
        """Write the project to ``path``; errors go to a dialog (returns False)."""
        try:
            save_project(self.document, path)
        except TerraSynthError as exc:
            self.report_error("Cannot save project", str(exc))
            return False
        if self.recovery is not None:
            self.recovery.discard()
        self._add_recent(str(path))
        self.statusBar().showMessage(f"Saved {path}", 5000)
        return True

    # -- recent files -------------------------------------------------------------------------------------
    def recent_files(self) -> list[str]:
        value = self.settings.value(RECENT_KEY, [])
        if isinstance(value, str):  # QSettings returns a lone string for a one-item list
            value = [value]
        return [str(v) for v in value or []]

    def _add_recent(self, path: str) -> None:
        path = str(Path(path).resolve())
        files = [path] + [p for p in self.recent_files() if p != path]
        self.settings.setValue(RECENT_KEY, files[:MAX_RECENT])
        self._update_recent_menu()

    def _update_recent_menu(self) -> None:
        self.recent_menu.clear()
        files = self.recent_files()
        for path in files:
            action = self.recent_menu.addAction(Path(path).name)
            action.setToolTip(path)
            action.setData(path)
            action.triggered.connect(self._open_recent)
        self.recent_menu.setEnabled(bool(files))

    def _open_recent(self) -> None:
        self.open_project(self.sender().data())

    # -- export ------------------------------------------------------------------------------------------
    def export_terrain(self) -> None:
        result = self.document.result
        if result is None:
            self.report_error("Nothing to export", "Synthesize a terrain first.")
            return
        folder = str(self.document.path.parent) if self.document.path is not None else ""
        dialog = ExportDialog(result.shape, directory=folder, parent=self)
        dialog.screenshot_requested.connect(self.save_screenshot)
        if not dialog.exec():
            return
        options = dialog.options()
        path = options.pop("path")
        self.statusBar().showMessage(f"Exporting {path}…")
        run_in_background(lambda: str(export_terrain(result, path, **options)), self._exported,
                          self._export_failed)

    def _exported(self, path: str) -> None:
        self.statusBar().showMessage(f"Exported {path}", 8000)
        self.export_finished.emit(path)

    def _export_failed(self, message: str) -> None:
        self.report_error("Export failed", message)

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
        self.statusBar().showMessage(f"Saved {path}", 5000)

    # -- autosave and recovery ------------------------------------------------------------------------------
    def autosave(self) -> None:
        """Write unsaved work to the recovery file, on the thread pool."""
        if self.recovery is None or not self.document.dirty:
            return
        if self.document.generation == self._autosaved_generation:
            return
        self._autosaved_generation = self.document.generation
        snapshot = self.document.snapshot()
        recovery = self.recovery
        run_in_background(lambda: recovery.save(snapshot), self._autosaved, self._autosave_failed)

    def _autosaved(self, _value) -> None:
        self.statusBar().showMessage("Autosaved", 2000)

    def _autosave_failed(self, message: str) -> None:
        self.statusBar().showMessage(f"Autosave failed: {message}", 10_000)

    def offer_recovery(self) -> bool:
        """If a previous session left unsaved work, offer to restore it; True if restored."""
        if self.recovery is None or not self.recovery.exists():
            return False
        answer = QMessageBox.question(self, APP_NAME, f"{self.recovery.describe()}.\nRecover it?",
                                      QMessageBox.Yes | QMessageBox.No, QMessageBox.Yes)
        if answer != QMessageBox.Yes:
            self.recovery.discard()
            return False
        try:
            self.document.assign(self.recovery.load())
        except TerraSynthError as exc:
            self.report_error("Cannot recover", str(exc))
            return False
        return True

    # -- closing --------------------------------------------------------------------------------------------
    def closeEvent(self, event) -> None:
        if not self.maybe_save():
            event.ignore()
            return
        self._autosave_timer.stop()
        self.runner.wait()
        self.variations_runner.wait()
        if self.recovery is not None:
            self.recovery.discard()
        if self.view3d.plotter is not None:
            self.view3d.plotter.close()
        event.accept()

