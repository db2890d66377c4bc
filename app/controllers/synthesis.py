"""Running syntheses and variations of the document off the GUI thread.

Each controller owns a :class:`~terrasynth_app.workers.LatestRunner`: a new
request cancels the running one.  The worker drains the model's event
generators (:func:`~terrasynth_app.model.synthesis_events`,
:func:`~terrasynth_app.model.variation_events`); the controllers handle the
events they care about by type, update the document when a run ends, and
tell the views what to show.  Progress is throttled: a repaint per patch
would flood the event loop.
"""

from __future__ import annotations

import dataclasses
import secrets
import time

from PySide6.QtCore import QObject, QTimer, Signal

from terrasynth_core.errors import TerraSynthError
from terrasynth_core.synthesis import LandformProgress, PatchPlaced, StageStarted, SynthesisFinished, import_engine

from ..model import (MAX_SEED, Document, RunStarted, TerrainResult, VariationMade, synthesis_events,
                     variation_events)
from ..workers import LatestRunner

#: Shortest period between progress updates, in ms.
PROGRESS_MS = 100
#: What the status shows while each core stage runs.
STAGE_TEXT = {"landform": "Shaping the landforms", "analyse": "Analysing the sketch", "features": "Placing feature patches",
              "fill": "Filling the rest", "finish": "Finishing"}


def new_seeds(count: int) -> list[int]:
    """``count`` distinct random seeds the seed box can show."""
    seeds: list[int] = []
    while len(seeds) < count:
        seed = secrets.randbelow(MAX_SEED + 1)
        if seed not in seeds:
            seeds.append(seed)
    return seeds


class _RunController(QObject):
    """What both controllers share: a latest-request-wins runner whose
    items, return value, errors and cancellation go to the subclass's
    ``_event``, ``_returned``, ``_failed`` and ``_cancelled``."""

    running_changed = Signal(bool)
    status = Signal(str, int)
    error = Signal(str, str)

    def __init__(self, document: Document, parent: QObject | None, *, wait_ms: int) -> None:
        super().__init__(parent)
        # Now, on the GUI thread while the window is built: a run's thread
        # importing faiss would hold the GIL long enough to stall the views.
        import_engine()
        self.document = document
        self.runner = LatestRunner(self, wait_ms=wait_ms)
        self.runner.yielded.connect(self._event)
        self.runner.returned.connect(self._returned)
        self.runner.errored.connect(self._failed)
        self.runner.cancelled.connect(self._cancelled)
        self.runner.running_changed.connect(self.running_changed)

    @property
    def running(self) -> bool:
        return self.runner.running

    def cancel(self) -> None:
        self.runner.cancel()

    def wait(self) -> bool:
        """Cancel and wait for every request's thread (at exit)."""
        return self.runner.wait()

    def _returned(self, value) -> None:
        """The generator's return value (unused unless overridden)."""


class SynthesisController(_RunController):
    """Synthesizes the document (or its selection again), one run at a time.

    Parameters
    ----------
    document : Document
    parent : QObject, optional
    progress_ms : int
        Shortest period between :attr:`progress_changed` signals.

    Attributes
    ----------
    runner : LatestRunner
        Its ``yielded`` signal carries every event of the current run.

    Signals
    -------
    run_started(object)
        A :class:`~terrasynth_app.model.RunInfo`: views start a new canvas.
    patch_placed(object)
        The core's ``PatchPlaced`` event.
    landform_preview(object)
        The core's ``LandformProgress`` event: a coarse patch stretched onto
        the output (``bbox`` and ``heights`` as a patch's), shown until the
        full-resolution patches replace it.
    stage_changed(str)
        What the run is doing, for a status label.
    progress_changed(int, int, str)
        Patches done, patches in all (both 0 while that is unknown) and the
        time left, in words.
    finished(object)
        The document holds the new terrain; carries the core's ``SynthesisResult``.
    failed(str)
        One-line message; the document is as it was.
    cancelled()
        The run stopped on request; the document is as it was.
    running_changed(bool)
    status(str, int)
        A message for the status bar and how many ms to show it.
    error(str, str)
        A title and a message for an error dialog.
    """

    run_started = Signal(object)
    patch_placed = Signal(object)
    landform_preview = Signal(object)
    stage_changed = Signal(str)
    progress_changed = Signal(int, int, str)
    finished = Signal(object)
    failed = Signal(str)
    cancelled = Signal()

    def __init__(self, document: Document, parent: QObject | None = None, *, progress_ms: int = PROGRESS_MS) -> None:
        super().__init__(document, parent, wait_ms=10_000)
        self._started_at = 0.0
        self._strokes = None
        self._progress: tuple[int, int] | None = None  # (done, total) not sent yet
        self._progress_timer = QTimer(self, singleShot=True, interval=progress_ms)
        self._progress_timer.timeout.connect(self._send_progress)
        self._handlers = {RunStarted: self._run_started, StageStarted: self._stage_started,
                          PatchPlaced: self._patch_placed, SynthesisFinished: self._synthesis_finished,
                          LandformProgress: self.landform_preview.emit}

    def synthesize(self) -> None:
        """Start a run with the document as it is now (cancelling a running one)."""
        try:
            request = self.document.synthesis_request()
        except TerraSynthError as exc:
            self.error.emit("Cannot synthesize", str(exc))
            return
        self._start(request)

    def resynthesize_selection(self) -> None:
        """Synthesize the selected cells again with a new random seed; the
        new terrain replaces the current one when (and only if) it finishes."""
        try:
            request = self.document.resynthesis_request(seed=new_seeds(1)[0])
        except TerraSynthError as exc:
            self.error.emit("Cannot re-synthesize", str(exc))
            return
        self._start(request)

    def cancel(self) -> None:
        super().cancel()
        self.stage_changed.emit("Cancelling…")

    def _start(self, request) -> None:
        self._stop_progress()
        # The strokes the new terrain will follow (live sketching compares
        # the sketch with them); a re-synthesis leaves the rest following
        # the strokes it followed.
        self._strokes = request.sketch_map if request.previous is None else self.document.result_strokes
        # First, so a run it supersedes says it was cancelled before this
        # one's stage is shown.
        self.runner.start(synthesis_events(request))
        self.stage_changed.emit("Reading examples…")
        self.progress_changed.emit(0, 0, "")

    # -- events of the current run --------------------------------------------------------
    def _event(self, event) -> None:
        handler = self._handlers.get(type(event))
        if handler is not None:
            handler(event)

    def _run_started(self, event: RunStarted) -> None:
        self._started_at = time.perf_counter()
        self.run_started.emit(event.info)

    def _stage_started(self, event: StageStarted) -> None:
        self.stage_changed.emit(STAGE_TEXT.get(event.stage, event.stage))

    def _patch_placed(self, event: PatchPlaced) -> None:
        self.patch_placed.emit(event)
        self._progress = (event.index + 1, event.total)
        if not self._progress_timer.isActive():
            self._progress_timer.start()

    def _send_progress(self) -> None:
        if self._progress is None:
            return
        done, total = self._progress
        self._progress = None
        elapsed = time.perf_counter() - self._started_at
        left = elapsed / done * max(total - done, 0)
        self.progress_changed.emit(done, max(total, done), f"about {left:.0f} s left" if left >= 1 else "almost done")

    def _synthesis_finished(self, event: SynthesisFinished) -> None:
        self._stop_progress()
        result = event.result
        terrain = TerrainResult.from_synthesis(result)
        self.document.set_result(terrain, strokes=self._strokes)
        self.stage_changed.emit("Done")
        self.finished.emit(result)
        warnings = "; ".join(result.warnings)
        what = (f"Re-synthesized {int(result.selection.sum())} cells (seed {result.params.seed})"
                if result.selection is not None else f"Synthesized {terrain.shape[0]} x {terrain.shape[1]}")
        if terrain.cell_size is not None:
            what += f" cells of {terrain.cell_size[0]:g} m"
        self.status.emit(f"{what} in {result.total_seconds:.1f} s" + (f" - {warnings}" if warnings else ""), 20_000)

    def _failed(self, message: str) -> None:
        self._stop_progress()
        self.stage_changed.emit("Failed")
        self.failed.emit(message)
        self.error.emit("Synthesis failed", message)

    def _cancelled(self) -> None:
        self._stop_progress()
        self.stage_changed.emit("Cancelled")
        self.status.emit("Synthesis cancelled; the previous terrain is shown", 10_000)
        self.cancelled.emit()

    def _stop_progress(self) -> None:
        self._progress_timer.stop()
        self._progress = None


class VariationsController(_RunController):
    """Makes batches of variations (one terrain per new seed), one batch at a time.

    Signals
    -------
    started(object)
        A batch began; carries its seeds (a list).
    variation_made(int, object)
        Variation ``index`` is done; carries its :class:`TerrainResult`.
    finished(object)
        The list of all terrains, in seed order.
    failed(str)
    cancelled()
    running_changed(bool)
    status(str, int)
    error(str, str)
        As :class:`SynthesisController`'s.
    """

    started = Signal(object)
    variation_made = Signal(int, object)
    finished = Signal(object)
    failed = Signal(str)
    cancelled = Signal()

    def __init__(self, document: Document, parent: QObject | None = None) -> None:
        # Cancelling a batch stops worker processes; they may take a while.
        super().__init__(document, parent, wait_ms=30_000)

    def make(self, count: int) -> None:
        """Start a batch of ``count`` variations of the document (cancelling a running one)."""
        try:
            request = self.document.synthesis_request()
        except TerraSynthError as exc:
            self.error.emit("Cannot make variations", str(exc))
            return
        seeds = new_seeds(count)
        self.started.emit(seeds)
        self.runner.start(variation_events(request, seeds))
        self.status.emit(f"Making {count} variations…", 0)

    def use(self, seed: int, terrain: TerrainResult) -> None:
        """Make a variation the current terrain and its seed the document's."""
        self.document.set_params(dataclasses.replace(self.document.params, seed=seed))
        self.document.set_result(terrain)
        self.status.emit(f"Using the variation with seed {seed}", 10_000)

    def _event(self, event) -> None:
        if isinstance(event, VariationMade):
            self.variation_made.emit(event.index, event.terrain)

    def _returned(self, terrains) -> None:
        self.finished.emit(terrains)
        self.status.emit(f"{len(terrains)} variations made", 10_000)

    def _failed(self, message: str) -> None:
        self.failed.emit(message)
        self.error.emit("Variations failed", message)

    def _cancelled(self) -> None:
        self.cancelled.emit()
        self.status.emit("Variations cancelled", 10_000)
