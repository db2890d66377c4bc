"""The worker processes: one executor for the whole process whichever
thread asks, and kits kept for the next stage (a live stroke's fill)."""

from __future__ import annotations

import threading
from pathlib import Path

from terrasynth_core.synthesis import workers


def test_every_thread_gets_the_same_executor():
    # The app drains each run and each live stroke on a new thread; loky's
    # own reusable executor is per thread and started cold workers each time.
    here = workers.executor(1)
    got = []
    threads = [threading.Thread(target=lambda: got.append(workers.executor(1))) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(pool is here for pool in got)
    assert workers.executor(1) is here


def _second(kit, value):
    return kit[1] + value


def test_a_kept_kit_is_written_once_and_loaded_once(monkeypatch):
    loads = []
    load = workers.pickle.load
    monkeypatch.setattr(workers.pickle, "load", lambda f: loads.append(1) or load(f))
    kit = ("searches", 40)
    with workers.KitWorkers(kit, 2, keep=("stroke kit",)) as first:
        assert first.submit(_second, 2).result() == 42
    with workers.KitWorkers(kit, 2, keep=("stroke kit",)) as second:
        assert second.submit(_second, 3).result() == 43
    assert first._path == second._path and Path(first._path).exists()
    # In this process (the worker's side of it): loaded on the first task only.
    assert workers.with_kit(first._path, _second, 1) == 41
    assert workers.with_kit(first._path, _second, 2) == 42
    assert len(loads) == 1


def test_kept_kits_are_bounded_and_unkept_ones_removed():
    paths = []
    for i in range(workers.KEPT_KITS + 1):
        kit_workers = workers.KitWorkers(("kit", i), 2, keep=("bounded", i))
        with kit_workers:
            assert kit_workers.submit(_second, 0).result() == i
        paths.append(kit_workers._path)
    assert not Path(paths[0]).exists()  # the oldest went
    assert all(Path(p).exists() for p in paths[1:])
    with workers.KitWorkers(("plain", 7), 2) as plain:
        assert plain.submit(_second, 0).result() == 7
    assert not Path(plain._path).exists()


def test_a_worker_holds_a_bounded_number_of_kits(tmp_path):
    paths = []
    for i in range(workers.KEPT_KITS + 2):
        path = tmp_path / f"kit{i}.pkl"
        path.write_bytes(workers.pickle.dumps(("kit", i)))
        paths.append(str(path))
        assert workers.with_kit(str(path), _second, 0) == i
    assert len(workers._KITS) == workers.KEPT_KITS
    assert [which[0] for which in workers._KITS] == paths[-workers.KEPT_KITS:]
