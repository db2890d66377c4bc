"""Live sketching: each finished stroke (or erase, undo, redo) re-makes the
terrain near it, debounced and cancellable.

The controller listens to the sketch: a finished edit restarts a short
debounce timer (:data:`LIVE_DELAY_MS`), so a burst of strokes makes one
update; when it fires, the model's :func:`~terrasynth_app.model.live_request`
snapshots the document and a latest-request-wins runner drains
:func:`~terrasynth_app.model.live_events` on a worker thread.  A new stroke
cancels the update running (as soon as it starts: the core stops at its
next patch), and the next update covers every stroke since the terrain's
last one.  A full run cancels a live update and pauses live sketching
until it ends.  The document gets the new terrain only when an update
finishes; a failed update leaves the sketch and the terrain as they were
and says why in the status bar (no dialog: the next stroke tries again).
"""

from __future__ import annotations

import threading

from PySide6.QtCore import QObject, QTimer, Signal

from terrasynth_core.errors import TerraSynthError

from ..model import Document, LiveUpdated, live_events, live_preparation, live_request
from ..workers import LatestRunner, run_in_background
from .synthesis import SynthesisController

#: Debounce after a finished stroke before a live update starts, ms: long
#: enough to join a quick second stroke, short against the update itself.
#: A stroke begun while an update runs cancels it at its next patch, so a
#: short wait costs little (100 against 200 ms: stroke to terrain shown
#: 1.33 and 1.53 s against 1.47 and 1.49 s, medians of six strokes,
#: alternated; the engine's own time varies as much).
LIVE_DELAY_MS = 100


class LiveController(QObject):
    """Keeps the terrain following the sketch's strokes while enabled.

    Parameters
    ----------
    document : Document
    synthesis : SynthesisController
        Its full runs take precedence.
    parent : QObject, optional
    delay_ms : int, default :data:`LIVE_DELAY_MS`
        Debounce after a finished stroke.

    Signals
    -------
    enabled_changed(bool)
    running_changed(bool)
        An update started, or the current one ended.
    scheduled()
        A finished edit started the debounce timer.
    started()
        An update went to the worker.
    updated(object)
        The document holds the new terrain; carries the core's
        ``SynthesisResult`` (its ``selection``: the cells re-made).
    failed(str)
        One line; the sketch and the terrain are as they were.
    cancelled()
        An update stopped for a newer stroke or a full run.
    prepared()
        What the first stroke's update reads from the examples is made
        (after a full run, or Live turned on with a terrain), or there was
        nothing to make, or it could not be made (the stroke then makes it).
    status(str, int)
        A status-bar message and how many ms to show it.
    error(str, str)
        Never emitted (a failed live update is a status message), there so
        the window can treat every controller alike.
    """

    enabled_changed = Signal(bool)
    running_changed = Signal(bool)
    scheduled = Signal()
    started = Signal()
    updated = Signal(object)
    failed = Signal(str)
    cancelled = Signal()
    prepared = Signal()
    status = Signal(str, int)
    error = Signal(str, str)

    def __init__(self, document: Document, synthesis: SynthesisController, parent: QObject | None = None, *,
                 delay_ms: int = LIVE_DELAY_MS) -> None:
        super().__init__(parent)
        self.document = document
        self.synthesis = synthesis
        self._enabled = False
        self._request = None  # of the update running
        self.runner = LatestRunner(self, wait_ms=10_000)
        self.runner.yielded.connect(self._event)
        self.runner.errored.connect(self._failed)
        self.runner.cancelled.connect(self.cancelled)
        self.runner.running_changed.connect(self.running_changed)
        self._timer = QTimer(self, singleShot=True, interval=int(delay_ms))
        # Set to stop the background preparation running (a run starts, Live
        # goes off, a newer one starts); a new Event for each preparation.
        self._preparing = threading.Event()
        self._timer.timeout.connect(self._start)
        document.sketch.history_changed.connect(self._edit_finished)
        document.sketch.changed.connect(self._sketch_changed)
        synthesis.running_changed.connect(self._synthesis_running)

    # -- public ---------------------------------------------------------------------------
    @property
    def enabled(self) -> bool:
        return self._enabled

    @property
    def running(self) -> bool:
        return self.runner.running

    @property
    def pending(self) -> bool:
        """An update waits for the debounce timer."""
        return self._timer.isActive()

    def set_enabled(self, on: bool) -> None:
        """Turn live sketching on (strokes drawn meanwhile are followed at
        once) or off (an update running is cancelled)."""
        on = bool(on)
        if on == self._enabled:
            return
        self._enabled = on
        if on:
            self.schedule()
            self._prepare()
        else:
            self._timer.stop()
            self.runner.cancel()
            self.stop_preparation()
        self.enabled_changed.emit(on)

    def schedule(self) -> None:
        """Start (or restart) the debounce timer, cancelling an update
        running: a newer edit supersedes it."""
        if not self._enabled or self.synthesis.running or self.document.result is None:
            return
        self.runner.cancel()
        self._timer.start()
        self.scheduled.emit()

    def stop_preparation(self) -> None:
        """Stop the background preparation at its next zone index: other
        heavy work (a run, variations, a large render) needs the cores.  The
        next run's end prepares again."""
        self._preparing.set()

    def wait(self) -> bool:
        """Cancel and wait for the worker's thread (at exit)."""
        self._timer.stop()
        self.stop_preparation()
        return self.runner.wait()

    # -- internals ------------------------------------------------------------------------
    def _edit_finished(self) -> None:
        # History changes mark finished edits: a stroke's end, an undo, a
        # redo, a clear.  Region edits come here too; the update finds
        # no stroke changed and does nothing.
        if not self.document.sketch.stroking:
            self.schedule()

    def _sketch_changed(self, _bbox) -> None:
        # A stroke being drawn will supersede the update running: free the
        # core for the GUI now rather than at the stroke's end.
        if self._enabled and self.document.sketch.stroking and self.runner.running:
            self.runner.cancel()
            self._timer.stop()

    def _synthesis_running(self, running: bool) -> None:
        if running:
            self._timer.stop()
            self.runner.cancel()
            self.stop_preparation()  # the run needs the cores more
        else:
            # Strokes drawn during the run are not in its terrain.
            self.schedule()
            self._prepare()

    def _prepare(self) -> None:
        # The first stroke after a run would make the examples' pools and
        # searches for its crop first (0.4-0.5 s for a 1201x1201 example):
        # made now, in the background, while the artist looks at the
        # terrain.  A stroke that comes meanwhile waits for them in the core
        # rather than making them twice.
        if not self._enabled or self.synthesis.running:
            return  # (a run's end prepares)
        self.stop_preparation()  # an older one: this one makes what it would
        self._preparing = threading.Event()
        try:
            prepare = live_preparation(self.document, cancel=self._preparing.is_set)
        except TerraSynthError:
            prepare = None  # the stroke's update will say what is wrong
        if prepare is None:
            self.prepared.emit()  # nothing to prepare
        else:
            run_in_background(prepare, self._prepared, self._preparation_failed)

    def _prepared(self, _value) -> None:
        self.prepared.emit()

    def _preparation_failed(self, _message: str) -> None:
        # Nothing is lost: the first stroke's update makes them (and says so
        # if it cannot).
        self.prepared.emit()

    def _start(self) -> None:
        if not self._enabled or self.synthesis.running or self.document.sketch.stroking:
            return
        try:
            request = live_request(self.document)
        except TerraSynthError as exc:
            self.status.emit(f"Live: {exc}", 10_000)
            return
        if request is None:
            return
        self._request = request
        self.runner.start(live_events(request))
        self.started.emit()
        self.status.emit("Live: updating the terrain near the stroke…", 0)

    def _event(self, event) -> None:
        if not isinstance(event, LiveUpdated):
            return
        if self._request is None or self.document.result is not self._request.terrain:
            # The terrain changed while the update ran (a full run, a
            # variation taken, a project opened): the update is of the old one.
            return
        self._request = None
        result = event.result
        self.document.set_result(event.terrain, strokes=event.strokes)
        self.updated.emit(result)
        cells = int(result.selection.sum()) if result.selection is not None else 0
        warnings = "; ".join(result.warnings)
        self.status.emit(f"Live: re-synthesized {cells} cells near the stroke in {event.seconds:.1f} s"
                         + (f" - {warnings}" if warnings else ""), 10_000)

    def _failed(self, message: str) -> None:
        self.failed.emit(message)
        self.status.emit(f"Live update failed: {message}; the sketch and the terrain are kept", 30_000)
