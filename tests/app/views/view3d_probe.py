"""Child process of ``test_view3d.py``: drive the 3D view on a real X display.

Prints one JSON line with what it saw.  Not a test module itself: Qt's
platform is chosen once per process, and the other tests run offscreen.
"""

import json
import sys
import types

import numpy as np
from PySide6.QtWidgets import QApplication


def main(screenshot_path: str) -> None:
    app = QApplication(sys.argv[:1])
    from terrasynth_app.model import TerrainResult
    from terrasynth_app.views.terrain_view_3d import MAX_SIDE, TerrainView3D

    import threading

    view = TerrainView3D()
    # (VTK is imported on a helper thread from construction, not on first show.)
    out_ahead = any(t.name == "terrasynth-import-3d" for t in threading.enumerate()) or "pyvistaqt" in sys.modules
    view.resize(500, 400)
    view.show()
    app.processEvents()
    out = {"platform": QApplication.platformName(), "available": view.available,
           "reason": view.unavailable_reason, "imported_ahead": out_ahead}
    out["frame_ms"] = round(view.render_ms, 1)
    out["live_updates"] = view.live_updates
    if view.available:
        # Exercise live updates even where this OpenGL is too slow for them.
        view.live_updates = True
        shape = (300, 200)
        view.begin_run(shape, cell_size=(30.0, 30.0), vrange=(0.0, 500.0))
        heights = np.full((40, 60), 400.0, np.float32)
        event = types.SimpleNamespace(bbox=(20, 60, 40, 100), heights=heights, index=0, total=1)
        redraws = view.redraws
        view.paste_patch(event)
        while view.redraws == redraws:  # the throttle timer redraws within ~100 ms
            app.processEvents()
        mesh = view.mesh_heights()
        step = int(np.ceil(max(shape) / MAX_SIDE))
        out["mesh_shape"] = list(mesh.shape)
        out["patch_in_mesh"] = bool(np.allclose(mesh[20 // step + 1:60 // step - 1, 40 // step + 1:100 // step - 1], 400))
        out["floor_elsewhere"] = bool(np.allclose(mesh[-1, -1], 400))  # unfilled cells sit at the lowest height
        # Frames that stall the GUI thread during a run pause live updates:
        # here every frame counts as slow.
        from PySide6.QtCore import QEventLoop

        from terrasynth_app.views import terrain_view_3d

        limit, terrain_view_3d.LOADED_FRAME_LIMIT_MS = terrain_view_3d.LOADED_FRAME_LIMIT_MS, 0.0
        for i in range(1, 1 + terrain_view_3d.SLOW_FRAMES):
            view.paste_patch(types.SimpleNamespace(bbox=(100, 140, 40 + i, 100 + i), heights=heights, index=i,
                                                   total=4))
            redraws = view.redraws
            while view.redraws == redraws and view.live_updates:
                app.processEvents()
            app.processEvents(QEventLoop.AllEvents, 200)  # the repaint that renders the frame
        out["paused_under_load"] = [view.live_updates, view.notice.text().startswith("Live 3D off")]
        terrain_view_3d.LOADED_FRAME_LIMIT_MS = limit
        view.live_updates = True
        ramp = np.add.outer(np.arange(300), np.arange(200)).astype(np.float32)
        view.show_result(TerrainResult(ramp, np.zeros(shape, np.int32), np.zeros(shape, bool), cell_size=(30.0, 30.0)))
        out["result_in_mesh"] = bool(np.allclose(view.mesh_heights(), ramp[::step, ::step]))
        # The same ramp as the 2D view over the same heights.
        from terrasynth_core.pictures import height_range, terrain_colours

        vrange = height_range(ramp)
        probes = np.linspace(*vrange, 9, dtype=np.float32)
        flat = terrain_colours(probes[None, :], vrange=vrange)[0].astype(float)
        mesh = np.array([view.ramp_colour(h) for h in probes])
        out["ramp_error"] = float(np.abs(mesh - flat).max())
        # A water plane at the level, following it and the vertical scale.
        out["no_water_plane"] = view.water_plane_height() is None
        view.set_water_level(120.0)
        first = view.water_plane_height()
        view.set_water_level(200.0)
        view.scale_spin.setValue(3.0)
        out["water_planes"] = [first, view.water_plane_height()]
        view.set_water_level(None)
        out["water_plane_removed"] = view.water_plane_height() is None
        # Only water connected to painted water: none painted in the low
        # corner, so no cell there is water.
        painted = np.zeros(shape, bool)
        painted[-1, -1] = True  # the highest corner, above the level: reaches nothing
        view.set_water_level(200.0, painted=painted)
        out["unconnected_dry"] = view.water_plane_height() is None
        view.set_water_level(200.0)
        view.screenshot(screenshot_path)
        view.plotter.close()
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1])
