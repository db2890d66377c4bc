"""Thread workers: the core's ``iter_run``, variations and slow one-off jobs
off the GUI thread.

:class:`SynthesisRunner` owns at most one current run.  Each run drains
``session.iter_run()`` on its own ``QThread`` and turns every event into a
signal; starting a new run cancels the old one, whose late events are
dropped.  Cancelling closes the generator at the next patch boundary.
:class:`VariationsRunner` does the same for a batch of variations (which
the core makes in worker processes).
"""

from __future__ import annotations

import logging
import threading
import traceback
from typing import Callable

from PySide6.QtCore import QObject, QRunnable, Qt, QThread, QThreadPool, Signal, Slot

from terrasynth_core.errors import SynthesisCancelled, TerraSynthError
from terrasynth_core.synthesis import PatchPlaced, StageFinished, StageStarted, SynthesisFinished

log = logging.getLogger(__name__)


def describe_error(exc: BaseException) -> str:
    """One line for the user: the core's own message, or the exception and where."""
    if isinstance(exc, TerraSynthError):
        return str(exc)
    return f"internal error: {type(exc).__name__}: {exc}"


def _log_failure(what: str, exc: Exception) -> None:
    # A user's mistake gets its one line; anything else its traceback, for a bug report.
    if isinstance(exc, TerraSynthError):
        log.info("%s failed: %s", what, exc)
    else:
        log.error("%s failed:\n%s", what, traceback.format_exc())


class SynthesisWorker(QObject):
    """Runs one synthesis on the thread it is moved to.

    Parameters
    ----------
    make_session : callable
        Returns a core ``Session``; called on the worker thread, since reading
        and analysing examples is slow.
    prepare : callable, optional
        Called on the worker thread after the session is made; its return
        value is sent with :attr:`session_ready` (e.g. the output cell size).

    Signals
    -------
    session_ready(object)
        The session is valid and the run starts; carries ``prepare()``'s value.
    stage_started(str, int)
        Stage name and the patches it will place.
    patch_placed(object)
        The core's :class:`PatchPlaced` event.
    stage_finished(str, float)
        Stage name and its seconds.
    synthesis_finished(object)
        The core's ``SynthesisResult``.
    synthesis_failed(str)
        One-line message; the run is over.
    synthesis_cancelled()
        The run stopped on request.
    done()
        Always last, whatever the outcome.
    """

    session_ready = Signal(object)
    stage_started = Signal(str, int)
    patch_placed = Signal(object)
    stage_finished = Signal(str, float)
    synthesis_finished = Signal(object)
    synthesis_failed = Signal(str)
    synthesis_cancelled = Signal()
    done = Signal()

    def __init__(self, make_session: Callable[[], object], prepare: Callable[[], object] | None = None) -> None:
        super().__init__()
        self._make_session = make_session
        self._prepare = prepare
        self._cancel = threading.Event()

    def cancel(self) -> None:
        """Ask the run to stop at its next event (callable from any thread)."""
        self._cancel.set()

    @property
    def cancelled(self) -> bool:
        return self._cancel.is_set()

    @Slot()
    def run(self) -> None:
        try:
            self._run()
        except Exception as exc:  # shown to the user, never lost in a thread
            _log_failure("synthesis", exc)
            self.synthesis_failed.emit(describe_error(exc))
        finally:
            self.done.emit()

    def _run(self) -> None:
        session = self._make_session()
        extra = self._prepare() if self._prepare is not None else None
        if self._cancel.is_set():
            self.synthesis_cancelled.emit()
            return
        self.session_ready.emit(extra)
        events = session.iter_run()
        try:
            for event in events:
                if self._cancel.is_set():
                    self.synthesis_cancelled.emit()
                    return
                if isinstance(event, PatchPlaced):
                    self.patch_placed.emit(event)
                elif isinstance(event, StageStarted):
                    self.stage_started.emit(event.stage, event.total)
                elif isinstance(event, StageFinished):
                    self.stage_finished.emit(event.stage, event.seconds)
                elif isinstance(event, SynthesisFinished):
                    self.synthesis_finished.emit(event.result)
        finally:
            events.close()


class _OneAtATime(QObject):
    """Bookkeeping shared by the runners: one current job, older ones still
    alive until their threads end, their late signals dropped.

    Subclasses define the forwarded signals and ``running_changed(bool)``;
    a run is an object with ``worker`` (having ``cancel()``) and ``thread``.
    """

    running_changed: Signal
    #: Milliseconds :meth:`wait` allows each thread at exit.
    WAIT_MS = 10_000

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._current = None
        self._runs: set = set()  # alive until their thread ends

    @property
    def running(self) -> bool:
        return self._current is not None

    def _start(self, run) -> None:
        self.cancel()
        self._runs.add(run)
        self._current = run
        self.running_changed.emit(True)
        run.thread.start()

    def cancel(self) -> None:
        """Cancel the current job; its cancelled signal is still forwarded."""
        if self._current is not None:
            self._current.worker.cancel()
            # Keep it current until it says it stopped, so the views learn
            # the job ended; only a newer one replaces it.

    def wait(self, msecs: int | None = None) -> bool:
        """Cancel everything and wait for the threads (at exit); False on timeout."""
        for run in list(self._runs):
            run.worker.cancel()
        ok = True
        for run in list(self._runs):
            ok &= run.thread.wait(self.WAIT_MS if msecs is None else msecs)
        return ok

    # -- called by the runs on the GUI thread ------------------------------------
    def _forward(self, run, signal: str, *args) -> None:
        if run is self._current:
            getattr(self, signal).emit(*args)

    def _run_done(self, run) -> None:
        if run is self._current:
            self._current = None
            self.running_changed.emit(False)

    def _thread_finished(self, run) -> None:
        self._runs.discard(run)


class SynthesisRunner(_OneAtATime):
    """Starts synthesis runs, one current at a time, and forwards their signals.

    Signals have the meaning of :class:`SynthesisWorker`'s, for the current
    run only.  ``running_changed(bool)`` tells when a run starts or ends.
    """

    session_ready = Signal(object)
    stage_started = Signal(str, int)
    patch_placed = Signal(object)
    stage_finished = Signal(str, float)
    synthesis_finished = Signal(object)
    synthesis_failed = Signal(str)
    synthesis_cancelled = Signal()
    running_changed = Signal(bool)

    def start(self, make_session: Callable[[], object], prepare: Callable[[], object] | None = None) -> None:
        """Start a run, cancelling the current one."""
        self._start(_Run(self, SynthesisWorker(make_session, prepare)))


class _Run(QObject):
    """One run: a worker, its thread, and slots (on the GUI thread) relaying
    the worker's queued signals to the runner if the run is still current."""

    def __init__(self, runner: SynthesisRunner, worker: SynthesisWorker) -> None:
        super().__init__()
        self.runner = runner
        self.worker = worker
        self.thread = QThread()
        worker.moveToThread(self.thread)
        self.thread.started.connect(worker.run)
        worker.session_ready.connect(self._session_ready)
        worker.stage_started.connect(self._stage_started)
        worker.patch_placed.connect(self._patch_placed)
        worker.stage_finished.connect(self._stage_finished)
        worker.synthesis_finished.connect(self._synthesis_finished)
        worker.synthesis_failed.connect(self._synthesis_failed)
        worker.synthesis_cancelled.connect(self._synthesis_cancelled)
        worker.done.connect(self._done)
        # Direct: QThread.quit is thread-safe, and a queued call would wait for
        # the GUI thread, which may be blocked in wait() at exit.
        worker.done.connect(self.thread.quit, Qt.DirectConnection)
        self.thread.finished.connect(self._thread_finished)

    @Slot(object)
    def _session_ready(self, extra) -> None:
        self.runner._forward(self, "session_ready", extra)

    @Slot(str, int)
    def _stage_started(self, stage: str, total: int) -> None:
        self.runner._forward(self, "stage_started", stage, total)

    @Slot(object)
    def _patch_placed(self, event) -> None:
        self.runner._forward(self, "patch_placed", event)

    @Slot(str, float)
    def _stage_finished(self, stage: str, seconds: float) -> None:
        self.runner._forward(self, "stage_finished", stage, seconds)

    @Slot(object)
    def _synthesis_finished(self, result) -> None:
        self.runner._forward(self, "synthesis_finished", result)

    @Slot(str)
    def _synthesis_failed(self, message: str) -> None:
        self.runner._forward(self, "synthesis_failed", message)

    @Slot()
    def _synthesis_cancelled(self) -> None:
        self.runner._forward(self, "synthesis_cancelled")

    @Slot()
    def _done(self) -> None:
        self.runner._run_done(self)

    @Slot()
    def _thread_finished(self) -> None:
        self.runner._thread_finished(self)


class VariationsWorker(QObject):
    """Runs one batch of variations on the thread it is moved to.

    Parameters
    ----------
    job : callable
        ``job(progress, cancel)`` returns the list of core results;
        ``progress(index, result)`` is to be called as each one finishes and
        ``cancel()`` polled (e.g. ``SynthesisRequest.make_variations``).

    Signals
    -------
    variation_finished(int, object)
        Variation ``index`` is done; carries its ``SynthesisResult``.
    variations_finished(object)
        The list of all results, in seed order.
    variations_failed(str)
        One-line message; the batch is over.
    variations_cancelled()
        The batch stopped on request.
    done()
        Always last.
    """

    variation_finished = Signal(int, object)
    variations_finished = Signal(object)
    variations_failed = Signal(str)
    variations_cancelled = Signal()
    done = Signal()

    def __init__(self, job: Callable[[Callable, Callable], list]) -> None:
        super().__init__()
        self._job = job
        self._cancel = threading.Event()

    def cancel(self) -> None:
        """Ask the batch to stop (callable from any thread)."""
        self._cancel.set()

    @Slot()
    def run(self) -> None:
        try:
            results = self._job(self.variation_finished.emit, self._cancel.is_set)
        except SynthesisCancelled:
            self.variations_cancelled.emit()
        except Exception as exc:  # shown to the user, never lost in a thread
            _log_failure("variations", exc)
            self.variations_failed.emit(describe_error(exc))
        else:
            if self._cancel.is_set():
                self.variations_cancelled.emit()
            else:
                self.variations_finished.emit(results)
        finally:
            self.done.emit()


class VariationsRunner(_OneAtATime):
    """Starts batches of variations, one current at a time, and forwards
    their signals (those of :class:`VariationsWorker`, for the current batch
    only).  ``running_changed(bool)`` tells when a batch starts or ends."""

    variation_finished = Signal(int, object)
    variations_finished = Signal(object)
    variations_failed = Signal(str)
    variations_cancelled = Signal()
    running_changed = Signal(bool)

    WAIT_MS = 30_000

    def start(self, job: Callable[[Callable, Callable], list]) -> None:
        """Start a batch, cancelling the current one."""
        self._start(_VariationsRun(self, VariationsWorker(job)))


class _VariationsRun(QObject):
    """One batch: a worker, its thread, and GUI-thread slots relaying the
    worker's queued signals to the runner while the batch is current."""

    def __init__(self, runner: VariationsRunner, worker: VariationsWorker) -> None:
        super().__init__()
        self.runner = runner
        self.worker = worker
        self.thread = QThread()
        worker.moveToThread(self.thread)
        self.thread.started.connect(worker.run)
        worker.variation_finished.connect(self._variation_finished)
        worker.variations_finished.connect(self._variations_finished)
        worker.variations_failed.connect(self._variations_failed)
        worker.variations_cancelled.connect(self._variations_cancelled)
        worker.done.connect(self._done)
        # Direct: QThread.quit is thread-safe, and a queued call would wait for
        # the GUI thread, which may be blocked in wait() at exit.
        worker.done.connect(self.thread.quit, Qt.DirectConnection)
        self.thread.finished.connect(self._thread_finished)

    @Slot(int, object)
    def _variation_finished(self, index: int, result) -> None:
        self.runner._forward(self, "variation_finished", index, result)

    @Slot(object)
    def _variations_finished(self, results) -> None:
        self.runner._forward(self, "variations_finished", results)

    @Slot(str)
    def _variations_failed(self, message: str) -> None:
        self.runner._forward(self, "variations_failed", message)

    @Slot()
    def _variations_cancelled(self) -> None:
        self.runner._forward(self, "variations_cancelled")

    @Slot()
    def _done(self) -> None:
        self.runner._run_done(self)

    @Slot()
    def _thread_finished(self) -> None:
        self.runner._thread_finished(self)


class _JobSignals(QObject):
    finished = Signal(object)
    failed = Signal(str)

    #: Signals of jobs whose result is not delivered yet, kept alive here
    #: because the pool deletes the runnable as soon as it has run.
    active: set["_JobSignals"] = set()

    @Slot()
    def release(self) -> None:
        _JobSignals.active.discard(self)


class BackgroundJob(QRunnable):
    """A function run on Qt's global thread pool; its result or error comes back by signal.

    Parameters
    ----------
    function : callable
        Called with no argument on a pool thread.
    """

    def __init__(self, function: Callable[[], object]) -> None:
        super().__init__()
        self._function = function
        self.signals = _JobSignals()

    def run(self) -> None:
        try:
            value = self._function()
        except Exception as exc:
            _log_failure("background job", exc)
            self.signals.failed.emit(describe_error(exc))
        else:
            self.signals.finished.emit(value)


def run_in_background(function: Callable[[], object], on_finished: Callable[[object], None],
                      on_failed: Callable[[str], None]) -> None:
    """Run ``function`` on Qt's thread pool and call back on the GUI thread.

    Parameters
    ----------
    function : callable
        Called with no argument on a pool thread.
    on_finished : callable
        ``on_finished(value)`` with ``function``'s return value.
    on_failed : callable
        ``on_failed(message)`` with a one-line message when it raised.

    The callbacks must be bound methods of QObjects living on the GUI thread,
    so Qt queues the calls there.
    """
    job = BackgroundJob(function)
    signals = job.signals
    signals.finished.connect(on_finished)
    signals.failed.connect(on_failed)
    # Connected last, so it runs after the callbacks of the same emission.
    signals.finished.connect(signals.release)
    signals.failed.connect(signals.release)
    _JobSignals.active.add(signals)
    QThreadPool.globalInstance().start(job)
