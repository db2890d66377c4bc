"""The 2D view of the terrain: shaded heights, water, live patches, result overlays.

Water is every cell below the water level, blue by depth (what the terrain
will show once exported under a water surface), redrawn as the level moves;
a banner over the image says how much land lies below it.  The height
legend, the banner, the feature legend and the placeholder float over the
image, so showing them never moves the image or the checkboxes.

During a run each placed patch is pasted into a GUI-side buffer of heights;
a timer (about 25 times a second) hands the windows round the patches pasted
since its last tick to a pool thread, which recolours them from a copy, and
the image is pushed to the screen when they come back.  Recolouring on the
GUI thread, patch by patch, let a burst of queued patches hold the event loop
for a tenth of a second: each of its dozen numpy calls gives the GIL to the
run's threads and waits to get it back.
"""

from __future__ import annotations

import logging

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QPointF, QThreadPool, QTimer, Signal
from PySide6.QtGui import QColor, QPen
from PySide6.QtWidgets import QCheckBox, QGraphicsRectItem, QToolBar, QVBoxLayout, QWidget

from terrasynth_core.pictures import height_range, patch_colours, ringed, shaded_relief, shaded_window, water_rgba

from ..controllers import FeatureGraphController
from ..model.result import TerrainResult
from ..workers import run_in_background
from .feature_overlay import FeatureGraphOverlay, legend_text
from .mask_overlay import MaskOverlay
from .overlay_widgets import HeightLegend, WarningBanner, note_label, pin_overlay

log = logging.getLogger(__name__)

#: What the view says before there is a terrain.
PLACEHOLDER = "Press Synthesize to make a terrain"

#: Screen refresh period during a run, in ms.
REFRESH_MS = 40


class HeightmapView(QWidget):
    """Shaded relief of the live or last synthesized terrain.

    Parameters
    ----------
    terrain_graph : FeatureGraphController
        Hands over the ridges and valleys of the document's terrain.

    Signals
    -------
    refreshed()
        The image on screen was updated from the buffer.
    result_shown()
        A finished terrain (or none) is fully drawn, overlays included.
    terrain_features_ready(object)
        Ridges and valleys extracted from the shown result.
    hovered(int, int)
        The mouse is over cell ``(row, col)``; ``(-1, -1)`` when it left
        the terrain.
    water_fix_requested()
        The banner's first button: lower the water level so no land drowns.
    """

    refreshed = Signal()
    result_shown = Signal()
    terrain_features_ready = Signal(object)
    hovered = Signal(int, int)
    water_fix_requested = Signal()

    def __init__(self, terrain_graph: FeatureGraphController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.terrain_graph = terrain_graph
        self.heights: np.ndarray | None = None  # GUI-side buffer, NaN = not yet synthesized
        self._rgba: np.ndarray | None = None
        self._rgba_result: TerrainResult | None = None  # the finished result _rgba shows, if any
        self._cell_size: tuple[float, float] | None = None
        self._vrange = (0.0, 1.0)
        self._result: TerrainResult | None = None
        self.water_level: float | None = None  # None: no painted water, none drawn
        self._painted: np.ndarray | None = None  # given: only water connected to it is drawn
        self._dirty = False
        # The windows the next tick recolours (r0, r1, c0, c1, patch cells in it).
        self._unshaded: list[tuple[int, int, int, int, int]] = []
        self._shading = False  # a pool thread is recolouring windows of the live run
        # Its own thread: on the global pool the live image would wait behind
        # long jobs (a live preparation builds indexes for seconds).
        self._shading_pool = QThreadPool(self, maxThreadCount=1)
        # Bumped by every new result or run; late images of an older one are
        # dropped.
        self._features_generation = 0
        self.last_bbox: tuple[int, int, int, int] | None = None
        self.patches_pasted = 0

        self.view = pg.GraphicsView()
        self.view.setBackground((40, 40, 40))
        self.view_box = pg.ViewBox(invertY=True, lockAspect=True, enableMenu=False)
        self.view.setCentralItem(self.view_box)
        self.image = pg.ImageItem()
        self.view_box.addItem(self.image)
        self.water_image = pg.ImageItem()
        self.water_image.setZValue(3)
        self.view_box.addItem(self.water_image)
        self.patch_image = pg.ImageItem(opacity=0.45)
        self.seam_image = pg.ImageItem()
        for z, item in enumerate((self.patch_image, self.seam_image), start=5):
            item.setZValue(z)
            item.setVisible(False)
            self.view_box.addItem(item)
        self.sketch_overlay = FeatureGraphOverlay(self.view_box)
        self.terrain_overlay = FeatureGraphOverlay(self.view_box)
        self.mask_overlay = MaskOverlay(self.view_box)
        self.outline = QGraphicsRectItem()
        pen = QPen(QColor(255, 235, 0), 2)
        pen.setCosmetic(True)
        self.outline.setPen(pen)
        self.outline.setZValue(50)
        self.outline.setVisible(False)
        self.view_box.addItem(self.outline)
        self.view.scene().sigMouseMoved.connect(self._mouse_moved)

        self.overlay_checks: dict[str, QCheckBox] = {}
        # A tool bar: what does not fit goes behind its "»" button, so the
        # checkboxes never set the panel's minimum width.
        bar = QToolBar("Overlays")
        self.link_check = QCheckBox("Linked", checked=True,
                                    toolTip="Zoom and pan the sketch and the 2D terrain together")
        bar.addWidget(self.link_check)
        bar.addSeparator()
        for name, text, tip in (
            ("patch_ids", "Patches", "Colour each cell by the patch it came from"),
            ("seams", "Seams", "Mark the graph-cut seams between patches"),
            ("sketch_features", "Sketch graph", "The ridge and valley graph the run followed"),
            ("terrain_features", "Terrain graph", "Ridges and valleys extracted from the result"),
        ):
            check = QCheckBox(text, toolTip=tip)
            check.toggled.connect(self._update_overlays)
            self.overlay_checks[name] = check
            bar.addWidget(check)
        self.connected_water_check = QCheckBox(
            "Connected water", toolTip="Draw as water only the cells below the level that connect to painted "
                                       "water (else every cell below the level)")
        bar.addWidget(self.connected_water_check)
        bar.addWidget(self.mask_overlay.combo)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.view, 1)
        layout.addWidget(bar)

        self.placeholder = pin_overlay(note_label(PLACEHOLDER), self.view, "centre")
        self.legend = pin_overlay(note_label(legend_text()), self.view, "bottom_left")
        self.legend.setVisible(False)
        self.height_legend = pin_overlay(HeightLegend(), self.view, "bottom_right")
        self.banner = pin_overlay(WarningBanner(), self.view, "top")
        self.banner.fix_clicked.connect(self._banner_fix)

        self._timer = QTimer(self, interval=REFRESH_MS)
        self._timer.timeout.connect(self._refresh)
        terrain_graph.ready.connect(self._terrain_features_done)
        terrain_graph.failed.connect(self._terrain_features_failed)

    # -- live run ---------------------------------------------------------------------------
    def begin_run(self, shape: tuple[int, int], *, cell_size: tuple[float, float] | None,
                  vrange: tuple[float, float], base: np.ndarray | None = None) -> None:
        """Start showing a new run on an empty canvas of ``shape``.

        ``vrange`` (metres) fixes the colours for the run, so pasting a patch
        never needs recolouring the whole image.  ``base`` (float32, shape
        ``shape``) is the terrain a re-synthesis starts from, shown under the
        new patches; default an empty canvas.  When ``base`` is the terrain on
        screen, its image and colours are kept (no recolouring).
        """
        reshaped = self.heights is None or self.heights.shape != tuple(shape)
        self._features_generation += 1
        if base is None:
            self.heights = np.full(shape, np.nan, np.float32)
            self._rgba = np.zeros(tuple(shape) + (4,), np.uint8)
        elif self._rgba_result is not None and self._rgba_result.heights is base:
            self.heights = np.array(base, dtype=np.float32)
            self._rgba = self._rgba.copy()
            vrange = self._vrange
        else:
            self.heights = np.array(base, dtype=np.float32)
            self._rgba = shaded_relief(self.heights, cell_size=cell_size, vrange=vrange)
        self._rgba_result = None
        self._cell_size = cell_size
        self._vrange = vrange
        self.last_bbox = None
        self._unshaded = []
        self.patches_pasted = 0
        self.outline.setVisible(False)
        self.placeholder.setVisible(False)
        self.water_image.setVisible(False)
        self.banner.show_warning(None)  # it spoke of the terrain this run replaces
        self.height_legend.set_range(vrange, self.water_level)
        for item in (self.patch_image, self.seam_image):
            item.setVisible(False)
        self.sketch_overlay.set_visible(False)
        self.terrain_overlay.set_visible(False)
        self.mask_overlay.set_result(None)
        self._dirty = True
        self._refresh()
        if reshaped:
            self.view_box.autoRange(padding=0.02)
        self._timer.start()

    def paste_patch(self, event) -> None:
        """Paste a core ``PatchPlaced`` event (or a ``LandformProgress`` preview) into the buffer and outline it."""
        if self.heights is None:
            return
        r0, r1, c0, c1 = event.bbox
        self.heights[r0:r1, c0:c1] = event.heights
        # The window and a one-cell ring need recolouring (the ring's slopes
        # changed too); the next tick has every window since the last recoloured.
        self._unshaded = _joined(self._unshaded, ringed(event.bbox, self.heights.shape))
        self.outline.setRect(c0, r0, c1 - c0, r1 - r0)
        self.outline.setVisible(True)
        self.last_bbox = (r0, r1, c0, c1)
        self.patches_pasted += 1

    def end_run(self) -> None:
        """Stop live refreshing (the result or the previous one is shown next)."""
        self._timer.stop()
        self._unshaded = []
        self.outline.setVisible(False)

    def _refresh(self) -> None:
        if self._unshaded and not self._shading and self._timer.isActive():
            self._shade_in_background()
        if not self._dirty or self._rgba is None:
            return
        self._dirty = False
        self.image.setImage(self._rgba, autoLevels=False, levels=None)
        self.refreshed.emit()

    def _shade_in_background(self) -> None:
        """Recolour the windows pasted since the last tick on a pool thread,
        from a copy of their heights (and the one-cell margin their slopes
        read): the run goes on pasting into the buffer meanwhile."""
        pieces = []
        for r0, r1, c0, c1, _cells in self._unshaded:
            R0, R1, C0, C1 = ringed((r0, r1, c0, c1), self.heights.shape)
            pieces.append(((r0, r1, c0, c1), self.heights[R0:R1, C0:C1].copy(), (r0 - R0, r1 - R0, c0 - C0, c1 - C0)))
        self._unshaded = []
        self._shading = True
        generation, cell_size, vrange = self._features_generation, self._cell_size, self._vrange

        def shade():
            return generation, [(bbox, shaded_window(copy, inner, cell_size=cell_size, vrange=vrange))
                                for bbox, copy, inner in pieces]

        run_in_background(shade, self._shaded, self._shading_failed, pool=self._shading_pool)

    def _shaded(self, value) -> None:
        self._shading = False
        generation, windows = value
        if generation != self._features_generation or not self._timer.isActive():
            return  # the run ended or another began: its own image is shown
        for (r0, r1, c0, c1), rgba in windows:
            self._rgba[r0:r1, c0:c1] = rgba
        self._dirty = True
        self._refresh()

    def _shading_failed(self, message: str) -> None:
        self._shading = False
        log.error("recolouring the live terrain failed: %s", message)

    # -- result ----------------------------------------------------------------------------
    def show_result(self, result: TerrainResult | None) -> None:
        """Show a finished terrain with its overlays (None shows nothing).

        The heights buffer is set at once; the shaded image and overlay
        images of a large terrain take a while to compute, so they are made
        on the thread pool and :attr:`result_shown` tells when they are up.
        """
        self.end_run()
        self._result = result
        self.mask_overlay.set_result(result)
        self._features_generation += 1
        self.terrain_overlay.set_maps(None)
        self.patch_image.clear()
        self.seam_image.clear()
        if result is None:
            self.heights = None
            self._rgba = None
            self._rgba_result = None
            self.image.clear()
            self.water_image.clear()
            self.placeholder.setVisible(True)
            self.height_legend.set_range(None)
            self._update_overlays()
            self.result_shown.emit()
            return
        self.heights = result.heights  # never written: a new run makes a new buffer
        self._cell_size = result.cell_size
        self._vrange = height_range(result.heights)
        self.placeholder.setVisible(False)
        self._draw_water()
        self.sketch_overlay.set_maps(result.sketch_features)
        self._update_overlays()
        generation = self._features_generation
        run_in_background(lambda: (generation, result_images(result, self._vrange)), self._result_images_ready,
                          self._result_images_failed)

    def _result_images_ready(self, value) -> None:
        generation, (rgba, patches, seams) = value
        if generation != self._features_generation:
            return  # another result or run came meanwhile
        reshaped = self._rgba is None or self._rgba.shape != rgba.shape
        self._rgba = rgba
        self._rgba_result = self._result
        self._dirty = True
        self._refresh()
        self.patch_image.setImage(patches, autoLevels=False, levels=None)
        self.seam_image.setImage(seams, autoLevels=False, levels=None)
        if reshaped:
            self.view_box.autoRange(padding=0.02)
        self._update_overlays()
        self.result_shown.emit()

    # -- water, hover ----------------------------------------------------------------------
    def set_water(self, level: float | None, drowning=None, *, painted: np.ndarray | None = None) -> None:
        """Draw water below ``level`` metres (None: no painted water, no
        water drawn), only where it connects to ``painted`` when given,
        and warn about ``drowning``, a
        :class:`~terrasynth_app.model.water_check.Drowning` or None."""
        self.water_level = level
        self._painted = painted
        self._draw_water()
        if drowning is None or self._timer.isActive():  # (a run replaces the terrain it speaks of)
            self.banner.show_warning(None)
            return
        fixes = (f"Lower to {drowning.safe_level:g} m and synthesize",)
        if painted is None:
            fixes += ("Draw only connected water",)
        self.banner.show_warning(drowning.message(connected_only=painted is not None), fixes)

    def _banner_fix(self, index: int) -> None:
        if index == 0:
            self.water_fix_requested.emit()
        else:
            self.connected_water_check.setChecked(True)

    def _draw_water(self) -> None:
        finished = self._result is not None and not self._timer.isActive()
        if self.water_level is None or not finished:
            self.water_image.clear()
            self.water_image.setVisible(False)
        else:
            self.water_image.setImage(water_rgba(self._result.heights, self.water_level, painted=self._painted),
                                      autoLevels=False, levels=None)
            self.water_image.setVisible(True)
        if self.heights is not None:
            self.height_legend.set_range(self._vrange, self.water_level)

    def water_cells(self) -> int:
        """Cells drawn as water now."""
        if not self.water_image.isVisible() or self.water_image.image is None:
            return 0
        return int((self.water_image.image[..., 3] > 0).sum())

    def _mouse_moved(self, scene_pos: QPointF) -> None:
        if self.heights is None or not self.view_box.sceneBoundingRect().contains(scene_pos):
            self.hovered.emit(-1, -1)
            return
        point = self.view_box.mapSceneToView(scene_pos)
        row, col = int(np.floor(point.y())), int(np.floor(point.x()))
        rows, cols = self.heights.shape
        self.hovered.emit(*((row, col) if 0 <= row < rows and 0 <= col < cols else (-1, -1)))

    def leaveEvent(self, event) -> None:
        super().leaveEvent(event)
        self.hovered.emit(-1, -1)

    def _result_images_failed(self, message: str) -> None:
        self.legend.setText(f"Cannot draw the terrain: {message}")
        self.legend.setVisible(True)

    def overlay_enabled(self, name: str) -> bool:
        return self.overlay_checks[name].isChecked()

    def set_overlay(self, name: str, on: bool) -> None:
        self.overlay_checks[name].setChecked(on)

    def _update_overlays(self) -> None:
        have = self._result is not None and self._timer.isActive() is False
        self.patch_image.setVisible(have and self.overlay_enabled("patch_ids"))
        self.seam_image.setVisible(have and self.overlay_enabled("seams"))
        self.sketch_overlay.set_visible(have and self.overlay_enabled("sketch_features"))
        terrain = have and self.overlay_enabled("terrain_features")
        self.terrain_overlay.set_visible(terrain)
        self.legend.setVisible(have and (self.overlay_enabled("sketch_features") or terrain))
        if terrain and self.terrain_overlay.maps is None:
            self._extract_terrain_features()

    def _extract_terrain_features(self) -> None:
        self.terrain_graph.request()

    def _terrain_features_done(self, maps) -> None:
        if self._result is None or self._timer.isActive():
            return  # a run started meanwhile; the next result asks again
        self.terrain_overlay.set_maps(maps)
        self.terrain_features_ready.emit(maps)

    def _terrain_features_failed(self, message: str) -> None:
        self.legend.setText(f"Terrain features unavailable: {message}")
        self.legend.setVisible(True)


def result_images(result: TerrainResult, vrange: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shaded terrain, patch-id colours and seam marks of a result, RGBA uint8 each."""
    rgba = shaded_relief(result.heights, cell_size=result.cell_size, vrange=vrange)
    seams = np.zeros(result.shape + (4,), np.uint8)
    seams[result.seam_mask] = (255, 40, 40, 230)
    return rgba, patch_colours(result.patch_id), seams


def _joined(windows: list[tuple[int, int, int, int, int]], new: tuple[int, int, int, int],
            cells: int | None = None) -> list[tuple[int, int, int, int, int]]:
    """``windows`` (r0, r1, c0, c1, cells of the patches in it) with the
    window ``new`` (r0, r1, c0, c1, holding ``cells`` patch cells, default
    its area) added: joined to the first it lies near (their bounding window
    at most twice their patches' cells), so a burst of neighbouring patches
    is recoloured in one go, while patches far apart (or along a diagonal)
    are not recoloured with the whole map between them."""
    if cells is None:
        cells = (new[1] - new[0]) * (new[3] - new[2])
    for i, w in enumerate(windows):
        both = min(w[0], new[0]), max(w[1], new[1]), min(w[2], new[2]), max(w[3], new[3])
        if (both[1] - both[0]) * (both[3] - both[2]) <= 2 * (w[4] + cells):
            return _joined(windows[:i] + windows[i + 1:], both, w[4] + cells)
    return windows + [(*new, cells)]
