"""Feature patches prepared on a worker process give the bytes of those
prepared on a helper thread."""

from __future__ import annotations

from concurrent.futures import wait

import numpy as np

from terrasynth_core.features import read_sketch
from terrasynth_core.synthesis import Session, SynthesisParams, pipeline, workers
from terrasynth_core.synthesis.feature_ahead import PrepareAhead


def _warm() -> bool:
    """The workers once their warm-up is done (a test must not depend on
    whether a fresh process imported in time)."""
    wait(list(workers._WARMING))
    return workers.ready()


def test_features_prepared_on_a_process_give_the_same_bytes(white_mountains, sketch_dir, monkeypatch):
    sketch = read_sketch(sketch_dir / "s_valley_1000.png").resized((256, 256))
    used = []
    enter = PrepareAhead.__enter__
    monkeypatch.setattr(PrepareAhead, "__enter__", lambda self: used.append(self.processes) or enter(self))
    monkeypatch.setattr(pipeline, "workers_ready", _warm)
    params = dict(patch_size=32, k=2, seed=5, landform=False)
    here = Session([white_mountains], sketch, params=SynthesisParams(**params, workers=1)).run()
    there = Session([white_mountains], sketch, params=SynthesisParams(**params, workers=2)).run()
    assert used == [1, 2]
    assert sum(here.counts()[k] for k in ("branch", "end", "path")) >= pipeline.MIN_AHEAD_SAMPLES
    np.testing.assert_array_equal(here.heights, there.heights)
    assert [(p.kind, p.example, p.source, p.mirrored) for p in here.patches] == \
        [(p.kind, p.example, p.source, p.mirrored) for p in there.patches]
    assert here.warnings == there.warnings
