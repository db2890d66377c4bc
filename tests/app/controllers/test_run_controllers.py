"""The synthesis controller and the feature-graph controller with stand-in work."""

import numpy as np
import pytest

from terrasynth_core.synthesis import PatchPlaced, StageFinished, StageStarted, SynthesisFinished, SynthesisParams
from terrasynth_app.controllers import FeatureGraphController, SynthesisController
from terrasynth_app.controllers import synthesis as synthesis_module
from terrasynth_app.model import Document, ExampleRef, RunInfo, RunStarted, Sketch, SketchGraph

TIMEOUT_MS = 10_000
SHAPE = (32, 32)


class _Result:
    """The parts of a core SynthesisResult the controller reads."""

    heights = np.ones(SHAPE, np.float32)
    patch_id = np.zeros(SHAPE, np.int32)
    seam_mask = np.zeros(SHAPE, bool)
    sketch_features = None
    pin_errors = ()
    total_seconds = 1.25
    warnings = ["a warning"]
    selection = None
    params = SynthesisParams(seed=3)
    cell_size = 30.0  # the session's, as in the run info

    def report(self):
        return {"params": {"seed": 3}}


def _events(patches, fail=False):
    yield RunStarted(RunInfo(SHAPE, (30.0, 30.0), (0.0, 1.0)))
    yield StageStarted("fill", patches)
    for i in range(patches):
        yield PatchPlaced(i, patches, "fill", (0, 8, 0, 8), np.zeros((8, 8), np.float32), 0.0)
    if fail:
        raise ValueError("broken")
    yield StageFinished("fill", 1.0)
    yield SynthesisFinished(_Result())


@pytest.fixture
def controller(qtbot, monkeypatch):
    sketch = Sketch.blank(SHAPE)
    doc = Document(sketch, [ExampleRef(builtin="white-mountains")])
    synthesis = SynthesisController(doc, progress_ms=50)
    yield synthesis
    assert synthesis.wait()


def _record(controller):
    log = []
    controller.run_started.connect(lambda info: log.append(("run_started", info.shape)))
    controller.patch_placed.connect(lambda event: log.append(("patch", event.index)))
    controller.stage_changed.connect(lambda text: log.append(("stage", text)))
    controller.progress_changed.connect(lambda done, total, left: log.append(("progress", done, total)))
    controller.status.connect(lambda text, ms: log.append(("status", text)))
    return log


def test_a_run_is_told_in_order_with_throttled_progress_and_ends_in_the_document(qtbot, controller, monkeypatch):
    monkeypatch.setattr(synthesis_module, "synthesis_events", lambda request: _events(200))
    log = _record(controller)
    with qtbot.waitSignal(controller.finished, timeout=TIMEOUT_MS) as finished:
        controller.synthesize()
    assert log[:3] == [("stage", "Reading examples…"), ("progress", 0, 0), ("run_started", SHAPE)]
    assert [entry[1] for entry in log if entry[0] == "patch"] == list(range(200))
    progress = [entry for entry in log if entry[0] == "progress"]
    assert len(progress) < 200  # at most one per 50 ms, however fast the patches come
    assert ("stage", "Filling the rest") in log and log[-2:] == [("stage", "Done"), (
        "status", "Synthesized 32 x 32 cells of 30 m in 1.2 s - a warning")]
    assert controller.document.result.seed == 3 and controller.document.result.cell_size == (30.0, 30.0)
    assert isinstance(finished.args[0], _Result)
    qtbot.waitUntil(lambda: not controller.running, timeout=TIMEOUT_MS)


def test_a_failed_run_reports_one_error_and_keeps_the_document(qtbot, controller, monkeypatch):
    monkeypatch.setattr(synthesis_module, "synthesis_events", lambda request: _events(3, fail=True))
    errors = []
    controller.error.connect(lambda title, message: errors.append((title, message)))
    with qtbot.waitSignal(controller.failed, timeout=TIMEOUT_MS) as failed:
        controller.synthesize()
    assert failed.args == ["internal error: ValueError: broken"]
    assert errors == [("Synthesis failed", "internal error: ValueError: broken")]
    assert controller.document.result is None


def test_a_request_the_document_refuses_is_an_error_and_starts_nothing(qtbot, controller):
    controller.document.set_examples([])
    errors = []
    controller.error.connect(lambda title, message: errors.append(title))
    controller.synthesize()
    assert errors == ["Cannot synthesize"] and not controller.running


def test_the_feature_graph_controller_computes_when_wanted_and_after_changes(qtbot):
    sketch = Sketch.blank((64, 64))
    sketch.draw_polyline([(10, 32), (50, 32)], "ridge", radius=2, hardness=1.0)
    graphs = FeatureGraphController(SketchGraph(sketch), delay_ms=20)
    with qtbot.waitSignal(graphs.ready, timeout=TIMEOUT_MS) as ready:
        graphs.set_wanted(True)
    assert len(ready.args[0].ridges.paths) == 1
    with qtbot.waitSignal(graphs.ready, timeout=TIMEOUT_MS) as ready:  # up to date: at once
        graphs.request()
    with qtbot.waitSignal(graphs.ready, timeout=TIMEOUT_MS) as ready:
        sketch.draw_polyline([(10, 5), (50, 5)], "valley", radius=2, hardness=1.0)
    assert ready.args[0].valleys.paths
    graphs.set_wanted(False)
    sketch.clear()
    assert not graphs.graph.up_to_date  # not recomputed while nobody wants it
