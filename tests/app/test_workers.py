"""The generic worker, the latest-request-wins runner and one-off pool jobs, with toy work."""

import gc
import threading

import pytest
from PySide6.QtCore import QCoreApplication, QObject, Signal

from terrasynth_core.errors import ParamsError, SynthesisCancelled
from terrasynth_app import workers
from terrasynth_app.workers import GeneratorWorker, LatestRunner, run_in_background

TIMEOUT_MS = 10_000


def _collect(source):
    log = []
    source.yielded.connect(lambda item: log.append(("yielded", item)))
    source.returned.connect(lambda value: log.append(("returned", value)))
    source.errored.connect(lambda message: log.append(("errored", message)))
    source.cancelled.connect(lambda: log.append(("cancelled",)))
    return log


def test_each_yield_is_one_signal_in_order_then_the_return_value():
    def events():
        yield "a"
        yield None  # a bare checkpoint: no signal
        yield {"b": 2}
        return 42

    worker = GeneratorWorker(events())
    log = _collect(worker)
    finished = []
    worker.finished.connect(lambda: finished.append(len(log)))
    worker.run()  # on this thread: signals are direct
    assert log == [("yielded", "a"), ("yielded", {"b": 2}), ("returned", 42)]
    assert finished == [3]  # finished comes last


@pytest.mark.parametrize("exc, message", [(ValueError("boom"), "internal error: ValueError: boom"),
                                          (ParamsError("patch size too big"), "patch size too big")])
def test_an_error_is_reported_as_one_line_after_the_items_before_it(exc, message):
    def events():
        yield 1
        raise exc

    worker = GeneratorWorker(events())
    log = _collect(worker)
    worker.run()
    assert log == [("yielded", 1), ("errored", message)]


def test_raising_synthesis_cancelled_counts_as_cancelled():
    def events():
        yield 1
        raise SynthesisCancelled("stopped")

    worker = GeneratorWorker(events())
    log = _collect(worker)
    worker.run()
    assert log == [("yielded", 1), ("cancelled",)]


def test_cancel_stops_at_the_next_yield_and_closes_the_generator(qtbot):
    gate = threading.Event()
    closed = threading.Event()

    def events():
        try:
            yield 1
            gate.wait(TIMEOUT_MS / 1000)
            yield 2  # the checkpoint after cancel: never emitted
            yield 3
        finally:
            closed.set()

    runner = LatestRunner()
    log = _collect(runner)
    with qtbot.waitSignal(runner.yielded, timeout=TIMEOUT_MS):
        runner.start(events())
    assert runner.running
    with qtbot.waitSignal(runner.running_changed, timeout=TIMEOUT_MS) as stopped:
        runner.cancel()
        gate.set()
    assert stopped.args == [False] and not runner.running
    assert log == [("yielded", 1), ("cancelled",)]
    assert closed.is_set()
    assert runner.wait()


def test_a_new_request_cancels_the_old_one_at_once_and_drops_its_late_signals(qtbot):
    gate = threading.Event()

    def slow():
        yield "old 1"
        gate.wait(TIMEOUT_MS / 1000)
        yield "old 2"
        return "old"

    def fast():
        yield "new 1"
        yield "new 2"
        return "new"

    runner = LatestRunner()
    log = _collect(runner)
    states = []
    runner.running_changed.connect(states.append)
    with qtbot.waitSignal(runner.yielded, timeout=TIMEOUT_MS):
        old = runner.start(slow())
    with qtbot.waitSignal(runner.returned, timeout=TIMEOUT_MS):
        runner.start(fast())
    assert old.is_cancelled
    gate.set()
    assert runner.wait()  # both threads have ended
    QCoreApplication.sendPostedEvents()  # the old request's late signals arrive, and are dropped
    # The old request's end is told once, when the new one supersedes it.
    assert log == [("yielded", "old 1"), ("cancelled",), ("yielded", "new 1"), ("yielded", "new 2"),
                   ("returned", "new")]
    assert states == [True, True, False] and not runner.running


def test_no_full_collection_while_a_request_runs(qtbot):
    # A full collection on the GUI thread in the middle of a run walked every
    # object of the app (80-140 ms); the younger generations are still collected.
    gate = threading.Event()
    seen = []
    before = gc.get_threshold()

    def work():
        seen.append(gc.get_threshold())
        gate.wait(TIMEOUT_MS / 1000)
        yield "done"

    runner = LatestRunner()
    with qtbot.waitSignal(runner.running_changed, timeout=TIMEOUT_MS):
        runner.start(work())
    gate.set()
    with qtbot.waitSignal(runner.running_changed, timeout=TIMEOUT_MS) as ended:
        pass
    assert ended.args == [False]
    assert seen == [(before[0], before[1], workers._NEVER)]
    assert gc.get_threshold() == before
    assert runner.wait()


def test_the_start_up_objects_leave_the_collector_for_good():
    # They live as long as the app; a full collection walking them took
    # 55-100 ms on the GUI thread, one without them about a millisecond.
    assert gc.get_freeze_count() == 0
    try:
        workers._hold_collector(True)
        assert not workers.freeze_start_up() and gc.get_freeze_count() == 0  # not a request's objects
        workers._hold_collector(False)
        assert workers.freeze_start_up()
        frozen = gc.get_freeze_count()
        assert frozen > 10_000
        workers._hold_collector(True)
        workers._hold_collector(False)
        assert gc.get_freeze_count() == frozen  # a request does not let them back
    finally:
        gc.unfreeze()


class _Receiver(QObject):
    """Callbacks of a GUI-thread object, as run_in_background wants them."""

    got = Signal(str, object)

    def finished(self, value):
        self.got.emit("finished", (value, threading.current_thread() is threading.main_thread()))

    def failed(self, message):
        self.got.emit("failed", message)


def test_run_in_background_hands_back_the_value_or_the_error_on_the_gui_thread(qtbot):
    receiver = _Receiver()
    pool_thread = []
    with qtbot.waitSignal(receiver.got, timeout=TIMEOUT_MS) as got:
        run_in_background(lambda: pool_thread.append(threading.current_thread()) or 42, receiver.finished,
                          receiver.failed)
    assert got.args == ["finished", (42, True)] and pool_thread[0] is not threading.main_thread()
    with qtbot.waitSignal(receiver.got, timeout=TIMEOUT_MS) as got:
        run_in_background(lambda: 1 / 0, receiver.finished, receiver.failed)
    assert got.args == ["failed", "internal error: ZeroDivisionError: division by zero"]


def test_the_collector_is_held_until_the_last_of_overlapping_requests_ends(qtbot):
    # A stroke's update ending after the run that superseded it began must
    # not let the collector walk everything during that run.
    gates = {"a": threading.Event(), "b": threading.Event()}

    def work(name):
        gates[name].wait(TIMEOUT_MS / 1000)
        yield name

    before = gc.get_threshold()
    first, second = LatestRunner(), LatestRunner()
    with qtbot.waitSignal(first.running_changed, timeout=TIMEOUT_MS):
        first.start(work("a"))
    with qtbot.waitSignal(second.running_changed, timeout=TIMEOUT_MS):
        second.start(work("b"))
    gates["a"].set()
    with qtbot.waitSignal(first.running_changed, timeout=TIMEOUT_MS):
        pass
    held = gc.get_threshold()[2]
    gates["b"].set()
    with qtbot.waitSignal(second.running_changed, timeout=TIMEOUT_MS):
        pass
    assert held == workers._NEVER and gc.get_threshold() == before
    assert first.wait() and second.wait()
