"""Work off the GUI thread: one generic worker around any generator of events.

:class:`GeneratorWorker` drains an iterator (usually a generator) on the
thread it is moved to and turns each item it yields into one
:attr:`~GeneratorWorker.yielded` signal; every yield is a cancel checkpoint.
:class:`LatestRunner` gives each request its own worker and ``QThread`` and
keeps one current: a new request cancels the old one, whose late signals
are dropped.  Nothing here knows what the items are, so a new kind of event
needs no relay code: whoever consumes :attr:`LatestRunner.yielded` handles
it.  :func:`run_in_background` runs a one-off function with the same worker on
Qt's thread pool.

A small class of our own rather than superqt's ``GeneratorWorker``: the
app needs the latest-request-wins bookkeeping on top anyway, and this keeps
the GUI extra to PySide6, pyqtgraph and pyvista.
"""

from __future__ import annotations

import gc
import logging
import threading
import traceback
from typing import Callable, Iterable

from PySide6.QtCore import QObject, QRunnable, Qt, QThread, QThreadPool, Signal, Slot

from terrasynth_core.errors import SynthesisCancelled, TerraSynthError

log = logging.getLogger(__name__)


def describe_error(exc: BaseException) -> str:
    """One line for the user: the core's own message, or the exception and where."""
    if isinstance(exc, TerraSynthError):
        return str(exc)
    return f"internal error: {type(exc).__name__}: {exc}"


def _log_failure(exc: Exception) -> None:
    # A user's mistake gets its one line; anything else its traceback, for a bug report.
    if isinstance(exc, TerraSynthError):
        log.info("background work failed: %s", exc)
    else:
        log.error("background work failed:\n%s", traceback.format_exc())


#: Requests running, over every runner (synthesis, live, variations).
_running_requests = 0

#: The collector's thresholds when no request runs (taken when the first starts).
_thresholds: tuple[int, int, int] | None = None

#: The oldest generation's threshold while requests run: never reached.
_NEVER = 1 << 30


def freeze_start_up() -> bool:
    """Take the objects the app has made by now (its modules, Qt and VTK
    wrappers, the window: about 280 000 with VTK) out of the cyclic
    collector for good, once the window is up; False, doing nothing, while
    a request runs (its objects are not for keeping).

    They live as long as the app.  A full collection walked them all, on
    whichever thread triggered it, often the GUI thread: 55-75 ms on this
    machine, and 80-100 ms measured right after a run, as its result was
    shown.  Without them a full collection walks the few thousand objects
    made since: about 1 ms.
    """
    if _running_requests:
        return False
    gc.collect()
    gc.freeze()
    return True


def _hold_collector(running: bool) -> None:
    """No full collection while any runner has work: the oldest
    generation's threshold is put out of reach when the first request
    starts and given back when the last ends.

    A run's threads make objects on top of the app's; a full collection
    in the middle of a run took 80-140 ms on the GUI thread.  The younger
    generations are still collected.  The full pass put off comes after
    the last request ends; with the start-up objects frozen
    (:func:`freeze_start_up`) it walks only what was made since.
    """
    global _running_requests, _thresholds
    _running_requests = max(_running_requests + (1 if running else -1), 0)
    if running and _running_requests == 1:
        _thresholds = gc.get_threshold()
        gc.set_threshold(_thresholds[0], _thresholds[1], _NEVER)
    elif _running_requests == 0 and _thresholds is not None:
        gc.set_threshold(*_thresholds)
        _thresholds = None


class GeneratorWorker(QObject):
    """Drains an iterator of events on the thread it is moved to.

    Parameters
    ----------
    events : iterable
        Usually a generator object: its body (the slow part) only runs
        when the worker asks for the first item, so it may be made on the
        GUI thread.  A ``None`` item is a bare cancel checkpoint (a
        generator waiting on something else yields it now and then) and is
        not emitted.  Raising ``SynthesisCancelled`` counts as cancelled.

    Signals
    -------
    yielded(object)
        One per item, in order.
    returned(object)
        The generator's return value; it ended normally.
    errored(str)
        One-line message; it raised.
    cancelled()
        It stopped on request: at the first yield after :meth:`cancel`.
    finished()
        Always last, whatever the outcome.
    """

    yielded = Signal(object)
    returned = Signal(object)
    errored = Signal(str)
    cancelled = Signal()
    finished = Signal()

    def __init__(self, events: Iterable) -> None:
        super().__init__()
        self._events = events
        self._cancel = threading.Event()

    def cancel(self) -> None:
        """Ask the worker to stop at its next yield (callable from any thread)."""
        self._cancel.set()

    @property
    def is_cancelled(self) -> bool:
        return self._cancel.is_set()

    @Slot()
    def run(self) -> None:
        """Drain the events; call once, on the worker thread."""
        try:
            self._drain()
        except SynthesisCancelled:
            self.cancelled.emit()
        except Exception as exc:  # shown to the user, never lost in a thread
            _log_failure(exc)
            self.errored.emit(describe_error(exc))
        finally:
            self.finished.emit()

    def _drain(self) -> None:
        events = iter(self._events)
        try:
            while not self._cancel.is_set():
                try:
                    item = next(events)
                except StopIteration as stop:
                    if not self._cancel.is_set():
                        self.returned.emit(stop.value)
                        return
                    break
                if self._cancel.is_set():
                    break
                if item is not None:
                    self.yielded.emit(item)
            self.cancelled.emit()
        finally:
            close = getattr(events, "close", None)
            if close is not None:
                close()  # runs the generator's ``finally`` blocks on this thread


class LatestRunner(QObject):
    """Runs requests one current at a time: a new one cancels the old one.

    Each request gets a :class:`GeneratorWorker` on its own ``QThread``;
    the runner's signals mean the worker's, for the current request only
    (an old request's late signals are dropped).  A cancelled request stays
    current until it says it stopped or a new request supersedes it, so
    listeners learn once that it ended.

    Parameters
    ----------
    parent : QObject, optional
    wait_ms : int, default 10 000
        Milliseconds :meth:`wait` allows each thread at exit.

    Signals
    -------
    yielded(object), returned(object), errored(str), cancelled()
        As :class:`GeneratorWorker`'s.
    running_changed(bool)
        A request started, or the current one ended (after its last signal).
    """

    yielded = Signal(object)
    returned = Signal(object)
    errored = Signal(str)
    cancelled = Signal()
    running_changed = Signal(bool)

    def __init__(self, parent: QObject | None = None, *, wait_ms: int = 10_000) -> None:
        super().__init__(parent)
        self.wait_ms = wait_ms
        self._current: GeneratorWorker | None = None
        self._threads: dict[GeneratorWorker, QThread] = {}  # alive until their thread ends
        self._holding = False  # the collector is held for this runner's current request

    @property
    def running(self) -> bool:
        return self._current is not None

    def start(self, events: Iterable) -> GeneratorWorker:
        """Run ``events`` (see :class:`GeneratorWorker`), cancelling the current request.

        A request still running is superseded: ``cancelled`` is emitted for
        it now, since its own signals (which may come after this one's
        first) are dropped from here on.
        """
        if self._current is not None:
            self.cancel()
            self.cancelled.emit()
        worker = GeneratorWorker(events)
        thread = QThread()
        worker.moveToThread(thread)
        thread.started.connect(worker.run)
        # Queued to this object's slots of the same names, which drop the
        # signals of old requests.
        for name in ("yielded", "returned", "errored", "cancelled", "finished"):
            getattr(worker, name).connect(getattr(self, f"_{name}"))
        # Direct: QThread.quit is thread-safe, and a queued call would wait for
        # the GUI thread, which may be blocked in wait() at exit.
        worker.finished.connect(thread.quit, Qt.DirectConnection)
        thread.finished.connect(self._thread_finished)
        self._threads[worker] = thread
        if not self._holding:
            self._holding = True
            _hold_collector(True)
        self._current = worker
        self.running_changed.emit(True)
        thread.start()
        return worker

    def cancel(self) -> None:
        """Cancel the current request; its ``cancelled`` signal still comes."""
        if self._current is not None:
            self._current.cancel()

    def wait(self, msecs: int | None = None) -> bool:
        """Cancel every request and wait for their threads (at exit); False on timeout."""
        for worker in list(self._threads):
            worker.cancel()
        ok = True
        for thread in list(self._threads.values()):
            ok &= thread.wait(self.wait_ms if msecs is None else msecs)
        if ok:
            # The current request's queued end may never be delivered (the
            # window is closing): the collector sees its objects again now.
            self._release_collector()
        return ok

    def _release_collector(self) -> None:
        if self._holding:
            self._holding = False
            _hold_collector(False)

    # -- the current worker's signals, on the GUI thread -----------------------------
    def _is_current(self) -> bool:
        return self._current is not None and self.sender() is self._current

    @Slot(object)
    def _yielded(self, item) -> None:
        if self._is_current():
            self.yielded.emit(item)

    @Slot(object)
    def _returned(self, value) -> None:
        if self._is_current():
            self.returned.emit(value)

    @Slot(str)
    def _errored(self, message: str) -> None:
        if self._is_current():
            self.errored.emit(message)

    @Slot()
    def _cancelled(self) -> None:
        if self._is_current():
            self.cancelled.emit()

    @Slot()
    def _finished(self) -> None:
        if self._is_current():
            self._current = None
            self._release_collector()
            self.running_changed.emit(False)

    @Slot()
    def _thread_finished(self) -> None:
        for worker, thread in list(self._threads.items()):
            if thread is self.sender():
                thread.wait()  # finished is emitted just before the thread really ends
                del self._threads[worker]


def _call(function: Callable[[], object]):
    """A generator that yields nothing and returns ``function()``."""
    yield from ()
    return function()


class _PoolJob(QRunnable):
    """Runs a :class:`GeneratorWorker` on a pool thread."""

    def __init__(self, worker: GeneratorWorker) -> None:
        super().__init__()
        self._worker = worker

    def run(self) -> None:
        self._worker.run()


class _PoolWorkers(QObject):
    """The workers running on the thread pool, kept alive (on the GUI thread)
    until their last signal has been delivered."""

    def __init__(self) -> None:
        super().__init__()
        self._workers: set[GeneratorWorker] = set()

    def start(self, worker: GeneratorWorker, pool: QThreadPool | None = None) -> None:
        self._workers.add(worker)
        # Queued, and connected after the caller's slots: runs after them.
        worker.finished.connect(self._release)
        (pool or QThreadPool.globalInstance()).start(_PoolJob(worker))

    @Slot()
    def _release(self) -> None:
        self._workers.discard(self.sender())


_pool_workers: _PoolWorkers | None = None


def run_in_background(function: Callable[[], object], on_finished: Callable[[object], None],
                      on_failed: Callable[[str], None], *, pool: QThreadPool | None = None) -> None:
    """Run ``function`` on Qt's thread pool and call back on the GUI thread.

    The same :class:`GeneratorWorker`, around a generator that yields nothing
    and returns ``function()``, run on a pool thread rather than a thread of
    its own.  Call from the GUI thread.

    Parameters
    ----------
    function : callable
        Called with no argument on a pool thread.
    on_finished : callable
        ``on_finished(value)`` with ``function``'s return value.
    on_failed : callable
        ``on_failed(message)`` with a one-line message when it raised.
    pool : QThreadPool, optional
        A pool of the caller's own (default Qt's global one), for work that
        must not queue behind long jobs.

    The callbacks must be bound methods of QObjects living on the GUI thread,
    so Qt queues the calls there.
    """
    global _pool_workers
    if _pool_workers is None:
        _pool_workers = _PoolWorkers()
    worker = GeneratorWorker(_call(function))
    worker.returned.connect(on_finished)
    worker.errored.connect(on_failed)
    _pool_workers.start(worker, pool)
