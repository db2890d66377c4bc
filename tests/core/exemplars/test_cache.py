"""The example analysis and its disk cache."""

import numpy as np


def test_analysis_disk_cache_round_trips_and_survives_damage(white_mountains, tmp_path, monkeypatch):
    from terrasynth_core.exemplars import prepare as an

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    an._CACHE.clear()
    first = an.prepare_example(white_mountains, 32)
    files = list(tmp_path.glob("example-*.npz"))
    assert len(files) == 1
    an._CACHE.clear()
    second = an.prepare_example(white_mountains, 32)  # from disk
    for kind in ("ridge", "valley"):
        a, b = first.samples[kind], second.samples[kind]
        assert len(a) == len(b) > 0
        assert all(np.array_equal(x.crossings, y.crossings) and np.array_equal(x.center, y.center)
                   for x, y in zip(a, b))
    assert np.array_equal(first.strong_mask, second.strong_mask) and first.relief == second.relief
    assert len(second.features.ridges.paths) == len(first.features.ridges.paths)
    files[0].write_bytes(b"not an npz")
    an._CACHE.clear()
    third = an.prepare_example(white_mountains, 32)  # damaged file: recomputed, not an error
    assert len(third.samples["ridge"]) == len(first.samples["ridge"])
