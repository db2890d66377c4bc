"""The worker processes: one executor for the whole process whichever
thread asks, and kits kept for the next stage (a live stroke's fill)."""

from __future__ import annotations

import os
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


def _where(kit):
    """In a worker: its process and the kit object it holds."""
    return os.getpid(), id(kit)


def test_a_kept_kit_is_written_once_and_a_worker_loads_it_once():
    kit = ("searches", 40)
    with workers.KitWorkers(kit, 2, keep=("stroke kit",)) as first:
        assert first.submit(_second, 2).result() == 42
        where = first.submit(_where).result()
    with workers.KitWorkers(kit, 2, keep=("stroke kit",)) as second:
        assert second.submit(_second, 3).result() == 43
        assert second.submit(_where).result() == where  # the same worker, the kit it loaded before
    assert first._path == second._path and Path(first._path).exists()
    assert where[0] != os.getpid()


def test_kept_kits_are_bounded_never_removed_in_use_and_unkept_ones_removed():
    busy = workers.KitWorkers(("kit", 100), 2, keep=("bounded", "busy"))
    with busy:
        assert busy.submit(_second, 0).result() == 100
        paths = []
        for i in range(workers.KEPT_KITS + 1):
            kit_workers = workers.KitWorkers(("kit", i), 2, keep=("bounded", i))
            with kit_workers:
                assert kit_workers.submit(_second, 0).result() == i
            paths.append(kit_workers._path)
        assert Path(busy._path).exists()  # in use: kept beyond the bound
        assert sum(Path(p).exists() for p in paths) <= workers.KEPT_KITS
        assert Path(paths[-1]).exists()
    with workers.KitWorkers(("plain", 7), 2) as plain:
        assert plain.submit(_second, 0).result() == 7
    assert not Path(plain._path).exists()


def test_stages_making_the_same_kept_kit_together_share_one_file():
    import tempfile

    kit = ("together", 1)
    results, barrier = [], threading.Barrier(3)
    folder = Path(tempfile.gettempdir())
    before = set(folder.glob("terrasynth-kit-*.pkl"))

    def stage():
        barrier.wait(10)
        with workers.KitWorkers(kit, 2, keep=("together",)) as kw:
            assert kw.submit(_second, 0).result() == 1
            results.append(kw._path)

    threads = [threading.Thread(target=stage) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert len(results) == 3 and len(set(results)) == 1 and Path(results[0]).exists()
    # The files the losers of the race wrote are gone: only the kept one is new.
    assert set(folder.glob("terrasynth-kit-*.pkl")) - before <= {Path(results[0])}


def test_a_worker_holds_a_bounded_number_of_kits(tmp_path):
    paths = []
    for i in range(workers.KEPT_KITS + 2):
        path = tmp_path / f"kit{i}.pkl"
        path.write_bytes(workers.pickle.dumps(("kit", i)))
        paths.append(str(path))
        assert workers.with_kit(str(path), _second, 0) == i
    assert len(workers._KITS) == workers.KEPT_KITS
    assert [which[0] for which in workers._KITS] == paths[-workers.KEPT_KITS:]
