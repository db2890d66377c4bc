"""The disk cache kept within its size: least recently used entries go whole."""

import os
import time

import numpy as np
import pytest

from terrasynth_core.exemplars import cache, cache_size

MB = 2**20


def _entry(key: str, megabytes: int, used_hours_ago: float) -> list[str]:
    """A real entry (an ``.npz`` and its side file) last used that long ago;
    the names of its files."""
    cache.save_arrays(key, {"heights": np.zeros(megabytes * MB // 8)})
    path = cache._path(key)
    files = sorted(p.name for p in path.parent.glob(path.stem + ".*"))
    when = time.time() - used_hours_ago * 3600
    for name in files:
        os.utime(path.parent / name, (when, when))
    return files


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(cache_size, "_last_scan", float("inf"))  # no scan while the entries are laid out
    return tmp_path


def test_the_least_recently_used_entries_go_whole_down_to_four_fifths_of_the_limit(folder):
    oldest = _entry("a", 4, used_hours_ago=30)
    older = _entry("b.with.dots", 4, used_hours_ago=20)
    recent = _entry("c", 4, used_hours_ago=2)
    just_used = _entry("d", 4, used_hours_ago=0.01)
    assert all(len(files) == 2 for files in (oldest, older, recent, just_used))  # .npz and .heights.npy
    loose_young = folder / "example-v1-e.heights.npy"  # an entry being written: side files come first
    loose_young.write_bytes(b"x" * MB)
    loose_old = folder / ".example-v1-f.npz.0123456789ab.tmp"  # a crash's unfinished file
    loose_old.write_bytes(b"x" * MB)
    os.utime(loose_old, (time.time() - 7200,) * 2)
    total = sum(p.stat().st_size for p in folder.iterdir())
    assert total > 16 * MB

    removed = cache_size.keep_within(folder, 12 * MB)
    left = {p.name for p in folder.iterdir()}
    assert not left & set(oldest + older) and not loose_old.exists()
    assert set(recent + just_used) <= left and loose_young.exists()
    assert total - removed == sum(p.stat().st_size for p in folder.iterdir()) <= 0.8 * 12 * MB
    assert cache.load_arrays("a") is None and cache.load_arrays("c") is not None


def test_files_that_are_not_the_caches_are_never_counted_nor_removed(folder):
    # TERRASYNTH_CACHE_DIR may name a folder of the user's own.
    mine = [folder / "N44W072.hgt", folder / "notes.txt", folder / ".hidden.tmp", folder / "example-video.mp4",
            folder / "example-v1-holiday.jpg"]
    for path in mine:
        path.write_bytes(b"x" * 3 * MB)
        os.utime(path, (time.time() - 30 * 86400,) * 2)
    entry = _entry("a", 2, used_hours_ago=30)
    assert cache_size.keep_within(folder, 4 * MB) == 0  # the cache's own 2 MB are within 4 MB (15 MB in all)
    assert cache_size.keep_within(folder, 1 * MB) >= 2 * MB
    assert all(path.exists() for path in mine) and not any((folder / name).exists() for name in entry)


def test_within_the_limit_nothing_goes_and_what_was_used_lately_never_goes(folder):
    a = _entry("a", 2, used_hours_ago=30)
    assert cache_size.keep_within(folder, 100 * MB) == 0
    b = _entry("b", 2, used_hours_ago=0.05)
    removed = cache_size.keep_within(folder, 1 * MB)  # over it, but only "a" is old enough to go
    left = {p.name for p in folder.iterdir()}
    assert not left & set(a) and set(b) <= left and removed >= 2 * MB


def test_a_read_marks_an_entry_used_and_a_write_keeps_the_folder_within_the_limit(folder, monkeypatch):
    _entry("a", 2, used_hours_ago=30)
    _entry("b", 2, used_hours_ago=20)
    assert cache.load_arrays("a") is not None  # read now: "b" is the least recently used
    monkeypatch.setenv("TERRASYNTH_CACHE_MAX_GB", str(5 * MB / 2**30))
    monkeypatch.setattr(cache_size, "_last_scan", float("-inf"))
    cache.save_arrays("c", {"heights": np.zeros(2 * MB // 8)})
    assert cache.load_arrays("b") is None
    assert cache.load_arrays("a") is not None and cache.load_arrays("c") is not None


def test_an_entry_being_rewritten_is_kept_whole(folder):
    # A writer lays fresh side files beside an old .npz before replacing it.
    files = _entry("a", 4, used_hours_ago=30)
    side = folder / next(name for name in files if not name.endswith(".npz"))
    os.utime(side)  # laid just now
    _entry("b", 4, used_hours_ago=20)
    cache_size.keep_within(folder, 2 * MB)
    assert all((folder / name).exists() for name in files) and cache.load_arrays("b") is None


def test_an_entry_used_since_the_scan_is_kept(folder, monkeypatch):
    files = _entry("a", 4, used_hours_ago=30)
    listing = cache_size._listing

    def listed_then_read(where):
        seen = listing(where)
        os.utime(folder / next(n for n in files if n.endswith(".npz")))  # read meanwhile by another process
        return seen

    monkeypatch.setattr(cache_size, "_listing", listed_then_read)
    assert cache_size.keep_within(folder, 1 * MB) == 0
    assert all((folder / name).exists() for name in files)


def test_a_write_never_fails_for_the_limit(folder, monkeypatch):
    monkeypatch.setenv("TERRASYNTH_CACHE_MAX_GB", "1e308")
    monkeypatch.setattr(cache_size, "_last_scan", float("-inf"))
    cache.save_arrays("a", {"heights": np.zeros(1000)})
    assert cache.load_arrays("a") is not None


@pytest.mark.parametrize("value", ["", "lots", "-1", "0", "nan"])
def test_a_limit_that_is_not_a_positive_number_is_the_default(monkeypatch, value):
    monkeypatch.setenv("TERRASYNTH_CACHE_MAX_GB", value)
    assert cache_size.cache_limit() == cache_size.DEFAULT_LIMIT_BYTES


def test_the_limit_is_read_in_gib(monkeypatch):
    monkeypatch.setenv("TERRASYNTH_CACHE_MAX_GB", "0.5")
    assert cache_size.cache_limit() == 2**29
    monkeypatch.setenv("TERRASYNTH_CACHE_MAX_GB", "inf")
    assert cache_size.cache_limit() == 10**6 * 2**30


def test_what_another_process_removed_meanwhile_counts_as_removed(folder, monkeypatch):
    # Two processes pruning from the same listing must not both go on to
    # newer entries.
    a = _entry("a", 4, used_hours_ago=30)
    b = _entry("b", 4, used_hours_ago=20)
    c = _entry("c", 4, used_hours_ago=10)
    listing = cache_size._listing

    def listed_then_pruned_elsewhere(where):
        seen = listing(where)
        for name in a:
            (folder / name).unlink()
        return seen

    monkeypatch.setattr(cache_size, "_listing", listed_then_pruned_elsewhere)
    cache_size.keep_within(folder, 11 * MB)  # 12 MB listed, down to 8.8: "a" alone is enough
    assert all((folder / name).exists() for name in b + c)


def test_one_process_prunes_at_a_time(folder, monkeypatch):
    # Pruners listing the folder at different moments removed twice what
    # was needed; a second one skips while the first holds the lock.
    pytest.importorskip("fcntl")
    pruned = []
    monkeypatch.setattr(cache_size, "keep_within", lambda where, limit: pruned.append(where))
    monkeypatch.setattr(cache_size, "_last_scan", float("-inf"))
    with cache_size._pruning(folder) as first:
        assert first
        cache_size.written(folder)  # another pruner: skipped
    assert pruned == []
    monkeypatch.setattr(cache_size, "_last_scan", float("-inf"))
    cache_size.written(folder)
    assert pruned == [folder]
