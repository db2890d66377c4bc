"""Feature patches prepared on a worker process give the bytes of those
prepared on a helper thread."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.features import read_sketch
from terrasynth_core.synthesis import Session, SynthesisParams, feature_ahead, pipeline, workers


def _warm() -> bool:
    """The workers once their warm-up is done (a test must not depend on
    whether a fresh process imported in time)."""
    return workers.wait_warm()


@pytest.mark.parametrize("thread_first", [0, 5])
def test_features_prepared_on_a_process_give_the_same_bytes(white_mountains, sketch_dir, monkeypatch, thread_first):
    """On the worker from the first patch, or (as in a fresh process whose
    worker is still importing) on the thread for the first five and on the
    worker for the rest."""
    sketch = read_sketch(sketch_dir / "s_valley_1000.png").resized((256, 256))
    sent = []  # tasks sent to a worker process
    submit = workers.KitWorkers.submit
    monkeypatch.setattr(workers.KitWorkers, "submit", lambda self, task, *a: sent.append(task) or submit(self, task, *a))
    asked = []
    monkeypatch.setattr(feature_ahead, "ready", lambda: len(asked) >= thread_first and _warm() or asked.append(1))
    params = dict(patch_size=32, k=2, seed=5, landform=False)
    here = Session([white_mountains], sketch, params=SynthesisParams(**params, workers=1)).run()
    assert sent == []
    there = Session([white_mountains], sketch, params=SynthesisParams(**params, workers=2)).run()
    assert len(asked) == thread_first
    assert sent.count(feature_ahead.prepare_with) >= pipeline.MIN_AHEAD_SAMPLES - thread_first
    np.testing.assert_array_equal(here.heights, there.heights)
    assert [(p.kind, p.example, p.source, p.mirrored) for p in here.patches] == \
        [(p.kind, p.example, p.source, p.mirrored) for p in there.patches]
    assert here.warnings == there.warnings


def test_a_pool_pickles_while_another_thread_ranks_with_it(white_mountains):
    """Pools are shared by a process's sessions: one run pickles them for its
    worker while another's thread may add an alignment to them."""
    import pickle

    from terrasynth_core.exemplars.prepare import prepare_example
    from terrasynth_core.matching.candidates import FeaturePool

    an = prepare_example(white_mountains, 32)
    pool = FeaturePool([(0, an.samples["ridge"])], 16.0, mirror=True)
    pool._aligned[98] = pool._aligned[99] = _AddsAnAlignment(pool._aligned)  # pickling adds one, as a thread would
    copy = pickle.loads(pickle.dumps(pool))
    assert copy.size() == pool.size() > 0
    assert 100 in pool._aligned and 100 not in copy._aligned


class _AddsAnAlignment:
    def __init__(self, aligned: dict):
        self.aligned = aligned

    def __reduce__(self):
        self.aligned[100] = None
        return (str, ("an alignment",))
