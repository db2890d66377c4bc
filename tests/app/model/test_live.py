"""Live sketching's model (no Qt): what a stroke asks for, and the update."""

import numpy as np
import pytest

from terrasynth_core.errors import ParamsError
from terrasynth_core.synthesis import SynthesisFinished
from terrasynth_app.model import LiveUpdated, TerrainResult, live_events, live_request, same_strokes, synthesis_events


@pytest.fixture(scope="module")
def finished(new_small_document):
    """A small document and its synthesized terrain."""
    doc = new_small_document()
    result = [e for e in synthesis_events(doc.synthesis_request()) if isinstance(e, SynthesisFinished)][0].result
    return doc, TerrainResult.from_synthesis(result)


def test_the_document_remembers_the_strokes_its_terrain_follows(finished, new_small_document):
    doc = new_small_document()
    _, terrain = finished
    assert doc.result_strokes is None  # no terrain yet
    doc.set_result(terrain)
    assert same_strokes(doc.result_strokes, doc.sketch.to_sketch_map())
    doc.sketch.draw_polyline([(100, 20), (100, 60)], "ridge", radius=2)
    assert not same_strokes(doc.result_strokes, doc.sketch.to_sketch_map())
    doc.set_result(terrain, strokes=None)
    assert doc.result_strokes is None and same_strokes(None, None)


def test_live_request_only_when_strokes_changed(finished, new_small_document):
    doc = new_small_document()
    _, terrain = finished
    assert live_request(doc) is None  # no terrain
    doc.set_result(terrain)
    assert live_request(doc) is None  # nothing changed
    doc.sketch.draw_polyline([(100, 20), (100, 60)], "water", radius=2)
    assert live_request(doc) is None  # regions are a full run's business
    doc.sketch.draw_polyline([(100, 20), (100, 60)], "ridge", radius=2)
    request = live_request(doc)
    assert request is not None and request.terrain is terrain
    doc.sketch.replace(np.zeros((120, 120), np.uint8), np.zeros((120, 120), np.uint8))
    with pytest.raises(ParamsError, match="synthesize it again first"):
        live_request(doc)


def test_live_events_change_the_terrain_near_the_stroke_only(finished, new_small_document):
    _, terrain = finished
    doc = new_small_document()
    doc.set_result(terrain)
    doc.sketch.draw_polyline([(100, 20), (100, 60)], "ridge", radius=2)
    events = list(live_events(live_request(doc)))
    update = events[-1]
    assert isinstance(update, LiveUpdated) and update.seconds > 0
    selection = update.result.selection
    assert selection[100, 40] and not selection[20, 150]
    assert np.array_equal(update.terrain.heights[~selection], terrain.heights[~selection])
    assert update.terrain.cell_size == terrain.cell_size
    assert same_strokes(update.strokes, doc.sketch.to_sketch_map())


def test_with_an_automatic_patch_size_a_stroke_uses_the_terrains(finished, new_small_document):
    from dataclasses import replace

    _, terrain = finished
    made = terrain.report["params"]["patch_size"]
    doc = new_small_document()
    doc.set_params(replace(doc.params, patch_size=None))
    doc.set_result(terrain)
    doc.sketch.draw_polyline([(100, 20), (100, 60)], "ridge", radius=2)
    update = list(live_events(live_request(doc)))[-1]
    assert isinstance(update, LiveUpdated) and update.result.params.patch_size == made
