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


def test_a_cache_file_of_another_dem_under_this_name_is_not_used(white_mountains, lowland, tmp_path, monkeypatch):
    """Issue 13, finding 6: another DEM's analysis copied onto this DEM's cache name was used."""
    from terrasynth_core.exemplars import prepare as an

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path / "a"))
    an._CACHE.clear()
    own = an.prepare_example(white_mountains, 32)
    [own_file] = (tmp_path / "a").glob("example-*.npz")
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path / "b"))
    an._CACHE.clear()
    an.prepare_example(lowland, 32)
    [other_file] = (tmp_path / "b").glob("example-*.npz")
    own_file.write_bytes(other_file.read_bytes())  # the other DEM's analysis under this DEM's name
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path / "a"))
    an._CACHE.clear()
    again = an.prepare_example(white_mountains, 32)
    assert again.strong_mask.shape == own.strong_mask.shape
    assert np.array_equal(again.strong_mask, own.strong_mask) and again.relief == own.relief
    assert len(again.samples["ridge"]) == len(own.samples["ridge"])
