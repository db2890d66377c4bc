"""The mapped cache pages a process holds, handed back past a budget."""

import numpy as np
import pytest

from terrasynth_core.exemplars import cache, mapped_pages
from terrasynth_core.matching import window_index
from terrasynth_core.matching.fill_search import FillSearch

needs_proc = pytest.mark.skipif(mapped_pages.file_resident() is None, reason="reads /proc/self/statm (Linux)")


@pytest.fixture
def releasers(monkeypatch):
    """The releasers registered during the test alone (the fill indexes' kept)."""
    monkeypatch.setattr(mapped_pages, "_RELEASERS", list(mapped_pages._RELEASERS))
    return mapped_pages._RELEASERS


def _mapped(key: str, megabytes: int) -> np.ndarray:
    values = np.arange(megabytes * 2**18, dtype=np.float32)
    return cache.kept_array(key, lambda: values)


@needs_proc
def test_released_pages_leave_the_resident_set_and_read_back_the_same():
    array = _mapped("mapped-pages-test", 48)
    assert isinstance(array, np.memmap)
    total = float(array.sum(dtype=np.float64))  # every page touched
    before = mapped_pages.file_resident()
    mapped_pages.release()
    after = mapped_pages.file_resident()
    assert before - after >= 40 * 2**20
    assert float(array.sum(dtype=np.float64)) == total
    assert mapped_pages.file_resident() - after >= 40 * 2**20  # mapped again as read


def test_keep_within_budget_releases_only_past_it(releasers):
    calls = []
    mapped_pages.on_release(lambda: calls.append(1))
    if mapped_pages.file_resident() is None:
        assert not mapped_pages.keep_within_budget(0)
        return
    assert not mapped_pages.keep_within_budget(2**60)
    assert calls == []
    assert mapped_pages.keep_within_budget(0)
    assert calls == [1]


def test_checked_keeps_the_budget_after_each_item(monkeypatch):
    """A loop over a library's examples checks the budget after each one,
    once the loop's body has read it (not only when the loop is done)."""
    events = []
    monkeypatch.setattr(mapped_pages, "keep_within_budget", lambda: events.append("check"))
    for item in mapped_pages.checked(["a", "b", "c"]):
        events.append(item)
    assert events == ["a", "check", "b", "check", "c", "check"]


@needs_proc
def test_a_library_read_whole_in_a_checked_loop_stays_within_the_budget(monkeypatch):
    """Six 24 MB examples read whole one after another: past a 64 MB
    budget (over what the process held before) the pages are handed back
    as the loop goes, so it never holds them all."""
    arrays = [_mapped(f"mapped-pages-library-{i}", 24) for i in range(6)]
    mapped_pages.release()
    start = mapped_pages.file_resident()
    monkeypatch.setattr(mapped_pages, "MAPPED_BUDGET", start + 64 * 2**20)
    monkeypatch.setattr(mapped_pages, "_floor", 0)
    highest = 0
    for a in mapped_pages.checked(arrays):
        a.sum(dtype=np.float64)
        highest = max(highest, mapped_pages.file_resident() - start)
    assert highest < 100 * 2**20  # (all six would be 144 MB)


def test_a_check_while_another_thread_checks_leaves_it_to_that_one(releasers):
    calls = []
    mapped_pages.on_release(lambda: calls.append(1))
    with mapped_pages._CHECK:  # (another thread deciding, or releasing)
        assert not mapped_pages.keep_within_budget(0)
    assert calls == []


def test_arrays_in_memory_are_not_tracked():
    before = len(mapped_pages._MAPS)
    array = np.zeros(10)
    assert mapped_pages.track(array) is array
    assert len(mapped_pages._MAPS) == before


def test_pages_it_cannot_hand_back_do_not_make_every_call_release(releasers, monkeypatch):
    calls = []
    mapped_pages.on_release(lambda: calls.append(1))
    monkeypatch.setattr(mapped_pages, "_floor", 0)
    monkeypatch.setattr(mapped_pages, "file_resident", lambda: 600)  # nothing released: stays at 600
    assert [mapped_pages.keep_within_budget(500) for _ in range(3)] == [True, False, False]
    assert calls == [1]


def test_a_release_closes_the_open_indexes_and_they_answer_as_before(white_mountains, monkeypatch, tmp_path):
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    example = white_mountains.heights[:200, :200]
    rng = np.random.default_rng(3)
    target = example[60:92, 70:102] + rng.normal(0.0, 3.0, (32, 32)).astype(np.float32)
    filled = np.zeros((32, 32), bool)
    filled[:11] = True
    search = FillSearch(example, (32, 32), coarse_factor=1)
    want = search.candidates(target, filled)
    assert window_index._OPEN._values
    mapped_pages.release()
    assert not window_index._OPEN._values
    np.testing.assert_array_equal(search.candidates(target, filled), want)


def test_an_index_closed_by_another_thread_during_a_query_still_answers(white_mountains, monkeypatch, tmp_path):
    """A release (another thread's) just after the index was opened for a
    query of its centres: the index asked stays alive until the answer."""
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path))
    example = white_mountains.heights[:200, :200]
    target = np.ascontiguousarray(example[60:92, 70:102])
    filled = np.zeros((32, 32), bool)
    filled[:11] = True
    zone = FillSearch(example, (32, 32), coarse_factor=1).zone_index(filled)
    vector = zone.query_vector(target, filled)
    want = zone.cluster_distance(vector)
    opened = window_index.ZoneIndex._faiss

    def released(self):
        index = opened(self)
        mapped_pages.release()
        import gc
        gc.collect()
        return index

    monkeypatch.setattr(window_index.ZoneIndex, "_faiss", released)
    for _ in range(3):
        assert zone.cluster_distance(vector) == want
