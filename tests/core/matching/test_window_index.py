"""The indexed fill search (Liang et al. 2001 zones, PCA, faiss IVF) against
the exhaustive FFT search, its disk cache and its determinism."""

import numpy as np
import pytest

from terrasynth_core.exemplars import cache
from terrasynth_core.matching import window_index
from terrasynth_core.matching.fill_search import FftFillSearch, FillSearch
from terrasynth_core.matching.window_index import block_means, zone_cells, zone_of


def test_zone_is_the_strips_at_least_half_filled():
    filled = np.zeros((30, 30), bool)
    filled[:10] = True  # top strip
    filled[:, :2] = True  # with the top's share of it, 140 of the left strip's 300 cells
    assert zone_of(filled, 10) == 1
    filled[:, :6] = True
    assert zone_of(filled, 10) == 1 | 4
    filled[:] = True
    assert zone_of(filled, 10) == 15
    corner = np.zeros((30, 30), bool)
    corner[25:, 27:] = True  # a little terrain, in no half-filled strip
    assert zone_of(corner, 10) in (2, 8)  # the fullest strip alone


def test_zone_cells_cover_the_strips_on_the_coarse_grid():
    top = zone_cells((40, 40), 12, 1, 4)
    assert set(np.unique(top[:, 0])) == {0, 1, 2}  # coarse rows centred above row 12
    assert top.shape == (3 * 10, 2)
    ring = zone_cells((40, 40), 12, 15, 4)
    assert ring.shape[0] == 100 - 4 * 4  # all but the 4x4 centre


def test_block_means_are_the_means_of_the_blocks_below_right():
    a = np.arange(30, dtype=np.float32).reshape(5, 6)
    b = block_means(a, 2)
    assert b.shape == (4, 5)
    assert b[1, 2] == pytest.approx(a[1:3, 2:4].mean())


def _windows_from(example, rng, n, window, noise, zones=((0, 2), (0, 1, 2, 3))):
    """Output windows cut from the example (plus noise), each filled on the
    strips of one of ``zones`` (side numbers: top, bottom, left, right)
    and at a few random cells beside."""
    h, w = window
    out = []
    for i in range(n):
        r = int(rng.integers(0, example.shape[0] - h))
        c = int(rng.integers(0, example.shape[1] - w))
        filled = rng.random(window) < 0.05
        sides = zones[i % len(zones)]
        ov = h // 3
        for s in sides:
            filled[[np.s_[:ov], np.s_[-ov:], np.s_[:, :ov], np.s_[:, -ov:]][s]] = True
        target = example[r:r + h, c:c + w] + rng.normal(0, noise, window).astype(np.float32) + 50.0
        out.append((target, filled))
    return out


def test_index_search_finds_the_exhaustive_searchs_best(white_mountains):
    """On real terrain the index's shortlist, re-ranked exactly, finds a
    window as good as the exhaustive search's best, nearly always the same."""
    example = white_mountains.heights[:300, :300]
    old = FftFillSearch(example, (32, 32), coarse_factor=2)
    new = FillSearch(example, (32, 32), coarse_factor=2, use_cache=False)
    assert new.indexes is not None  # 18 000 windows: indexed, not exhaustive
    rng = np.random.default_rng(5)
    same, ratios = 0, []
    for target, filled in _windows_from(example, rng, 12, (32, 32), noise=5.0):
        (o_pos, *_), = old.best(target, filled, 1, None)
        (n_pos, *_), = new.best(target, filled, 1, None)
        o_score, n_score = new.scores(target, filled, np.array([o_pos, n_pos]))
        same += o_pos == n_pos
        ratios.append(n_score / o_score)
    assert same >= 10
    assert max(ratios) < 1.05


def test_exact_match_is_found_and_refined_to_the_cell(white_mountains):
    example = white_mountains.heights[:300, :300]
    search = FillSearch(example, (40, 40), coarse_factor=3, use_cache=False)
    filled = np.zeros((40, 40), bool)
    filled[:13] = True
    filled[:, :13] = True
    target = example[101:141, 157:197] - 30.0
    (r, c), ssd, offset, _ = search.best(target, filled, 3, None)[0]
    assert (r, c) == (101, 157)
    assert ssd < 1e-6 and offset == pytest.approx(-30.0, abs=1e-3)


def test_small_examples_are_scored_exhaustively(white_mountains):
    """Under EXHAUSTIVE_BELOW windows no index is built, and the best
    window is the brute-force best."""
    example = white_mountains.heights[:60, :60]
    search = FillSearch(example, (24, 24), coarse_factor=1)
    assert search.indexes is None
    filled = np.zeros((24, 24), bool)
    filled[:8] = True
    target = example[10:34, 20:44] + np.random.default_rng(0).normal(0, 3, (24, 24))
    grid = np.argwhere(np.ones((37, 37), bool))
    best = grid[int(np.argmin(search.scores(target, filled, grid)))]
    assert search.best(target, filled, 1, None)[0][0] == tuple(best)


def test_indexes_are_stored_and_loaded_from_the_disk_cache(white_mountains, monkeypatch, tmp_path):
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    example = white_mountains.heights[:200, :200]
    rng = np.random.default_rng(2)
    windows = _windows_from(example, rng, 4, (32, 32), noise=3.0, zones=((0, 2),))
    first = FillSearch(example, (32, 32), coarse_factor=1)
    expected = [first.candidates(t, m) for t, m in windows]
    files = sorted(p.name for p in tmp_path.iterdir())
    assert any("-windows-v" in name for name in files) and all(name.startswith("example-v") for name in files)

    def no_build(*args, **kwargs):
        raise AssertionError("built again instead of loaded")

    monkeypatch.setattr(window_index, "build_zone_index", no_build)
    second = FillSearch(example, (32, 32), coarse_factor=1)
    for (t, m), want in zip(windows, expected):
        np.testing.assert_array_equal(second.candidates(t, m), want)
    # The roughness prior is stored too, and read back as made.
    assert any("-prior-" in p.name for p in tmp_path.iterdir())
    np.testing.assert_array_equal(second.prior, first.prior)
    # The prior is a coordinate of every indexed vector: another prior
    # (a new way of making it) keys other indexes, never stale ones.
    offered = second.prior[second.positions[:, 0], second.positions[:, 1]]
    keys = {window_index.index_key(example, (32, 32), second.overlap, second.positions, prior)
            for prior in (offered, 2.0 * offered)}
    assert len(keys) == 2


def test_a_damaged_index_file_is_rebuilt(white_mountains, monkeypatch, tmp_path):
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    example = white_mountains.heights[:200, :200]
    target, filled = _windows_from(example, np.random.default_rng(3), 1, (32, 32), noise=3.0, zones=((0,),))[0]
    want = FillSearch(example, (32, 32), coarse_factor=1).candidates(target, filled)
    for path in tmp_path.iterdir():
        path.write_bytes(b"PK\x03\x04 not an index")
    got = FillSearch(example, (32, 32), coarse_factor=1).candidates(target, filled)
    np.testing.assert_array_equal(got, want)
    # The entry (its large members are files beside it) was written again, whole.
    assert cache.load_arrays(next(iter(tmp_path.glob("*.npz"))).stem.split("-", 2)[2]) is not None


def test_stored_indexes_past_the_open_limit_are_closed_and_opened_again(white_mountains, monkeypatch, tmp_path):
    """A process keeps few stored indexes open (each holds its centroids in
    memory, so a library's worth grew with its size): one closed is opened
    again when asked and answers as before."""
    from terrasynth_core.memo import Memo

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    example = white_mountains.heights[:200, :200]
    windows = _windows_from(example, np.random.default_rng(4), 4, (32, 32), noise=3.0, zones=((0,), (2,)))
    want = [FillSearch(example, (32, 32), coarse_factor=1).candidates(t, m) for t, m in windows]
    opened = []

    def counted(path):
        opened.append(path)
        return open_stored(path)

    open_stored = window_index._open_stored
    monkeypatch.setattr(window_index, "_open_stored", counted)
    monkeypatch.setattr(window_index, "_OPEN", Memo(1))
    search = FillSearch(example, (32, 32), coarse_factor=1)
    for _ in range(2):
        for (t, m), w in zip(windows, want):  # zones top, left, top, left: one open at a time
            np.testing.assert_array_equal(search.candidates(t, m), w)
    assert len(opened) == 8 and len(set(opened)) == 2
    assert len(window_index._OPEN._values) == 1


def _first_zone_closed(white_mountains, monkeypatch, tmp_path):
    """A search whose first zone's index was stored, answered and closed
    (one index open at a time): the search, that window, its answer."""
    from terrasynth_core.memo import Memo

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(window_index, "_OPEN", Memo(1))
    example = white_mountains.heights[:200, :200]
    (t1, m1), (t2, m2) = _windows_from(example, np.random.default_rng(5), 2, (32, 32), noise=3.0,
                                       zones=((0,), (2,)))
    search = FillSearch(example, (32, 32), coarse_factor=1)
    want = search.candidates(t1, m1)
    search.candidates(t2, m2)  # closes the first zone's index
    return search, (t1, m1), want


def _rewrite(files, contents) -> None:
    """New files with these contents under the old names, as the cache
    renames them on (a new inode and time)."""
    for f, data in zip(files, contents):
        f.unlink()
        f.write_bytes(data)


def test_a_stored_index_replaced_while_closed_is_made_again(white_mountains, monkeypatch, tmp_path):
    """The cache cleared during a run: an index closed since is built
    again, the same, instead of mapping whatever file now has its name."""
    search, window, want = _first_zone_closed(white_mountains, monkeypatch, tmp_path)
    # Each zone's file now holds the other's index: valid indexes, but not this one.
    files = sorted(tmp_path.glob("*.bin"))
    assert len(files) == 2
    _rewrite(files, [f.read_bytes() for f in reversed(files)])
    np.testing.assert_array_equal(search.candidates(*window), want)


def test_a_stored_index_written_again_while_closed_is_read_again_not_built(white_mountains, monkeypatch, tmp_path):
    """Another worker storing the same index renames a new file onto the
    old one: the closed index is read again from the cache entry (its
    digest checked), not built."""
    search, window, want = _first_zone_closed(white_mountains, monkeypatch, tmp_path)
    files = sorted(tmp_path.glob("*.bin"))
    _rewrite(files, [f.read_bytes() for f in files])

    def no_build(*args, **kwargs):
        raise AssertionError("built again instead of read")

    monkeypatch.setattr(window_index, "build_zone_index", no_build)
    np.testing.assert_array_equal(search.candidates(*window), want)


def test_builds_are_deterministic(white_mountains):
    """Two builds from scratch give the same index, byte for byte, so a
    seed gives the same terrain whether or not the cache is warm."""
    example = white_mountains.heights[:200, :200]
    a = FillSearch(example, (32, 32), coarse_factor=2, use_cache=False).indexes.get(15).to_arrays()
    b = FillSearch(example, (32, 32), coarse_factor=2, use_cache=False).indexes.get(15).to_arrays()
    assert a.keys() == b.keys()
    for name in a:
        np.testing.assert_array_equal(a[name], b[name])


def test_lazy_indexes_share_the_coarse_grid_and_build_the_same_index():
    """The zones of one example read one coarse grid (made once): each
    index is byte for byte the one a lone build makes."""
    import faiss

    rng = np.random.default_rng(3)
    example = np.cumsum(np.cumsum(rng.normal(size=(150, 170)), 0), 1).astype(np.float32)
    window, overlap = (32, 32), 6
    positions = np.stack(np.meshgrid(np.arange(0, 118, 3), np.arange(0, 138, 3), indexing="ij"), -1).reshape(-1, 2)
    prior = rng.random(len(positions)) * 0.1
    lazy = window_index.LazyIndexes(example, window, overlap, positions, prior)
    for zone in (15, 1, 6):
        alone = window_index.build_zone_index(example, window, overlap, zone, positions, prior)
        shared = lazy.get(zone)
        assert np.array_equal(faiss.serialize_index(shared._index), faiss.serialize_index(alone._index))
        assert np.array_equal(shared.pca_axes, alone.pca_axes)
    assert lazy._blocks is not None


_SIMD_PROBE = """
import hashlib, sys
import numpy as np
import faiss
from terrasynth_core.matching.window_index import ivf_index
if sys.argv[1] != "AUTO":  # (AUTO: the level faiss chose for this CPU)
    faiss.SIMDConfig.set_level(getattr(faiss, "SIMDLevel_" + sys.argv[1]))  # as another CPU would choose
rng = np.random.default_rng(5)
vectors = rng.normal(size=(20000, 24)).astype(np.float32)
index = ivf_index(vectors)
d, i = index.search(vectors[:500] + 0.01, 20)
print(faiss.SIMDConfig.get_level_name(), hashlib.sha256(
    faiss.serialize_index(index).tobytes() + d.tobytes() + i.tobytes()).hexdigest())
"""


def test_indexes_and_searches_do_not_depend_on_the_cpus_simd_kernels():
    """faiss picks AVX2 or AVX-512 kernels by the CPU, and they give other
    k-means cells and distances (on these vectors raw faiss gives three
    different digests at NONE, AVX2 and AVX-512): pinned to the portable
    kernels, an index and its answers are the same bytes whatever the CPU
    would have chosen."""
    import subprocess
    import sys

    import faiss

    # The portable level is on every CPU, and the CPU's own choice too: the
    # check holds (and says the pin took) even where faiss offers no other.
    levels = ["AUTO"] + [name for name in ("NONE", "AVX2", "AVX512", "ARM_NEON")
                         if faiss.SIMDConfig.is_simd_level_available(getattr(faiss, "SIMDLevel_" + name))]
    outs = {tuple(subprocess.run([sys.executable, "-c", _SIMD_PROBE, name], capture_output=True, text=True,
                                 check=True).stdout.split()) for name in levels}
    assert len(outs) == 1
    assert next(iter(outs))[0] == "NONE"


def test_a_zone_made_is_handed_out_while_another_zone_is_being_built():
    """The live preparation builds zone after zone in the background; a
    stroke's search asking for a zone already made, or another one, does not
    wait for that build."""
    import threading
    import types

    building = threading.Event()
    release = threading.Event()

    class Slow(window_index.LazyIndexes):
        def _key(self):
            return "k"

        def _build(self, zone):
            if zone == 15:
                building.set()
                release.wait(30)
            return types.SimpleNamespace(zone=zone)

    indexes = Slow(None, (8, 8), 2, None, None)
    assert indexes.get(3).zone == 3
    slow = threading.Thread(target=indexes.get, args=(15,))
    slow.start()
    assert building.wait(30)
    got = []
    asking = threading.Thread(target=lambda: got.extend([indexes.get(3), indexes.get(5)]))
    asking.start()
    asking.join(10)
    waited = asking.is_alive()
    release.set()
    slow.join(30)
    asking.join(30)
    assert not waited and [g.zone for g in got] == [3, 5]
    assert indexes.get(15).zone == 15


def test_an_example_whose_windows_are_all_alike_still_offers_windows():
    # A flat DEM as a style: its index's k-means centres tie, most lists are
    # empty, and the probed ones held nothing, so a fill window had no
    # candidate at all (an IndexError in the CLI).  The search widens to
    # every list when the probed ones come back short.
    flat = np.full((300, 300), 500.0, np.float32)
    search = FillSearch(flat, (32, 32), coarse_factor=1, use_cache=False)
    assert search.indexes is not None
    filled = np.zeros((32, 32), bool)
    filled[:, :10] = True
    target = np.random.default_rng(0).normal(500.0, 5.0, (32, 32)).astype(np.float32)
    assert len(search.candidates(target, filled)) == search.shortlist
    assert len(search.best(target, filled, 3, np.random.default_rng(0))) >= 1
