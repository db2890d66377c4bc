"""The example library as a tiled run's workers hold it: stored once in the
example cache, memory-mapped, keyed by content; a damaged entry is rebuilt,
never trusted."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from terrasynth_core.exemplars import cache
from terrasynth_core.matching.fill_search import FillSearch
from terrasynth_core.tiled.library import LibraryExample, library_examples


@pytest.fixture
def library_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    return tmp_path


def _mapped(array: np.ndarray) -> bool:
    """Whether ``array``'s memory is a mapped file."""
    while array is not None and not isinstance(array, np.memmap):
        array = array.base if isinstance(array.base, np.ndarray) else None
    return array is not None


def test_an_example_sent_to_a_worker_arrives_stored_and_mapped(white_mountains, library_dir):
    [shipped] = library_examples([white_mountains])
    arrived = pickle.loads(pickle.dumps(shipped, protocol=5))
    assert isinstance(arrived, LibraryExample) and _mapped(arrived.heights)
    assert np.array_equal(arrived.heights, white_mountains.heights)
    assert arrived.cell_size == white_mountains.cell_size and arrived.source == white_mountains.source
    # Sent again (another worker, a restarted one): the stored file is used.
    files = sorted(library_dir.iterdir())
    again = pickle.loads(pickle.dumps(arrived, protocol=5))
    assert sorted(library_dir.iterdir()) == files and np.array_equal(again.heights, white_mountains.heights)


def test_without_the_cache_an_example_stays_in_memory(white_mountains, monkeypatch):
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", "")
    arrived = pickle.loads(pickle.dumps(library_examples([white_mountains])[0]))
    assert not _mapped(arrived.heights) and np.array_equal(arrived.heights, white_mountains.heights)


def _window(example: np.ndarray):
    rng = np.random.default_rng(5)
    target = example[40:72, 60:92] + rng.normal(0.0, 2.0, (32, 32))
    filled = np.zeros((32, 32), bool)
    filled[:11] = True
    return target, filled


@pytest.mark.parametrize("suffix", [".bin", ".npy"])
def test_a_damaged_side_file_is_rebuilt_not_trusted(white_mountains, library_dir, suffix):
    """Fill indexes are stored as a faiss file and arrays beside the entry
    (mapped when loaded); one byte changed in either makes the entry
    unreadable, and the index is built again: the same candidates."""
    example = white_mountains.heights  # 400 x 400: the windows' corners (1 MB) are a side file too
    target, filled = _window(example)
    want = FillSearch(example, (32, 32), coarse_factor=1).candidates(target, filled)
    loaded = FillSearch(example, (32, 32), coarse_factor=1)
    np.testing.assert_array_equal(loaded.candidates(target, filled), want)  # from the stored files
    side = next(p for p in library_dir.iterdir() if p.name.endswith(suffix) and "windows" in p.name)
    data = bytearray(side.read_bytes())
    data[len(data) // 2] ^= 0xFF
    side.write_bytes(bytes(data))
    cache._CHECKED.clear()  # a new process: nothing checked yet
    [entry] = [p for p in library_dir.glob("*.npz") if p.stem.startswith(side.name.split(".")[0])]
    assert cache.load_arrays(entry.stem.split("-", 2)[2]) is None  # not trusted
    np.testing.assert_array_equal(FillSearch(example, (32, 32), coarse_factor=1).candidates(target, filled), want)
    assert cache.load_arrays(entry.stem.split("-", 2)[2]) is not None  # written again, whole
