"""Derived feature graphs: out of date after a change, stale answers dropped."""

import numpy as np

from terrasynth_app.model import Document, ExampleRef, Sketch, SketchGraph, TerrainGraph, TerrainResult


def _sketch():
    sketch = Sketch.blank((64, 64))
    sketch.draw_polyline([(10, 32), (50, 32)], "ridge", radius=2, hardness=1.0)
    return sketch


def test_a_sketch_graph_is_computed_from_a_snapshot_and_kept_while_current():
    sketch = _sketch()
    graph = SketchGraph(sketch)
    invalidations = []
    graph.invalidated.connect(lambda: invalidations.append(True))
    assert graph.maps is None and not graph.up_to_date
    generation, compute = graph.job()
    sketch.draw_polyline([(10, 5), (50, 5)], "valley", radius=2)  # after the snapshot
    maps = compute()
    assert len(maps.ridges.paths) == 1 and not maps.valleys.paths  # the snapshot, not the edit
    assert invalidations  # the edit made the graph out of date
    assert not graph.deliver(generation, maps)  # answers a question no longer asked
    assert graph.maps is None
    generation, compute = graph.job()
    assert graph.deliver(generation, compute()) and graph.up_to_date
    assert graph.maps.valleys.paths


def test_a_sketch_graph_is_busy_while_a_stroke_is_drawn():
    sketch = _sketch()
    graph = SketchGraph(sketch)
    sketch.begin_stroke("ridge", 30, 10, radius=2)
    assert graph.busy
    sketch.end_stroke()
    assert not graph.busy


def test_the_terrain_graph_follows_the_documents_result():
    doc = Document(_sketch(), [ExampleRef(builtin="white-mountains")])
    graph = TerrainGraph(doc)
    assert graph.job() is None  # no terrain yet
    rr, cc = np.mgrid[:64, :64]
    heights = (100 - np.abs(cc - 32) * 3.0 + 0.1 * rr).astype(np.float32)  # a ridge down the middle
    doc.set_result(TerrainResult(heights, np.zeros((64, 64), np.int32), np.zeros((64, 64), bool)))
    generation, compute = graph.job()
    assert graph.deliver(generation, compute()) and graph.up_to_date
    doc.set_params(doc.params)  # no change of the result: still current
    assert graph.up_to_date
    doc.set_result(None)
    assert not graph.up_to_date and graph.job() is None
