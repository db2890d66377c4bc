"""The 3D view of the terrain (pyvistaqt), or a message where it cannot run.

The mesh is built once per output size, decimated to at most
:data:`MAX_SIDE` vertices a side; patches update its heights in place and a
timer redraws at most 10 times a second.  Rendering happens on the GUI
thread, so when the view starts it times a frame: if this OpenGL (e.g. a
software renderer) is too slow for live updates, the terrain is drawn only
when a run ends, and the view says so, rather than freezing the window.

With painted water, a translucent plane lies at the water level, moved as
the level changes.  Heights are coloured by the same ramp
(:data:`~terrasynth_core.pictures.TERRAIN_LUT`) over the same heights as
the 2D view.
"""

from __future__ import annotations

import functools
import importlib
import logging
import threading
import time

import numpy as np
from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtGui import QGuiApplication
from PySide6.QtWidgets import QDoubleSpinBox, QHBoxLayout, QLabel, QStackedLayout, QVBoxLayout, QWidget

from terrasynth_core.pictures import SHALLOW_RGB, TERRAIN_LUT, camera_direction, height_range, water_cells

from ..model.result import TerrainResult
from .overlay_widgets import ElidedLabel

log = logging.getLogger(__name__)

#: Most vertices along a side of the displayed mesh.
MAX_SIDE = 160
#: Longest frame, in ms, that still allows live updates during a run (the
#: GUI thread must never stall for 100 ms).
LIVE_FRAME_BUDGET_MS = 60.0
#: A frame this long during a run is a stall of the GUI thread; after
#: :data:`SLOW_FRAMES` in a row live 3D updates pause (frames measured at
#: start, on an idle machine, can take twice as long once a run keeps the
#: cores busy: software OpenGL shares them).
LOADED_FRAME_LIMIT_MS = 100.0
SLOW_FRAMES = 2
#: Shortest redraw period while heights change, in ms (10 redraws a second).
REDRAW_MS = 100
#: Redraws may take at most this share of the GUI thread's time; slow OpenGL
#: stretches the period instead.
MAX_RENDER_SHARE = 0.3
#: Cell size assumed when the examples do not tell one, in metres.
DEFAULT_CELL_M = 30.0
#: Camera direction of a new mesh: degrees from south towards east, and above the horizon.
CAMERA = (-30.0, 35.0)
#: Opacity of the water plane.
WATER_OPACITY = 0.6
#: Qt platforms that have no OpenGL window to render into.
_HEADLESS_PLATFORMS = {"offscreen", "minimal", "vnc"}


#: The thread importing pyvistaqt ahead (:func:`_import_ahead`), once started.
_IMPORTING: threading.Thread | None = None


@functools.cache  # (once per process, however many views are made)
def _import_ahead() -> None:
    """Import pyvistaqt (VTK) on a helper thread while the app starts: on
    the GUI thread, the first showing of the 3D view froze the window for
    1-2.5 s importing it (measured under Xvfb); now it only makes the
    widget.  A failed import is left for :meth:`TerrainView3D.start` to
    report, and a start that comes first waits on the import lock."""
    if QGuiApplication.platformName() in _HEADLESS_PLATFORMS:
        return

    def load() -> None:
        try:
            importlib.import_module("pyvistaqt")
        except Exception:  # (start() imports it again and shows why)
            pass

    global _IMPORTING
    _IMPORTING = threading.Thread(target=load, name="terrasynth-import-3d", daemon=True)
    _IMPORTING.start()



def importing_ahead() -> bool:
    """Whether the 3D view's libraries are still being imported ahead."""
    return _IMPORTING is not None and _IMPORTING.is_alive()


class TerrainView3D(QWidget):
    """A shaded 3D surface of the live or last terrain.

    The VTK widget is created the first time the view is shown; if that is
    impossible (no display, no OpenGL, pyvistaqt missing) a message takes its
    place and every method quietly only keeps the heights.

    Signals
    -------
    rendered()
        A redraw happened.
    """

    rendered = Signal()

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        _import_ahead()
        self.plotter = None  # pyvistaqt QtInteractor once started
        self._starting = False
        self.unavailable_reason: str | None = None
        self.heights: np.ndarray | None = None  # full-resolution buffer
        self._cell_size = (DEFAULT_CELL_M, DEFAULT_CELL_M)
        self._vrange = (0.0, 1.0)
        self._grid = None
        self._grid_key = None
        self._actor = None
        self._water_actor = None
        self.water_level: float | None = None
        self._painted: np.ndarray | None = None
        self._dirty = False
        self.redraws = 0

        self.message = QLabel("The 3D view starts when shown.", alignment=Qt.AlignCenter, wordWrap=True)
        self._stack = QStackedLayout()
        holder = QWidget()
        holder.setLayout(self._stack)
        self._stack.addWidget(self.message)
        self.scale_spin = QDoubleSpinBox(minimum=0.1, maximum=20.0, singleStep=0.5, value=2.0, decimals=1,
                                         suffix=" x")
        self.scale_spin.setToolTip("Vertical exaggeration of the 3D surface")
        self.scale_spin.valueChanged.connect(self._scale_changed)
        bar = QHBoxLayout()
        bar.addWidget(QLabel("Vertical scale"))
        bar.addWidget(self.scale_spin)
        # Elided: a long notice must not widen the result panel.
        self.notice = ElidedLabel(width_hint=200)
        bar.addWidget(self.notice, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(holder, 1)
        layout.addLayout(bar)

        self._timer = QTimer(self, singleShot=True, interval=REDRAW_MS)
        self._timer.timeout.connect(self._redraw)
        self.render_ms = 0.0
        self._frame_started_at = 0.0
        self._slow_frames = 0  # in a row, during a run
        self._live = False
        #: False when a frame is too slow for live updates during runs.
        self.live_updates = True

    # -- start-up ----------------------------------------------------------------------------
    @property
    def available(self) -> bool:
        return self.plotter is not None

    def showEvent(self, event) -> None:
        super().showEvent(event)
        if self.plotter is None and self.unavailable_reason is None and not self._starting:
            self.start()

    def start(self) -> bool:
        """Create the VTK widget; False (and a message shown) when it cannot run."""
        if self.plotter is not None:
            return True
        platform = QGuiApplication.platformName()
        if platform in _HEADLESS_PLATFORMS:
            return self._unavailable(f"The 3D view needs a display with OpenGL; the Qt platform "
                                     f"'{platform}' has none. The 2D view shows the terrain.")
        # Making the VTK widget shows it, which re-enters showEvent.
        self._starting = True
        try:
            from pyvistaqt import QtInteractor

            plotter = QtInteractor(self, auto_update=False)
            plotter.set_background("#2b2b2b", top="#6d7f99")
            plotter.enable_terrain_style(mouse_wheel_zooms=True)
        except Exception as exc:  # VTK reports missing OpenGL in many ways
            log.warning("3D view unavailable: %s", exc)
            return self._unavailable(f"The 3D view could not start ({type(exc).__name__}: {exc}). "
                                     "The 2D view shows the terrain.")
        finally:
            self._starting = False
        self.plotter = plotter
        # Every frame is timed, however it is asked for (a repaint, a camera move).
        plotter.ren_win.AddObserver("StartEvent", self._frame_started)
        plotter.ren_win.AddObserver("EndEvent", self._frame_ended)
        self._stack.addWidget(plotter)
        self._stack.setCurrentWidget(plotter)
        self._time_frames()
        return True

    def _time_frames(self) -> None:
        """Draw the terrain (or a flat test mesh) twice and decide whether live
        updates can keep up.

        The first frame pays for compiling shaders; the second is the typical
        cost of a redraw.
        """
        shown = self.heights
        if shown is None:
            self.heights = np.zeros((MAX_SIDE, MAX_SIDE), np.float32)
        for _ in range(2):
            self._dirty = True
            self._redraw(now=True)
        log.info("3D frame: %.0f ms", self.render_ms)
        if self.render_ms > LIVE_FRAME_BUDGET_MS:
            self._live_off(f"a frame takes {self.render_ms:.0f} ms with this OpenGL")
        if shown is None:
            self.heights = None
            self._clear_mesh()

    def _frame_started(self, _obj, _event) -> None:
        self._frame_started_at = time.perf_counter()

    def _frame_ended(self, _obj, _event) -> None:
        """Pause live updates once frames during a run stall the GUI thread."""
        if not (self._live and self.live_updates):
            return
        ms = (time.perf_counter() - self._frame_started_at) * 1000
        self._slow_frames = self._slow_frames + 1 if ms > LOADED_FRAME_LIMIT_MS else 0
        if self._slow_frames >= SLOW_FRAMES:
            self._timer.stop()
            self._live_off(f"a frame took {ms:.0f} ms while the run kept the cores busy")

    def _live_off(self, why: str) -> None:
        """No more redraws during runs (the terrain shows when a run ends), and say ``why``."""
        self.live_updates = False
        log.info("live 3D updates off: %s", why)
        self.notice.setText(f"Live 3D off: {why}; the terrain shows when a run ends.")

    def _clear_mesh(self) -> None:
        self.plotter.clear()
        self._water_actor = None
        self._grid = None
        self._grid_key = None
        self.plotter.render()

    def _unavailable(self, reason: str) -> bool:
        self.unavailable_reason = reason
        self.message.setText(reason)
        self._stack.setCurrentWidget(self.message)
        return False

    # -- data ---------------------------------------------------------------------------------
    def begin_run(self, shape: tuple[int, int], *, cell_size: tuple[float, float] | None,
                  vrange: tuple[float, float], base: np.ndarray | None = None) -> None:
        """A new run of ``shape``: start from a flat floor (or from ``base``,
        the terrain a re-synthesis changes) and redraw as patches come."""
        self.heights = np.full(shape, np.nan, np.float32) if base is None else np.array(base, dtype=np.float32)
        self._cell_size = cell_size or (DEFAULT_CELL_M, DEFAULT_CELL_M)
        self._vrange = vrange
        self._dirty = True
        self._live = True
        self._slow_frames = 0
        self._schedule()

    def paste_patch(self, event) -> None:
        """Paste a core ``PatchPlaced`` event (or a ``LandformProgress`` preview); the next timer tick redraws."""
        if self.heights is None:
            return
        r0, r1, c0, c1 = event.bbox
        self.heights[r0:r1, c0:c1] = event.heights
        self._dirty = True
        self._schedule()

    def end_run(self) -> None:
        self._timer.stop()
        self._live = False

    def show_result(self, result: TerrainResult | None) -> None:
        """Show a finished terrain (None clears the view)."""
        self.end_run()
        if result is None:
            self.heights = None
            if self.plotter is not None:
                self._clear_mesh()
            return
        self.heights = result.heights.copy()
        self._cell_size = result.cell_size or (DEFAULT_CELL_M, DEFAULT_CELL_M)
        self._vrange = height_range(result.heights)
        self._dirty = True
        self._redraw()

    def screenshot(self, path: str) -> None:
        """Save the 3D view as a PNG.

        Raises
        ------
        RuntimeError
            When the 3D view is not running.
        """
        if self.plotter is None:
            raise RuntimeError(self.unavailable_reason or "the 3D view is not running")
        self._redraw(now=True)
        self.plotter.render()  # changes since the last frame (water, camera) may be waiting for a repaint
        self.plotter.screenshot(str(path))

    def set_water_level(self, level: float | None, *, painted: np.ndarray | None = None) -> None:
        """Show water at ``level`` metres (None: none) over the cells below
        it, only those connected to ``painted`` (bool, the terrain's shape)
        when given."""
        self.water_level = level
        self._painted = painted
        self._place_water()

    def water_plane_height(self) -> float | None:
        """Height of the drawn water plane in scene units (metres times the
        vertical scale), None when none is drawn; for tests."""
        if self._water_actor is None:
            return None
        return float(self._water_actor.GetBounds()[4])

    def ramp_colour(self, height: float) -> np.ndarray:
        """RGB (0-255) the mesh gives ``height`` metres, from its lookup table; for tests."""
        rgb = np.zeros(3)
        self._actor.mapper.lookup_table.GetColor(float(height), rgb)
        return rgb * 255

    def _place_water(self, *, render: bool = True) -> None:
        """Draw the water surface: the mesh's cells whose corners lie below
        the level, flat at the level (so it ends at the shore, not at the
        map's edge under the terrain)."""
        if self.plotter is None or self._grid is None:
            return
        if self._water_actor is not None:
            self.plotter.remove_actor(self._water_actor, render=False)
            self._water_actor = None
        if self.water_level is None:
            return
        (rows, cols), step = self._grid_key[0], self._grid_key[1]
        heights = np.asarray(self._grid["elevation"]).reshape(rows, cols)
        painted = None
        if self._painted is not None and self._painted.shape == self.heights.shape:
            painted = self._painted[::step, ::step]
        wet = water_cells(heights, self.water_level, painted=painted)
        if not wet.any():
            return
        water = self._grid.copy(deep=True)
        points = water.points
        points[:, 2] = self.water_level * self.scale_spin.value()
        water.points = points
        water["wet"] = wet.ravel().astype(np.float32)
        # A cell is water if any corner is below the level: the surface
        # reaches the shore, and the terrain hides the overlap above it.
        surface = water.threshold(0.5, scalars="wet", all_scalars=False)
        self._water_actor = self.plotter.add_mesh(surface, color=tuple(SHALLOW_RGB / 255), opacity=WATER_OPACITY,
                                                  show_scalar_bar=False, render=False, reset_camera=False)
        if render:
            self.plotter.update()

    def mesh_heights(self) -> np.ndarray | None:
        """Heights of the displayed mesh vertices (metres, decimated), for tests."""
        if self._grid is None:
            return None
        rows, cols = self._grid_key[0]
        return np.asarray(self._grid["elevation"]).reshape(rows, cols)

    # -- drawing ----------------------------------------------------------------------------------
    def _scale_changed(self) -> None:
        self._dirty = True
        self._redraw()

    def _schedule(self) -> None:
        if self._live and not self.live_updates:
            return
        if self.plotter is not None and not self._timer.isActive():
            self._timer.start(max(REDRAW_MS, int(self.render_ms / MAX_RENDER_SHARE)))

    def _redraw(self, *, now: bool = False) -> None:
        """Update the mesh from the heights and draw it.

        ``now`` renders synchronously and measures the frame; otherwise the
        widget is only marked for repaint, where VTK renders once (an
        explicit render would be followed by a second one in the repaint).
        """
        if not self._dirty or self.plotter is None or self.heights is None:
            return
        self._dirty = False
        started = time.perf_counter()
        import pyvista as pv

        step = max(1, int(np.ceil(max(self.heights.shape) / MAX_SIDE)))
        small = self.heights[::step, ::step]
        valid = np.isfinite(small)
        # Not yet synthesized cells sit flat at the lowest height so far.
        floor = float(small[valid].min()) if valid.any() else self._vrange[0]
        z = np.where(valid, small, floor).astype(np.float32)
        key = (small.shape, step, self._cell_size)
        if self._grid is None or key != self._grid_key:
            rows, cols = small.shape
            dy, dx = self._cell_size
            yy, xx = np.meshgrid(-np.arange(rows) * dy * step, np.arange(cols) * dx * step, indexing="ij")
            grid = pv.StructuredGrid()
            grid.points = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)]).astype(np.float32)
            grid.dimensions = (cols, rows, 1)
            grid["elevation"] = z.ravel()
            self._grid = grid
            self._grid_key = key
            self._apply_heights(z)
            self.plotter.clear()
            self._water_actor = None
            # No smooth_shading: it would draw a copy with computed normals, and
            # in-place height updates would not show; _apply_heights sets the
            # normals itself.
            # A lookup table brings its own range (add_mesh ignores clim then).
            ramp = pv.LookupTable(values=np.column_stack([TERRAIN_LUT, np.full(len(TERRAIN_LUT), 255, np.uint8)]),
                                  scalar_range=self._vrange)
            self._actor = self.plotter.add_mesh(grid, scalars="elevation", cmap=ramp, show_scalar_bar=False,
                                                render=False)
            # From the south-south-west, north up the screen, as the 2D view
            # and the README's 3D pictures (render_3d) are seen.
            centre = np.array(grid.center)
            x0, x1, y0, y1, _, _ = grid.bounds
            eye = centre + 2.0 * max(x1 - x0, y1 - y0) * camera_direction(*CAMERA)
            self.plotter.camera_position = [tuple(eye), tuple(centre), (0.0, 0.0, 1.0)]
            # The renderer's own: the plotter's renders whatever it is told,
            # a whole frame more on the GUI thread when a run's mesh is made.
            self.plotter.renderer.reset_camera(render=False)
        else:
            self._apply_heights(z)
            self._actor.mapper.scalar_range = self._vrange
        self._place_water(render=False)
        if now:
            self.plotter.render()
            self.render_ms = (time.perf_counter() - started) * 1000
        else:
            self.plotter.update()
        self.redraws += 1
        self.rendered.emit()

    def _apply_heights(self, z: np.ndarray) -> None:
        """Set the mesh heights (metres, decimated grid) and their normals in place."""
        scale = self.scale_spin.value()
        points = self._grid.points
        points[:, 2] = z.ravel() * scale
        self._grid.points = points
        self._grid["elevation"] = z.ravel()
        step = self._grid_key[1]
        dy, dx = self._cell_size
        # Normals of the surface z(x, y) with y pointing north (rows run south).
        dz_drow, dz_dcol = np.gradient(z * scale, dy * step, dx * step)
        normals = np.column_stack([-dz_dcol.ravel(), dz_drow.ravel(), np.ones(z.size)])
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        self._grid.point_data["Normals"] = normals.astype(np.float32)
        self._grid.point_data.active_normals_name = "Normals"
