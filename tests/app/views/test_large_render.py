"""File > Render large...: the document tiled on Dask in the background, with
progress and cancel (app/controllers/large_render.py, app/views/large_render_dialog.py)."""

from __future__ import annotations

import numpy as np
import rasterio

from terrasynth_core.tiled.store import store_path


def _set_up(dialog, out, *, side=288, tile=96):
    dialog.rows.setValue(side)
    dialog.cols.setValue(side)
    dialog.tile.setValue(tile)
    dialog.workers.setValue(1)
    dialog.out.setText(str(out))


def test_render_large_cancels_then_continues_to_the_geotiff(window, qtbot, tmp_path):
    dialog = window.render_large()
    assert dialog.isVisible() and window.actions.render_large.text() == "Render large…"
    out = tmp_path / "large.tif"
    _set_up(dialog, out)
    controller = window.large_render
    # Cancel after the first tile: the tiles made so far stay beside the output.
    controller.tile_finished.connect(lambda done, total: controller.cancel() if done == 1 else None)
    with qtbot.waitSignal(controller.cancelled, timeout=180_000):
        dialog.render_button.click()
    qtbot.waitUntil(lambda: dialog.render_button.isEnabled(), timeout=60_000)
    assert not out.exists() and list(store_path(out).glob("tile_*.npy"))
    assert "Cancelled" in dialog.status.text()
    controller.tile_finished.disconnect()
    controller.tile_finished.connect(dialog._tile_finished)
    # The second render also writes Unity's 2 x 2 tiles beside the GeoTIFF.
    dialog.engine.setCurrentIndex(dialog.engine.findData("unity"))
    assert dialog.engine_tiles.isEnabled()
    dialog.engine_tiles.setValue(2)
    with qtbot.waitSignal(controller.finished, timeout=180_000) as finished:
        dialog.render_button.click()
    result = finished.args[0].result
    assert result.reused >= 1 and result.shape == (288, 288)
    assert dialog.progress.value() == dialog.progress.maximum() == 1
    assert "Wrote" in dialog.status.text() and "Unity: resolution" in dialog.status.text()
    assert sorted(p.name for p in (tmp_path / "large_unity").glob("*.r16")) == [
        f"large_x{i}_y{j}.r16" for i in range(2) for j in range(2)]
    with rasterio.open(out) as ds:
        heights = ds.read(1)
    assert heights.shape == (288, 288) and np.isfinite(heights).all() and heights.std() > 1
    qtbot.waitUntil(lambda: not controller.running, timeout=60_000)


def test_render_large_says_why_it_cannot(window, qtbot, tmp_path):
    dialog = window.render_large()
    _set_up(dialog, tmp_path / "small.tif", side=96, tile=200)
    with qtbot.waitSignal(window.large_render.failed, timeout=60_000) as failed:
        dialog.render_button.click()
    assert "tile size 200" in failed.args[0] and "Stopped: tile size 200" in dialog.status.text()
