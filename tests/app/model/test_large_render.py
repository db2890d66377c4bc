"""Render large (app/model/large_render.py): the document's controls go to
the tiled run, its pins and stamps following the sketch to the render's
size."""

from __future__ import annotations

import numpy as np
import pytest
import rasterio

from terrasynth_app.model import Document, ExampleRef, Sketch
from terrasynth_app.model.large_render import LargeRender, large_render_events
from terrasynth_core.project.resize import resize_pins
from terrasynth_core.synthesis import SynthesisParams


def test_a_pinned_document_renders_large_with_the_pin_at_its_place(tmp_path):
    sketch = Sketch.blank((96, 96))
    sketch.draw_polyline([(20, 48), (76, 48)], "ridge", radius=2, hardness=1.0)
    doc = Document(sketch, [ExampleRef(builtin="white-mountains", crop=(400, 700, 400, 700))],
                   params=SynthesisParams(patch_size=32, k=2, seed=4))
    doc.add_pin(30, 70, 1400.0)
    request = doc.synthesis_request()
    render = LargeRender(size=(192, 192), tile=96, workers=1, out=tmp_path / "large.tif")
    events = large_render_events(request, render)
    with pytest.raises(StopIteration) as done:
        while True:
            next(events)
    assert done.value.value.result.shape == (192, 192) and done.value.value.engine is None
    with rasterio.open(render.out) as ds:
        heights = ds.read(1)
    (pin,) = resize_pins(request.pins, (96, 96), (192, 192))
    assert (pin.row, pin.col) != (30, 70)  # it followed the sketch
    assert heights[pin.row, pin.col] == pytest.approx(1400.0, abs=1e-3)
    assert np.isfinite(heights).all()


def test_an_engine_folder_holding_a_file_is_refused_before_any_work(tmp_path):
    """A name the engine export would take is refused when the render
    starts, not after the tiles: nothing is made and the file is kept."""
    from terrasynth_core.errors import DEMFormatError

    doc = Document(Sketch.blank((96, 96)), [ExampleRef(builtin="white-mountains", crop=(400, 700, 400, 700))],
                   params=SynthesisParams(patch_size=32, k=2, seed=4))
    render = LargeRender(size=(192, 192), tile=96, workers=1, out=tmp_path / "large.tif", engine="godot")
    render.engine_folder().mkdir()
    (render.engine_folder() / "large.exr").write_bytes(b"mine")
    with pytest.raises(DEMFormatError, match="large.exr exists"):
        next(large_render_events(doc.synthesis_request(), render))
    assert (render.engine_folder() / "large.exr").read_bytes() == b"mine"
    assert not render.out.exists()


def test_a_render_cancelled_while_writing_the_engine_files_keeps_the_geotiff_only(tmp_path):
    """The engine's files come after the GeoTIFF, announced; stopping the
    render then keeps the GeoTIFF and no engine file."""
    from terrasynth_app.model.large_render import EngineExportStarted

    doc = Document(Sketch.blank((96, 96)), [ExampleRef(builtin="white-mountains", crop=(400, 700, 400, 700))],
                   params=SynthesisParams(patch_size=32, k=2, seed=4))
    render = LargeRender(size=(192, 192), tile=96, workers=1, out=tmp_path / "large.tif", engine="unity",
                         engine_tiles=2)
    events = large_render_events(doc.synthesis_request(), render)
    for event in events:
        if isinstance(event, EngineExportStarted):
            break
    assert event.engine == "unity" and render.out.exists()
    events.close()
    assert not render.engine_folder().exists()
