"""The fill on several processes gives the bytes of the fill on one."""

from __future__ import annotations

import numpy as np

from terrasynth_core.features import read_sketch
from terrasynth_core.synthesis import Session, SynthesisParams
from terrasynth_core.synthesis.fill_workers import FillWorkers


def test_one_or_two_processes_give_the_same_bytes(white_mountains, sketch_dir, monkeypatch):
    sketch = read_sketch(sketch_dir / "y_junction_512.png").resized((256, 256))
    pools = []
    enter = FillWorkers.__enter__

    def recording(self):
        out = enter(self)
        pools.append(self._workers is not None)
        return out

    monkeypatch.setattr(FillWorkers, "__enter__", recording)
    waves = []
    run = FillWorkers.run
    monkeypatch.setattr(FillWorkers, "run", lambda self, tasks: waves.append(len(tasks)) or run(self, tasks))
    params = SynthesisParams(patch_size=32, k=2, seed=4, landform=False)
    one = Session([white_mountains], sketch, params=SynthesisParams(**{**params.__dict__, "workers": 1})).run()
    two = Session([white_mountains], sketch, params=SynthesisParams(**{**params.__dict__, "workers": 2})).run()
    assert pools == [False, True]  # the second run had a worker process ...
    assert max(waves) > 1  # ... and gave it windows
    assert one.counts()["fill"] > 20
    np.testing.assert_array_equal(one.heights, two.heights)
    np.testing.assert_array_equal(one.patch_id, two.patch_id)
    assert [p.bbox for p in one.patches] == [p.bbox for p in two.patches]


def test_pages_handed_back_after_every_window_change_nothing(white_mountains, sketch_dir, monkeypatch):
    """A process over a large library hands its mapped pages back as it
    fills (``mapped_pages``): the bytes are the same."""
    from terrasynth_core.exemplars import mapped_pages

    sketch = read_sketch(sketch_dir / "y_junction_512.png").resized((192, 192))
    params = SynthesisParams(patch_size=32, k=2, seed=2, landform=False, workers=1)
    kept = Session([white_mountains], sketch, params=params).run()
    released = []
    release = mapped_pages.release
    monkeypatch.setattr(mapped_pages, "release", lambda: released.append(1) or release())
    monkeypatch.setattr(mapped_pages, "MAPPED_BUDGET", 0)
    again = Session([white_mountains], sketch, params=params).run()
    if mapped_pages.file_resident() is not None:
        assert len(released) >= again.counts()["fill"]
    np.testing.assert_array_equal(kept.heights, again.heights)
    np.testing.assert_array_equal(kept.patch_id, again.patch_id)
