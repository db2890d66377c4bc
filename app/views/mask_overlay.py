"""A preview of one mask (splat map) over the 2D view, before exporting them.

The masks made from the heights (slope, curvature, flow, wetness, height
bands, normal map) are computed on the thread pool exactly as
:func:`~terrasynth_app.model.export_masks` writes them and drawn
translucent over the shaded terrain.  Water and style regions are not
offered: the sketch canvas already shows what was painted.
"""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import QComboBox

from terrasynth_core.pictures import mask_picture

from ..model.export import mask_preview
from ..model.result import TerrainResult
from ..workers import run_in_background

#: Masks offered, with their menu text.
PREVIEW_MASKS = {"slope": "Slope", "convex": "Convex", "concave": "Concave", "flow": "Flow",
                 "wetness": "Wetness", "height_bands": "Height bands", "normal": "Normal map"}

#: Opacity of the mask over the terrain.
OPACITY = 0.8


class MaskOverlay(QObject):
    """A "Mask" chooser and the image it draws in a view box.

    Parameters
    ----------
    view_box : pyqtgraph.ViewBox
        Where the mask is drawn, above the terrain and under the graphs.

    Signals
    -------
    mask_shown(str)
        The chosen mask is drawn (its name; "" when none is).
    """

    mask_shown = Signal(str)

    def __init__(self, view_box: pg.ViewBox) -> None:
        super().__init__(view_box)
        self.combo = QComboBox(toolTip="Preview a mask of the terrain, as Export for… > Masks writes it")
        self.combo.addItem("No mask", "")
        for name, text in PREVIEW_MASKS.items():
            self.combo.addItem(text, name)
        self.combo.currentIndexChanged.connect(self._update)
        self.image = pg.ImageItem(opacity=OPACITY)
        self.image.setZValue(4)
        self.image.setVisible(False)
        view_box.addItem(self.image)
        self._result: TerrainResult | None = None
        self._generation = 0  # bumped by every new result or choice; late masks are dropped

    @property
    def name(self) -> str:
        """The chosen mask, "" for none."""
        return self.combo.currentData()

    def set_result(self, result: TerrainResult | None) -> None:
        """Preview the chosen mask of ``result`` (None: a run started, hide it)."""
        self._result = result
        self._update()

    def _update(self) -> None:
        self._generation += 1
        self.image.setVisible(False)
        name, result = self.name, self._result
        if not name or result is None:
            self.mask_shown.emit("")
            return
        generation = self._generation
        run_in_background(lambda: (generation, name, mask_picture(mask_preview(result, name))), self._ready,
                          self._failed)

    def _ready(self, value) -> None:
        generation, name, rgb = value
        if generation != self._generation:
            return
        self.image.setImage(np.ascontiguousarray(rgb), autoLevels=False, levels=(0, 255))
        self.image.setVisible(True)
        self.mask_shown.emit(name)

    def _failed(self, message: str) -> None:
        self.combo.setToolTip(f"Cannot preview the mask: {message}")
        self.mask_shown.emit("")
