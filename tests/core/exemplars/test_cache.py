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


def test_a_stored_analysis_is_held_as_arrays_that_give_the_same_graph(white_mountains, tmp_path, monkeypatch):
    """A library's analyses are held by every tile worker: the graphs and
    samples read from the cache are tables over the stored arrays, which
    give the nodes, paths and samples the analysis made."""
    from terrasynth_core.exemplars import prepare as an
    from terrasynth_core.features.graph import NodeTable, PathTable
    from terrasynth_core.features.samples import SampleTable

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    an._CACHE.clear()
    made = an.prepare_example(white_mountains, 32)
    an._CACHE.clear()
    stored = an.prepare_example(white_mountains, 32)
    for kind in ("ridges", "valleys"):
        a, b = getattr(made.features, kind), getattr(stored.features, kind)
        assert isinstance(b.nodes, NodeTable) and isinstance(b.paths, PathTable)
        assert len(a.nodes) == len(b.nodes) > 0 and len(a.paths) == len(b.paths) > 0
        assert list(a.nodes) == list(b.nodes)  # FeatureNode compares by value
        assert all(p.start == q.start and p.end == q.end and np.array_equal(p.points, q.points)
                   for p, q in zip(a.paths, b.paths))
        assert b.nodes[-1] == a.nodes[-1] and b.nodes[1:3] == tuple(a.nodes[1:3])
        assert np.array_equal(b.node_positions(), a.node_positions())
        assert np.array_equal(b.path_ends(), a.path_ends()) and b.total_length() == a.total_length()
        with np.testing.assert_raises(IndexError):
            b.paths[len(b.paths)]
    samples = stored.samples["ridge"]
    assert isinstance(samples, SampleTable)
    assert samples[-1].degree == made.samples["ridge"][-1].degree
    assert np.array_equal(samples[-1].crossings, made.samples["ridge"][-1].crossings)


def test_an_entry_holding_its_large_arrays_inside_is_made_again_with_them_beside_it(white_mountains, tmp_path,
                                                                                    monkeypatch):
    """An entry written before side files would be read into memory whole:
    it is taken as absent, and the array stored anew is mapped."""
    from terrasynth_core.exemplars import cache

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    heights = np.asarray(white_mountains.heights, dtype=np.float32)
    assert heights.nbytes >= cache.SIDE_BYTES
    key = "old-style-entry"
    with open(cache._path(key), "wb") as f:  # as the cache wrote it before side files
        np.savez(f, key=np.array(key), heights=heights)
    assert cache.load_array(key) is None
    kept = cache.kept_array(key, lambda: heights)
    assert isinstance(kept, np.memmap) and np.array_equal(kept, heights)
    assert list(tmp_path.glob("*.heights.npy"))


def test_a_side_file_as_written_is_not_read_through_and_a_changed_one_is_caught(white_mountains, tmp_path,
                                                                               monkeypatch):
    """A side file whose size and modification time are those its entry
    names is used without hashing it again (a cold run read 15 MB fill
    indexes through the hash in every process); one rewritten since, even
    at the same size, is hashed, and its entry is taken as absent."""
    import os

    from terrasynth_core.exemplars import cache

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    heights = np.asarray(white_mountains.heights, dtype=np.float32)
    cache.save_array("side-check", heights)
    [side] = tmp_path.glob("*.heights.npy")
    hashed = []
    blake2b = cache.hashlib.blake2b
    monkeypatch.setattr(cache.hashlib, "blake2b", lambda *a, **k: hashed.append(1) or blake2b(*a, **k))
    cache._CHECKED.clear()  # as in a new process
    assert np.array_equal(cache.load_array("side-check"), heights)
    assert hashed == []
    data = bytearray(side.read_bytes())
    data[-4:] = b"\x00\x00\x80\x7f"  # the last height made infinite, the size kept
    side.write_bytes(bytes(data))
    st = side.stat()
    os.utime(side, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))  # a rewrite within the clock's tick
    cache._CHECKED.clear()
    assert cache.load_array("side-check") is None
    assert hashed
