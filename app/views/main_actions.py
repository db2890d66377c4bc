"""The main window's actions, menus and toolbar."""

from __future__ import annotations

from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QMainWindow

from ..model import EXAMPLE_MAPS
from .export_dialog import EXPORT_FOR


class MainActions:
    """Builds the window's actions and puts them in its menus and toolbar.

    Parameters
    ----------
    window : MainWindow
        Its controllers, panels and :class:`~.file_actions.FileActions`
        provide the slots.

    Attributes
    ----------
    synthesize, live, cancel, randomize, resynthesize, variations, export, save : QAction
        ``live`` is checkable: live sketching on or off.
    example_maps : dict of str -> QAction
        One per built-in example map.
    export_for : dict of str -> QAction
        "Export for…" one engine preset each, and the masks.
    """

    def __init__(self, window: QMainWindow) -> None:
        self.window = window
        files, synthesis = window.files, window.synthesis
        self.synthesize = self._action("Synthesize", synthesis.synthesize, shortcut=QKeySequence("Ctrl+R"),
                                       tip="Synthesize a terrain from the sketch and examples (Ctrl+R)")
        self.live = self._action(
            "Live", window.live.set_enabled, shortcut=QKeySequence("Ctrl+L"),
            tip="Live sketching (Ctrl+L): after a run, each finished stroke, erase or undo re-synthesizes the "
                "terrain near it; Synthesize still makes the whole terrain again")
        self.live.setCheckable(True)
        self.live.setChecked(window.live.enabled)
        window.live.enabled_changed.connect(self.live.setChecked)
        self.cancel = self._action("Cancel", window.cancel_synthesis, tip="Stop the running synthesis")
        self.cancel.setEnabled(False)
        self.randomize = self._action("Randomize seed", window.params.randomize_seed, tip="Pick a new random seed")
        self.resynthesize = self._action(
            "Re-synthesize selection", synthesis.resynthesize_selection, shortcut=QKeySequence("Ctrl+Shift+R"),
            tip="Synthesize the selected cells again with a new seed; the rest of the terrain stays as it is")
        self.variations = self._action("Make variations…", lambda: window.make_variations(),
                                       tip="Synthesize several terrains with different seeds and pick one")
        self.export = self._action("Export terrain…", window.export_terrain, shortcut=QKeySequence("Ctrl+E"),
                                   tip="Write the terrain as a DEM or a mesh")
        self.render_large = self._action("Render large…", window.render_large,
                                         tip="Render the sketch at a world size (8k, 16k…) as tiles on Dask, in the "
                                             "background, to a GeoTIFF")
        self.export_for = {
            key: self._action(f"{title}…", lambda _=False, key=key: files.export_for(key),
                              tip="Heightmaps sized and scaled for this tool, with its import settings"
                              if key != "masks" else "Slope, curvature, flow, wetness, water, height bands, "
                                                     "normal map and style regions")
            for key, title in EXPORT_FOR.items()}
        new_project = self._action("New project", files.new_project, shortcut=QKeySequence.New)
        open_project = self._action("Open project…", lambda: files.open_project(), shortcut=QKeySequence.Open)
        self.save = self._action("Save project", files.save, shortcut=QKeySequence.Save)
        save_as = self._action("Save project as…", files.save_as, shortcut=QKeySequence.SaveAs)
        new_sketch = self._action("New sketch…", files.new_sketch, tip="Start an empty sketch of a chosen size")
        open_sketch = self._action("Open sketch PNG…", lambda: files.open_sketch(),
                                   tip="Red strokes are ridges, blue strokes valleys")
        save_sketch = self._action("Save sketch PNG…", lambda: files.save_sketch())
        import_features = self._action("Import DEM features as sketch…", lambda: files.import_dem_features(),
                                       tip="Trace the ridges and valleys of a DEM into the sketch")
        import_styles = self._action("Import style regions PNG…", lambda: files.import_style_regions(),
                                     tip="Paint the style layer from a PNG with one flat colour per style: each "
                                         "colour goes to the style of the nearest colour")
        import_water = self._action("Import water mask PNG…", lambda: files.import_water_mask(),
                                    tip="Paint the water layer from a PNG: dark paint on a light ground is water")
        self.example_maps = {
            key: self._action(title, lambda _=False, key=key: files.open_example_map(key),
                              tip=f"Open the built-in {title} map: styles, water, stamp and pins, "
                                  "ready to synthesize")
            for key, title in EXAMPLE_MAPS.items()}
        quit_action = self._action("Quit", window.close, shortcut=QKeySequence.Quit)

        file_menu = window.menuBar().addMenu("&File")
        file_menu.addActions([new_project, open_project])
        files.recent_menu = file_menu.addMenu("Open recent")
        files.update_recent_menu()
        file_menu.addMenu("Open example map").addActions(list(self.example_maps.values()))
        file_menu.addActions([self.save, save_as])
        file_menu.addSeparator()
        file_menu.addActions([new_sketch, open_sketch, save_sketch, import_features, import_styles, import_water])
        file_menu.addSeparator()
        file_menu.addAction(self.export)
        file_menu.addMenu("Export for…").addActions(list(self.export_for.values()))
        file_menu.addAction(self.render_large)
        file_menu.addSeparator()
        file_menu.addAction(quit_action)

        canvas = window.canvas
        window.menuBar().addMenu("&Edit").addActions([canvas.undo_action, canvas.redo_action, canvas.clear_action])
        synth_menu = window.menuBar().addMenu("&Synthesis")
        synth_menu.addActions([self.synthesize, self.live, self.cancel, self.randomize])
        synth_menu.addSeparator()
        synth_menu.addActions([self.resynthesize, self.variations])

        toolbar = window.addToolBar("Main")
        toolbar.setObjectName("main_toolbar")
        toolbar.addActions([self.synthesize, self.live, self.cancel, self.randomize, self.resynthesize, self.variations,
                            self.export])

    def _action(self, text: str, slot, *, shortcut=None, tip: str = "") -> QAction:
        action = QAction(text, self.window, toolTip=tip or text, statusTip=tip)
        if shortcut is not None:
            action.setShortcut(shortcut)
        action.triggered.connect(slot)
        return action
