"""The run's worker processes: started once, reused by every run, handed
what a run's tasks need as one file.

Most of a run's CPU work holds the interpreter lock (graph cuts, warps,
many small array operations), so threads do not run it in parallel; worker
processes do.  They come from loky's reusable executor: started once (fork
and exec, safe beside Qt and BLAS threads; no ``if __name__ ==
"__main__"`` guard needed in a user's script) and reused by every later run.
What a stage's tasks need from the examples (their detail, feature pools,
fill searches) goes to the workers once per stage, as a *kit* file
(:class:`KitWorkers`) that a worker loads on its first task of the stage
(:func:`with_kit`); a fill's kit is kept for the next stage with the same
one (the next live stroke's fill).  Which process did a task changes nothing: tasks are
pure functions of what they are given.
"""

from __future__ import annotations

import atexit
import os
import pickle
import tempfile
import threading
import time
from collections import OrderedDict
from concurrent.futures import Future, wait
from pathlib import Path

#: Seconds an idle worker process waits for more work before it exits.
IDLE_SECONDS = 300

#: Environment variables that hold native libraries to one thread.
_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def executor(processes: int):
    """The worker processes' executor, ``processes`` of them: one for the
    whole process, whichever thread asks (a run's events are drained on
    a new thread each time in the app).

    loky's own reusable executor is kept per thread, so each run or live
    stroke on a new thread started a new executor with cold worker
    processes (imports, kits, indexes): eight worker processes in turn for
    a run and six live strokes in the app, where one serves them all now.
    This one is replaced only when broken, shut down or asked for another
    number of processes.
    """
    from loky import ProcessPoolExecutor

    with _EXECUTOR_LOCK:
        pool = _EXECUTOR.get("pool")
        # (loky's own reuse test reads the same flags.  The count asked for,
        # not the pool's: loky caps it on some systems.)
        if pool is not None and _EXECUTOR.get("processes") == processes and not (pool._flags.broken or
                                                                                 pool._flags.shutdown):
            return pool
        if pool is not None:
            pool.shutdown(wait=False)
        # One BLAS thread per worker: the processes themselves use the cores
        # (see pipeline.run_pipeline for what BLAS threads on top cost).  A
        # worker keeps its stage's kit (searches, indexes) by design: loky, where
        # psutil is installed (Dask brings it), would take that growth for a
        # leak and restart the worker mid-run, with a warning.
        pool = ProcessPoolExecutor(max_workers=processes, timeout=IDLE_SECONDS,
                                   env={**{name: "1" for name in _THREAD_VARIABLES},
                                        "LOKY_MAX_MEMORY_LEAK_SIZE": str(2**62)})
        _EXECUTOR.update(pool=pool, processes=processes)
        return pool


#: The executor of :func:`executor` (key ``"pool"``) and the count it was
#: made for (``"processes"``).
_EXECUTOR: dict = {}
_EXECUTOR_LOCK = threading.Lock()


@atexit.register
def _shut_down() -> None:
    # Before the interpreter tears its modules down: an executor collected
    # after that prints an ignored exception from loky's clean-up.
    with _EXECUTOR_LOCK:
        pool = _EXECUTOR.pop("pool", None)
    if pool is not None:
        pool.shutdown(wait=False)


def import_engine() -> None:
    """Import the extension modules a run's stages load on first use
    (faiss, PyMaxflow, the warps).

    A GUI calls this before its first run: importing faiss holds the GIL
    for 35-100 ms in one piece, which would stall its event loop if a run's
    thread did it."""
    from ..matching.window_index import faiss_module
    from ..placing import graph_cut  # noqa: F401
    from . import feature_patches  # noqa: F401

    faiss_module()  # (its kernels pinned before any index is read)


def _warm(shape: tuple[int, int]) -> int:
    """In a worker: import what a fill window and a feature preparation
    need and make the seam solver of the window's shape."""
    from ..blending.rectangle import rectangle_solver

    import_engine()
    rectangle_solver(shape)
    return os.getpid()


#: The warm-up tasks of the last :func:`warm_up` (see :func:`ready`).
_WARMING: list = []
_WARMING_LOCK = threading.Lock()


#: The process count of the last :func:`warm_up`, and when a task last
#: went to the workers (monotonic seconds).
_STATE = {"processes": 1, "sent": float("-inf")}


def _sent() -> None:
    with _WARMING_LOCK:
        _STATE["sent"] = time.monotonic()


def warm_up(processes: int, patch_size: int) -> None:
    """Start the worker processes now (in the background) and have them
    import and prepare what their tasks need, so they are ready when the
    run needs them.  Nothing happens for 1 process."""
    if processes > 1:
        pool = executor(processes - 1)
        futures = [pool.submit(_warm, (patch_size, patch_size)) for _ in range(processes - 1)]
        with _WARMING_LOCK:
            _WARMING[:] = futures
            _STATE.update(processes=processes, sent=time.monotonic())


def ready() -> bool:
    """Whether the workers of the last :func:`warm_up` have started and
    imported what they need (a task sent to them now runs at once; one sent
    earlier would wait for a fresh process's imports)."""
    with _WARMING_LOCK:
        futures = list(_WARMING)
    return bool(futures) and all(f.done() and not f.cancelled() and f.exception() is None for f in futures)


def wait_warm(timeout: float | None = None) -> bool:
    """Wait until the workers of the last :func:`warm_up` are warm (or
    ``timeout`` seconds); whether they are (:func:`ready`).  For benchmarks
    and tests that must time or exercise warm workers; a run never waits."""
    with _WARMING_LOCK:
        futures = list(_WARMING)
    wait(futures, timeout=timeout)
    return ready()


def running(processes: int) -> bool:
    """Whether a run of ``processes`` (this one included) finds worker
    processes up and warm: :func:`ready`, started for as many processes
    (another count would restart them), and used recently enough that they
    have not exited idle (:data:`IDLE_SECONDS`).  Work beside a short run
    (a live stroke's crop) goes to them only then: starting them would cost
    it more than they save."""
    with _WARMING_LOCK:
        idle = time.monotonic() - _STATE["sent"]
        same = _STATE["processes"] == processes
    return processes > 1 and same and idle < IDLE_SECONDS / 2 and ready()


def submit(processes: int, task, *args) -> Future:
    """``task(*args)`` on a worker process, for a run of ``processes``
    (this one included; above 1, and :func:`running` true)."""
    pool = executor(processes - 1)
    _sent()
    return pool.submit(task, *args)


class KitWorkers:
    """A stage's tasks on the worker processes; use as a context manager.

    What the tasks share (the *kit*) is pickled to a temporary file, and
    the executor fetched, when the first task is sent: a stage whose
    workers are never used pays nothing.  The file is removed on exit,
    unless the kit has a ``keep`` key: then the file is kept for the next
    stage whose kit has the same key (the next live stroke's fill), which
    neither pickles it again nor has the workers load it again
    (:data:`KEPT_KITS` files at most, removed at exit).

    Parameters
    ----------
    kit : object
        Picklable.
    processes : int
        The run's processes, this one included (above 1).
    keep : hashable, optional
        Says which kits are the same: equal keys, the same kit.
    """

    def __init__(self, kit, processes: int, *, keep=None):
        self.kit = kit
        self.processes = processes
        self.keep = keep
        self._path: str | None = None
        self._pool = None

    @property
    def started(self) -> bool:
        """Whether a task has been sent (the kit is with the workers)."""
        return self._pool is not None

    def submit(self, task, *args) -> Future:
        """``task(kit, *args)`` on a worker (:func:`with_kit`)."""
        if self._pool is None:
            self._path = _kit_file(self.kit) if self.keep is None else _use_kept_kit(self.keep, self.kit)
        # Asked for at every task: another thread may have replaced it (for
        # another process count), and a worker of the new one loads the kit
        # from the same file.  (Every stage asks for the same size: resizing
        # would restart warm workers.)
        self._pool = executor(self.processes - 1)
        _sent()
        return self._pool.submit(with_kit, self._path, task, *args)

    def __enter__(self) -> "KitWorkers":
        return self

    def __exit__(self, *exc) -> None:
        if self._path is None:
            return
        if self.keep is None:
            Path(self._path).unlink(missing_ok=True)
        else:
            _done_with_kept_kit(self.keep)


#: Kit files kept for later stages (:class:`KitWorkers` ``keep``), and as
#: many kits a worker keeps loaded: one for each fill that comes back, the
#: landform pass's (a coarse one, a few MB), the whole map's and a live
#: stroke's crop's (the examples without the landform split).  With two,
#: the app's run after a stroke pickled and loaded the whole map's again
#: and its next stroke the crop's.  A fill's kit holds the examples'
#: searches (tens of MB with the indexes a worker loads); its file, in the
#: temporary folder, holds them without the indexes.
KEPT_KITS = 3

#: Kept kit files by key, oldest first: [path, kit, stages using it].  The
#: kit is held so that the objects its key names stay alive (an ``id`` in
#: a key is not reused while they do).  A file in use is never removed:
#: beyond :data:`KEPT_KITS`, the oldest unused ones go.
_KEPT: OrderedDict = OrderedDict()
_KEPT_LOCK = threading.Lock()


def _use_kept_kit(key, kit) -> str:
    """The kept file of the kit ``key`` names (made now if there is none),
    counted as in use until :func:`_done_with_kept_kit`."""
    with _KEPT_LOCK:
        kept = _claim_kept(key)
    if kept is not None:
        return kept
    path = _kit_file(kit)
    with _KEPT_LOCK:
        kept = _claim_kept(key)
        if kept is not None:  # another stage made it meanwhile: theirs
            Path(path).unlink(missing_ok=True)
            return kept
        _KEPT[key] = [path, kit, 1]
        _trim_kept()
    return path


def _claim_kept(key) -> str | None:
    """The kept file of ``key``, now counted in use, or None (under
    :data:`_KEPT_LOCK`)."""
    got = _KEPT.get(key)
    if got is None or not Path(got[0]).exists():
        return None
    got[2] += 1
    _KEPT.move_to_end(key)
    return got[0]


def _done_with_kept_kit(key) -> None:
    with _KEPT_LOCK:
        got = _KEPT.get(key)
        if got is not None:
            got[2] -= 1
        _trim_kept()


def _trim_kept() -> None:
    """Remove the oldest unused kept files beyond :data:`KEPT_KITS` (under
    :data:`_KEPT_LOCK`)."""
    for key in [k for k, (_, _, users) in _KEPT.items() if users <= 0][:max(len(_KEPT) - KEPT_KITS, 0)]:
        Path(_KEPT.pop(key)[0]).unlink(missing_ok=True)


@atexit.register
def _remove_kept() -> None:
    with _KEPT_LOCK:
        for path, _, _ in _KEPT.values():
            Path(path).unlink(missing_ok=True)
        _KEPT.clear()


def _kit_file(kit) -> str:
    """``kit`` pickled to a new temporary file: its path."""
    fd, path = tempfile.mkstemp(prefix="terrasynth-kit-", suffix=".pkl")
    try:
        with os.fdopen(fd, "wb") as f:
            pickle.dump(kit, f, protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException:  # a full disk, an interrupt: no file left behind
        Path(path).unlink(missing_ok=True)
        raise
    return path


#: In a worker: the kits it holds, by the file each came from (path, inode
#: and modification time: a later kit may reuse a removed one's name),
#: the last used last; at most :data:`KEPT_KITS`.
_KITS: OrderedDict = OrderedDict()


def with_kit(kit_path: str, task, *args):
    """In a worker: ``task(kit, *args)`` with the kit of ``kit_path``
    (loaded on the first task that names it; the least recently used of
    more than :data:`KEPT_KITS` goes)."""
    st = os.stat(kit_path)
    which = (kit_path, st.st_ino, st.st_mtime_ns)
    kit = _KITS.get(which)
    if kit is None:
        # (Room first: a worker never holds more than KEPT_KITS, even loading.)
        while len(_KITS) >= KEPT_KITS:
            _KITS.popitem(last=False)
        with open(kit_path, "rb") as f:
            kit = pickle.load(f)
        _KITS[which] = kit
    _KITS.move_to_end(which)
    return task(kit, *args)
