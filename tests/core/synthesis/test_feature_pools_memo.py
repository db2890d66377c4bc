"""Feature pools kept between sessions (terrasynth_core/synthesis/feature_patches.py)."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.features.sketch import read_sketch
from terrasynth_core.synthesis import Session, SynthesisParams
from terrasynth_core.memo import Memo
from terrasynth_core.synthesis import feature_patches, fill_patches

P = SynthesisParams(patch_size=32, k=2, seed=3, landform=False)


def test_feature_pools_are_kept_for_the_same_examples_and_made_again_for_others(white_mountains, sketch_dir,
                                                                             monkeypatch):
    """A new session (a new run, a live stroke) reuses the pools an earlier
    one made from the same examples, with the same result; a changed
    example, patch size or mirror option gets its own."""
    made = []
    make = feature_patches.feature_pools

    def counted(layout, radius, *, mirror, stored=None):
        made.append((radius, mirror))
        return make(layout, radius, mirror=mirror, stored=stored)

    monkeypatch.setattr(feature_patches, "feature_pools", counted)
    monkeypatch.setattr(feature_patches, "_POOLS", Memo(4))
    sketch = read_sketch(sketch_dir / "y_junction_512.png").resized((160, 160))
    first = Session([white_mountains], sketch, params=P).run()
    assert len(made) == 1
    again = Session([white_mountains], sketch, params=P).run()  # a new session, the same inputs
    assert len(made) == 1
    np.testing.assert_array_equal(first.heights, again.heights)
    # Made afresh (the memo emptied), the pools give the same terrain.
    monkeypatch.setattr(feature_patches, "_POOLS", Memo(4))
    np.testing.assert_array_equal(Session([white_mountains], sketch, params=P).run().heights, first.heights)
    assert len(made) == 2
    # Other inputs, other pools: a steeper example, another radius, no mirrors.
    steeper = white_mountains.with_heights(white_mountains.heights * np.float32(2))
    layout = Session([white_mountains], sketch, params=P).layout
    pools = feature_patches.memo_feature_pools(layout, 16.0, mirror=True)
    assert len(made) == 2 and feature_patches.memo_feature_pools(layout, 16.0, mirror=True) is pools
    feature_patches.memo_feature_pools(Session([steeper], sketch, params=P).layout, 16.0, mirror=True)
    feature_patches.memo_feature_pools(layout, 20.0, mirror=True)
    feature_patches.memo_feature_pools(layout, 16.0, mirror=False)
    assert made[2:] == [(16.0, True), (20.0, True), (16.0, False)]


def test_example_stations_are_kept_between_sessions_and_the_sketch_stations_are_not(white_mountains, sketch_dir,
                                                                                    monkeypatch):
    """Two sessions on the same example share its networks' stations (they
    come from the memoised analysis); each session's sketch gets its own,
    and the shared ones answer as fresh ones do."""
    monkeypatch.setattr(feature_patches, "_EXAMPLE_STATIONS", Memo(8))
    sketch = read_sketch(sketch_dir / "y_junction_512.png").resized((160, 160))
    made = [Session([white_mountains], sketch, params=P) for _ in range(2)]
    stations = [feature_patches.Stations(s.sketch_maps, s.layout.examples, 16.0) for s in made]
    assert made[0].layout.examples[0].features is made[1].layout.examples[0].features
    for kind in ("ridge", "valley"):
        assert stations[0]._of((0, kind)) is stations[1]._of((0, kind))
        assert stations[0]._of(("sketch", kind)) is not stations[1]._of(("sketch", kind))
    samples = made[0].layout.examples[0].samples["ridge"][:20]
    assert samples
    monkeypatch.setattr(feature_patches, "_EXAMPLE_STATIONS", Memo(8))
    fresh = feature_patches.Stations(made[0].sketch_maps, made[0].layout.examples, 16.0)._of((0, "ridge"))
    assert fresh is not stations[0]._of((0, "ridge"))
    for s in samples:
        kept = stations[1]._of((0, "ridge")).inner(s.center, s.crossings)
        np.testing.assert_array_equal(kept, fresh.inner(s.center, s.crossings))


def test_an_analysis_read_again_from_disk_finds_its_pools_and_stations(white_mountains, sketch_dir, monkeypatch):
    """The memos key an example by its analysis's content: when the analysis
    memo has let it go (a tiled run over a library larger than the memo) and
    it is read back from disk as a new object, the pools and stations made
    from the first are found, not made and kept a second time."""
    from terrasynth_core.exemplars import cache, prepare

    made = []
    make = feature_patches.feature_pools

    def counted(layout, radius, *, mirror, stored=None):
        made.append(radius)
        return make(layout, radius, mirror=mirror, stored=stored)

    monkeypatch.setattr(feature_patches, "feature_pools", counted)
    monkeypatch.setattr(feature_patches, "_POOLS", Memo(4))
    monkeypatch.setattr(feature_patches, "_EXAMPLE_STATIONS", Memo(8))
    sketch = read_sketch(sketch_dir / "y_junction_512.png").resized((160, 160))
    first = Session([white_mountains], sketch, params=P)
    heights = first.run().heights
    # The analysis memo forgets: the next session reads the analysis from disk.
    monkeypatch.setattr(prepare, "_CACHE", cache.Memo(8, cache.load, lambda key, value: cache.save(key, *value)))
    again = Session([white_mountains], sketch, params=P)
    assert again.layout.examples[0] is not first.layout.examples[0]
    assert again.layout.examples[0].key == first.layout.examples[0].key
    np.testing.assert_array_equal(again.run().heights, heights)
    assert len(made) == 1
    stations = [feature_patches.Stations(s.sketch_maps, s.layout.examples, 16.0) for s in (first, again)]
    assert stations[0]._of((0, "valley")) is stations[1]._of((0, "valley"))


def test_a_once_memo_makes_a_value_once_for_threads_asking_together():
    """Two threads asking a ``once`` memo for a missing key: one makes it,
    the other waits for it; when the maker fails, the waiting one makes it."""
    import threading

    memo = Memo(4, once=True)
    started, release = threading.Event(), threading.Event()
    calls = []

    def slow():
        calls.append("slow")
        started.set()
        release.wait(10)
        return 1

    got = []
    first = threading.Thread(target=lambda: got.append(memo.get("k", slow)))
    first.start()
    assert started.wait(10)
    second = threading.Thread(target=lambda: got.append(memo.get("k", lambda: calls.append("again") or 2)))
    second.start()
    second.join(0.2)
    assert second.is_alive()  # waiting for the first maker, not making its own
    release.set()
    first.join(10)
    second.join(10)
    assert got == [1, 1] and calls == ["slow"]

    started.clear()
    release.clear()

    def failing():
        started.set()
        release.wait(10)
        raise RuntimeError("disk full")

    errors = []
    first = threading.Thread(target=lambda: errors.append(pytest.raises(RuntimeError, memo.get, "f", failing)))
    first.start()
    assert started.wait(10)
    second = threading.Thread(target=lambda: got.append(memo.get("f", lambda: 3)))
    second.start()
    second.join(0.2)
    assert second.is_alive()  # waiting for the failing maker
    release.set()
    first.join(10)
    second.join(10)
    assert errors and got[-1] == 3 and memo.peek("f") == 3


def test_prepare_resynthesis_makes_what_the_first_stroke_reads(white_mountains, sketch_dir, monkeypatch):
    """After ``prepare_resynthesis`` a stroke's crop run makes no feature
    pools, no fill search and no zone index of its own (here or in a fill
    worker, which would store it), and its result is the same bytes."""
    from terrasynth_core.exemplars.cache import cache_dir
    from terrasynth_core.features import SketchMap
    from terrasynth_core.synthesis import (changed_cells, prepare_resynthesis, resynthesize_region,
                                           stroke_selection)

    sketch = read_sketch(sketch_dir / "y_junction_512.png").resized((160, 160))
    first = Session([white_mountains], sketch, params=P).run()
    ridge = sketch.ridge_mask.copy()
    ridge[120:124, 20:80] = True
    after = SketchMap(ridge, sketch.valley_mask)
    selection = stroke_selection(changed_cells(sketch, after), patch_size=P.patch_size)
    cold = resynthesize_region([white_mountains], after, previous=first.heights, selection=selection, params=P)

    made = []
    make_pools, make_search = feature_patches.feature_pools, fill_patches.FillSearch
    monkeypatch.setattr(feature_patches, "_POOLS", Memo(4, once=True))
    monkeypatch.setattr(fill_patches, "_SEARCHES", Memo(4, once=True))
    monkeypatch.setattr(feature_patches, "feature_pools",
                        lambda *a, **k: made.append("pools") or make_pools(*a, **k))
    monkeypatch.setattr(fill_patches, "FillSearch", lambda *a, **k: made.append("search") or make_search(*a, **k))
    prepare_resynthesis([white_mountains], after, previous=first.heights, params=P)
    assert sorted(set(made)) == ["pools", "search"]
    prepared = len(made)
    zones = sorted(p.name for p in cache_dir().glob("*-z*.npz"))
    warm = resynthesize_region([white_mountains], after, previous=first.heights, selection=selection, params=P)
    assert len(made) == prepared
    assert sorted(p.name for p in cache_dir().glob("*-z*.npz")) == zones
    np.testing.assert_array_equal(warm.heights, cold.heights)


def test_prepare_resynthesis_makes_every_zone_index_of_the_crops_searches(white_mountains, sketch_dir, monkeypatch,
                                                                          tmp_path):
    """A crop's holes ask for zones a whole-map run may not have made; the
    first strokes built them (0.3-0.4 s each for a 1201x1201 example)."""
    import dataclasses
    import re

    from terrasynth_core.matching import fill_search
    from terrasynth_core.matching.window_index import ZONES_BY_SIDES
    from terrasynth_core.synthesis import prepare_resynthesis

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(fill_search.FillSearch, "EXHAUSTIVE_BELOW", 64)  # the 400x400 corner is searched indexed
    monkeypatch.setattr(fill_patches, "_SEARCHES", Memo(4, once=True))
    params = dataclasses.replace(P, workers=1)
    sketch = read_sketch(sketch_dir / "y_junction_512.png").resized((160, 160))
    first = Session([white_mountains], sketch, params=params).run()

    def zones() -> dict[str, set[int]]:
        found: dict[str, set[int]] = {}
        for path in tmp_path.glob("*-z*.npz"):
            key, zone = re.fullmatch(r"(.*)-z(\d+)\.npz", path.name).groups()
            found.setdefault(key, set()).add(int(zone))
        return found

    made_by_the_run = zones()
    assert made_by_the_run and all(not set(ZONES_BY_SIDES) <= z for z in made_by_the_run.values())
    prepare_resynthesis([white_mountains], sketch, previous=first.heights, params=params, cancel=lambda: True)
    assert zones() == made_by_the_run  # cancelled before the first zone index
    prepare_resynthesis([white_mountains], sketch, previous=first.heights, params=params)
    assert any(set(ZONES_BY_SIDES) <= z for z in zones().values())
