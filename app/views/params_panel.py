"""The synthesis parameters, one widget per field of ``SynthesisParams``."""

from __future__ import annotations

import secrets
from dataclasses import replace

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDoubleSpinBox, QFormLayout, QLabel, QPushButton,
                               QSpinBox, QWidget)

from terrasynth_core.errors import ParamsError
from terrasynth_core.exemplars.patch_size import DEFAULT_PATCH
from terrasynth_core.synthesis import SynthesisParams

from ..model import MAX_SEED
from ..model.document import Document
from .panel_widgets import error_label, hbox

_TIPS = {
    "patch_size": "Side of a square patch in output cells (the paper uses 80). Larger patches copy "
                  "bigger landforms; smaller ones follow the sketch more closely. Auto: 80, or down to 32 "
                  "when an example holds too few distinct ridges or valleys at 80 (the run says so).",
    "overlap": "Width of the band a fill patch shares with its neighbours, in cells. "
               "Auto is a third of the patch, as in the paper.",
    "k": "Candidates kept after the cheap ranking; the final pick among them adds the overlap "
         "mismatch and the seam cost. More is slower and usually smoother.",
    "seed": "Seeds every random choice: the same seed and inputs give the same terrain.",
    "order": "Feature patch order: breadth-first along the sketch's feature tree (the paper) "
             "or top-to-bottom raster.",
    "seam": "cut: a graph-cut seam through the overlap (Kwatra 2003); paste: the new patch simply "
            "covers the overlap (for comparison).",
    "blend": "Seam removal: poisson (the paper's Poisson solve), c1 (also carries the slope across "
             "the seam) or none.",
    "mirror": "Also consider the mirror image of each example feature patch.",
    "drainage": "Shape the finished terrain so painted valleys drain to an outlet (the border, water or "
                "their lowest end) and no stream cuts a painted ridge.",
    "landform": "First synthesize the sketch on a grid 2-4 times coarser, where a patch spans whole "
                "landforms, and build the detail on that terrain: structure larger than a patch. Off: one "
                "pass on a flat level per style, as in the paper.",
    "coarse_factor": "Down-sampling of the example for the fast search of fill patches; the best "
                     "positions are refined at full resolution. auto: from the example's size.",
    "workers": "Processes that fill windows; 0 uses every core (the terrain is the same).",
    "feature_weight": "Weight of the feature deformation cost against the overlap mismatch when "
                      "picking feature patches.",
    "cell_size": "Side of the output's square cells on the ground, in metres. Every example, style and "
                 "stamp is resampled to it once, so features keep their true size and slopes. auto: the "
                 "finest example's; a larger size is faster and avoids up-sampling coarse examples.",
}


class ParamsPanel(QWidget):
    """Edits the document's :class:`SynthesisParams`; invalid combinations are
    shown in red and not applied.

    Signals
    -------
    params_rejected(str)
        The widgets hold an invalid combination; carries the core's message.
    """

    params_rejected = Signal(str)

    def __init__(self, document: Document, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.document = document
        self._updating = False
        form = QFormLayout(self)

        self.patch_size_auto = QCheckBox("auto")
        self.patch_size = QSpinBox(minimum=16, maximum=512, suffix=" cells")
        patch_row = hbox(self.patch_size_auto, (self.patch_size, 1))
        self.overlap_auto = QCheckBox("auto")
        self.overlap = QSpinBox(minimum=2, maximum=256, suffix=" cells")
        overlap_row = hbox(self.overlap_auto, (self.overlap, 1))
        self.k = QSpinBox(minimum=1, maximum=64)
        self.seed = QSpinBox(minimum=0, maximum=MAX_SEED)
        self.randomize_button = QPushButton("Randomize")
        self.randomize_button.setToolTip("Pick a new random seed")
        self.randomize_button.clicked.connect(self.randomize_seed)
        seed_row = hbox((self.seed, 1), self.randomize_button)
        self.order = QComboBox()
        self.order.addItems(["bfs", "raster"])
        self.seam = QComboBox()
        self.seam.addItems(["cut", "paste"])
        self.blend = QComboBox()
        self.blend.addItems(["poisson", "c1", "none"])
        self.mirror = QCheckBox("use mirrored patches")
        self.drainage = QCheckBox("valleys drain, ridges divide, basins open")
        self.drainage.setToolTip("Painted valleys descend to an outlet, painted ridges are not cut by a stream, "
                                 "and the closed basins the patches leave are breached (painted ridges kept)")
        self.landform = QCheckBox("coarse landform pass first")
        self.coarse_factor = QSpinBox(minimum=0, maximum=8, specialValueText="auto")
        self.workers = QSpinBox(minimum=0, maximum=256, specialValueText="all cores")
        self.feature_weight = QDoubleSpinBox(minimum=0.0, maximum=100.0, singleStep=0.1, decimals=2)
        # 0 is "auto" (SynthesisParams.cell_size None).
        self.cell_size = QDoubleSpinBox(minimum=0.0, maximum=100_000.0, singleStep=10.0, decimals=1,
                                        specialValueText="auto (finest example)", suffix=" m")
        self.output_label = QLabel()
        self.error_label = error_label()

        for label, widget, name in (
            ("Patch size", patch_row, "patch_size"),
            ("Overlap", overlap_row, "overlap"),
            ("Candidates (k)", self.k, "k"),
            ("Seed", seed_row, "seed"),
            ("Order", self.order, "order"),
            ("Seam", self.seam, "seam"),
            ("Blend", self.blend, "blend"),
            ("Mirror", self.mirror, "mirror"),
            ("Drainage", self.drainage, "drainage"),
            ("Landforms", self.landform, "landform"),
            ("Coarse factor", self.coarse_factor, "coarse_factor"),
            ("Workers", self.workers, "workers"),
            ("Feature weight", self.feature_weight, "feature_weight"),
            ("Cell size (m)", self.cell_size, "cell_size"),
        ):
            form.addRow(label, widget)
            tip = _TIPS[name]
            form.labelForField(widget).setToolTip(tip)
            for child in ([widget] if isinstance(widget, QWidget) else
                          [widget.itemAt(i).widget() for i in range(widget.count())]):
                if child is not None and not child.toolTip():
                    child.setToolTip(tip)
        form.addRow("Output", self.output_label)
        form.addRow(self.error_label)

        for spin in (self.patch_size, self.overlap, self.k, self.seed, self.coarse_factor, self.workers):
            spin.valueChanged.connect(self._apply)
        self.feature_weight.valueChanged.connect(self._apply)
        self.cell_size.valueChanged.connect(self._apply)
        for combo in (self.order, self.seam, self.blend):
            combo.currentTextChanged.connect(self._apply)
        for check in (self.patch_size_auto, self.overlap_auto, self.mirror, self.drainage, self.landform):
            check.toggled.connect(self._apply)

        self._show(document.params)
        self.show_output()
        document.changed.connect(self._document_changed)
        document.sketch.changed.connect(self._sketch_changed)

    # -- document to widgets -------------------------------------------------------------------
    def _document_changed(self, what: str) -> None:
        if what in ("params", "result"):
            self._show(self.document.params)
        if what in ("params", "examples", "styles", "stamps"):
            self.show_output()

    def _show(self, params: SynthesisParams) -> None:
        self._updating = True
        try:
            self.patch_size_auto.setChecked(params.patch_size is None)
            # Automatic: the size the terrain on show was made with, else
            # where the choice starts.
            made = None if self.document.result is None else self.document.result.patch_size
            self.patch_size.setValue(params.patch_size or made or DEFAULT_PATCH)
            self.patch_size.setEnabled(params.patch_size is not None)
            self.overlap_auto.setChecked(params.overlap is None)
            # (Shown for the patch in the box when the patch size is automatic.)
            self.overlap.setValue(replace(params, patch_size=self.patch_size.value()).overlap_cells)
            self.overlap.setEnabled(params.overlap is not None)
            self.k.setValue(params.k)
            self.seed.setValue(min(params.seed, MAX_SEED))
            self.order.setCurrentText(params.order)
            self.seam.setCurrentText(params.seam)
            self.blend.setCurrentText(params.blend)
            self.mirror.setChecked(params.mirror)
            self.drainage.setChecked(params.drainage)
            self.landform.setChecked(params.landform)
            self.coarse_factor.setValue(params.coarse_factor)
            self.workers.setValue(params.workers)
            self.feature_weight.setValue(params.feature_weight)
            self.cell_size.setValue(params.cell_size or 0.0)
        finally:
            self._updating = False
        self.error_label.clear()

    def _sketch_changed(self, bbox) -> None:
        if bbox is None:  # the whole sketch was replaced, maybe resized
            self.show_output()

    def show_output(self) -> None:
        rows, cols = self.document.output_shape
        cell = self.document.cell_size()
        cells = "cells" if cell is None else f"cells of {cell:.3g} m"
        self.output_label.setText(f"{rows} x {cols} {cells} (the sketch's size)")

    # -- widgets to document ----------------------------------------------------------------------
    def values(self) -> dict:
        """The widgets' values as ``SynthesisParams`` keyword arguments."""
        return {
            "patch_size": None if self.patch_size_auto.isChecked() else self.patch_size.value(),
            "overlap": None if self.overlap_auto.isChecked() else self.overlap.value(),
            "k": self.k.value(),
            "seed": self.seed.value(),
            "order": self.order.currentText(),
            "seam": self.seam.currentText(),
            "blend": self.blend.currentText(),
            "mirror": self.mirror.isChecked(),
            "drainage": self.drainage.isChecked(),
            "landform": self.landform.isChecked(),
            "coarse_factor": self.coarse_factor.value(),
            "workers": self.workers.value(),
            "feature_weight": self.feature_weight.value(),
            "cell_size": self.cell_size.value() or None,
        }

    def _apply(self) -> None:
        if self._updating:
            return
        self.overlap.setEnabled(not self.overlap_auto.isChecked())
        self.patch_size.setEnabled(not self.patch_size_auto.isChecked())
        try:
            params = SynthesisParams(**self.values())
        except ParamsError as exc:
            self.error_label.setText(str(exc))
            self.params_rejected.emit(str(exc))
            return
        self.error_label.clear()
        self.document.set_params(params)

    def randomize_seed(self) -> None:
        """Set a new random seed (applied to the document at once)."""
        self.seed.setValue(secrets.randbelow(MAX_SEED + 1))
