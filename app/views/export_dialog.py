"""The export dialogs: every DEM format and mesh, with size and vertical scale;
and "Export for…": engine presets (Unreal, Unity, Godot, Blender, Houdini)
and masks, each into a folder."""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDialog, QDialogButtonBox, QDoubleSpinBox, QFileDialog,
                               QFormLayout, QHBoxLayout, QLabel, QLineEdit, QPushButton, QSpinBox, QWidget)

from terrasynth_core.export import MASK_FORMATS, PRESETS
from terrasynth_core.export.engines import default_size
from terrasynth_core.io import MESH_EXTENSIONS

from ..model.export import EXPORT_EXTENSIONS

_NAMES = {
    ".tif": "GeoTIFF, float32", ".tiff": "GeoTIFF, float32", ".asc": "ESRI ASCII grid",
    ".png": "16-bit PNG + JSON sidecar", ".npy": "NumPy float32 + JSON sidecar", ".ter": "Terragen",
    ".r16": "RAW 16-bit + JSON sidecar", ".r32": "RAW 32-bit float", ".obj": "Wavefront OBJ mesh",
    ".stl": "STL mesh (binary)", ".ply": "PLY mesh (binary)", ".exr": "OpenEXR float32",
    ".glb": "glTF binary mesh (GLB)",
}


class ExportDialog(QDialog):
    """Choose file, format, size and mesh options for exporting the terrain.

    Parameters
    ----------
    shape : (rows, cols)
        The result's size, the default export size.
    directory : str
        Folder proposed for the file.

    Signals
    -------
    screenshot_requested()
        The user asked for a 3D screenshot instead.
    """

    screenshot_requested = Signal()

    def __init__(self, shape: tuple[int, int], *, directory: str = "", screenshot_available: bool = True,
                 parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Export terrain")
        self.format = QComboBox()
        for ext in EXPORT_EXTENSIONS:
            self.format.addItem(f"{_NAMES.get(ext, ext)} ({ext})", ext)
        self.path = QLineEdit(str(Path(directory or ".") / "terrain.tif"))
        browse = QPushButton("Browse…")
        browse.clicked.connect(self._browse)
        path_row = QHBoxLayout()
        path_row.addWidget(self.path, 1)
        path_row.addWidget(browse)
        self.rows = QSpinBox(minimum=2, maximum=8000, value=shape[0], suffix=" rows")
        self.cols = QSpinBox(minimum=2, maximum=8000, value=shape[1], suffix=" cols")
        size_row = QHBoxLayout()
        size_row.addWidget(self.rows)
        size_row.addWidget(self.cols)
        self.vertical_scale = QDoubleSpinBox(minimum=0.01, maximum=100.0, value=1.0, singleStep=0.5, decimals=2)
        self.vertical_scale.setToolTip("Height exaggeration of the mesh")
        self.step = QSpinBox(minimum=1, maximum=64, value=1)
        self.step.setToolTip("Keep every n-th row and column of the mesh")
        self.triangles = QSpinBox(minimum=0, maximum=100_000_000, value=0, singleStep=100_000,
                                  specialValueText="all", suffix=" triangles")
        self.triangles.setToolTip("Simplify the mesh to about this many triangles (flat ground first)")
        self.texture = QCheckBox("Height colours under the hillshade")
        self.texture.setToolTip("GLB only: drape the 2D view's picture over the mesh")
        self.screenshot_button = QPushButton("Save 3D screenshot…")
        self.screenshot_button.setEnabled(screenshot_available)
        self.screenshot_button.clicked.connect(self._screenshot)

        form = QFormLayout(self)
        form.addRow("Format", self.format)
        form.addRow("File", path_row)
        form.addRow("Size", size_row)
        form.addRow("Mesh vertical scale", self.vertical_scale)
        form.addRow("Mesh step", self.step)
        form.addRow("Mesh simplified to", self.triangles)
        form.addRow("GLB texture", self.texture)
        form.addRow(self.screenshot_button)
        buttons = QDialogButtonBox(QDialogButtonBox.Save | QDialogButtonBox.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)
        self.format.currentIndexChanged.connect(self._format_changed)
        self.path.textEdited.connect(self._path_edited)
        self._format_changed()

    def options(self) -> dict:
        """``export_terrain`` arguments: path, size, vertical_scale, step, target_triangles, texture."""
        return {
            "path": self.path.text(),
            "size": (self.rows.value(), self.cols.value()),
            "vertical_scale": self.vertical_scale.value(),
            "step": self.step.value(),
            "target_triangles": self.triangles.value() or None,
            "texture": self.texture.isEnabled() and self.texture.isChecked(),
        }

    def _format_changed(self) -> None:
        ext = self.format.currentData()
        path = Path(self.path.text())
        self.path.setText(str(path.with_suffix(ext)))
        self._enable_mesh_options(ext)

    def _enable_mesh_options(self, ext: str) -> None:
        is_mesh = ext in MESH_EXTENSIONS
        for widget in (self.vertical_scale, self.step, self.triangles):
            widget.setEnabled(is_mesh)
        self.texture.setEnabled(ext == ".glb")

    def _path_edited(self, text: str) -> None:
        index = self.format.findData(Path(text).suffix.lower())
        if index >= 0:
            self.format.blockSignals(True)
            self.format.setCurrentIndex(index)
            self.format.blockSignals(False)
            self._enable_mesh_options(self.format.currentData())

    def _browse(self) -> None:
        ext = self.format.currentData()
        path, _ = QFileDialog.getSaveFileName(self, "Export terrain", self.path.text(), f"{ext} files (*{ext})")
        if path:
            self.path.setText(path)
            self._path_edited(path)

    def _screenshot(self) -> None:
        self.screenshot_requested.emit()


#: "Export for…" entries: the engine presets, then the masks.
EXPORT_FOR: dict[str, str] = {**{key: preset.title for key, preset in PRESETS.items()},
                              "masks": "Masks (splat maps)"}

_MASK_FORMAT_NAMES = {"png8": "8-bit PNG", "png16": "16-bit PNG", "exr": "32-bit float OpenEXR"}


class PresetExportDialog(QDialog):
    """Options of "Export for…": the folder, and the preset's size and tiles
    (or the masks' format).

    Parameters
    ----------
    preset : str
        A key of :data:`EXPORT_FOR`.
    shape : (rows, cols)
        The result's size, for the default heightmap size.
    directory : str
        Folder proposed.
    """

    def __init__(self, preset: str, shape: tuple[int, int], *, directory: str = "",
                 parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.preset = preset
        self.setWindowTitle(f"Export for {EXPORT_FOR[preset]}")
        self.folder = QLineEdit(str(Path(directory or ".") / f"terrain_{preset}"))
        browse = QPushButton("Browse…")
        browse.clicked.connect(self._browse)
        folder_row = QHBoxLayout()
        folder_row.addWidget(self.folder, 1)
        folder_row.addWidget(browse)
        self.name = QLineEdit("terrain")
        self.name.setToolTip("Start of every file name")
        form = QFormLayout(self)
        form.addRow("Folder", folder_row)
        form.addRow("File names", self.name)
        self.size = QComboBox()
        self.tiles = QSpinBox(minimum=1, maximum=16, value=1)
        self.mask_format = QComboBox()
        if preset == "masks":
            for fmt in MASK_FORMATS:
                self.mask_format.addItem(_MASK_FORMAT_NAMES[fmt], fmt)
            form.addRow("Format", self.mask_format)
        else:
            chosen = PRESETS[preset]
            sizes = chosen.sizes or ()
            longest = max(shape)
            if not sizes:
                self.size.addItem(f"{longest} (as synthesized)", None)
                sizes = tuple(n for n in (257, 513, 1025, 2049, 4097) if n != longest)
            for n in sizes:
                self.size.addItem(f"{n} samples", n)
            if chosen.sizes:
                self.size.setCurrentIndex(self.size.findData(default_size(chosen, longest)))
            form.addRow("Size (longer side)" if not chosen.sizes else "Size (per tile)", self.size)
            self.tiles.setEnabled(chosen.tiles)
            self.tiles.setToolTip("A K x K grid of tiles sharing their edges, named _x{i}_y{j}")
            form.addRow("Tiles (K x K)", self.tiles)
            note = QLabel(chosen.how_to_import)
            note.setWordWrap(True)
            form.addRow(note)
        buttons = QDialogButtonBox(QDialogButtonBox.Save | QDialogButtonBox.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)

    def options(self) -> dict:
        """The folder and the options of :meth:`FilesController.export_preset`."""
        options = {"folder": self.folder.text(), "name": self.name.text() or "terrain"}
        if self.preset == "masks":
            options["fmt"] = self.mask_format.currentData()
        else:
            options["size"] = self.size.currentData()
            options["tiles"] = self.tiles.value()
        return options

    def _browse(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "Export into folder", self.folder.text())
        if folder:
            self.folder.setText(folder)
