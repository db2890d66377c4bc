"""*Render large...*: the document rendered as tiles on Dask, in the
background, with progress and cancel (:mod:`terrasynth_app.model.large_render`)."""

from __future__ import annotations

from PySide6.QtCore import QObject, Signal

from terrasynth_core.errors import TerraSynthError
from terrasynth_core.tiled import TileFinished

from ..model import Document
from ..model.large_render import EngineExportStarted, LargeRender, large_render_events
from .synthesis import _RunController


class LargeRenderController(_RunController):
    """Renders the document tiled, one render at a time.

    Signals
    -------
    started()
    tile_finished(int, int)
        Tiles finished (kept ones included) and tiles in all.
    engine_started(str)
        The GeoTIFF is written; the engine's files (this preset's) are being made.
    finished(object)
        A ``LargeRendered``: the GeoTIFF is written (and the engine's files
        when asked for).
    failed(str)
        One-line message.
    cancelled()
        Stopped on request; the finished tiles stay beside the output.
    running_changed(bool)
    status(str, int)
    error(str, str)
        As the other run controllers'.
    """

    started = Signal()
    tile_finished = Signal(int, int)
    engine_started = Signal(str)
    finished = Signal(object)
    failed = Signal(str)
    cancelled = Signal()

    def __init__(self, document: Document, parent: QObject | None = None) -> None:
        # Cancelling closes the Dask cluster: its worker processes take a moment.
        super().__init__(document, parent, wait_ms=60_000)

    def render(self, size: tuple[int, int], tile: int, workers: int, out, *, engine: str | None = None,
               engine_tiles: int = 1) -> None:
        """Start rendering the document at ``size`` in tiles of ``tile`` cells
        to ``out`` (and for ``engine`` in ``engine_tiles`` x ``engine_tiles``
        tiles beside it)."""
        try:
            request = self.document.synthesis_request()
        except TerraSynthError as exc:
            self.failed.emit(str(exc))
            return
        self.started.emit()
        render = LargeRender(tuple(size), int(tile), int(workers), out, engine, int(engine_tiles))
        self.runner.start(large_render_events(request, render))
        self.status.emit(f"Rendering {size[0]}x{size[1]} in tiles of {tile}…", 0)

    def _event(self, event) -> None:
        if isinstance(event, TileFinished):
            self.tile_finished.emit(event.done, event.total)
        elif isinstance(event, EngineExportStarted):
            self.engine_started.emit(event.engine)

    def _returned(self, rendered) -> None:
        self.finished.emit(rendered)
        result = rendered.result
        self.status.emit(f"Wrote {result.path} ({result.shape[0]}x{result.shape[1]})", 10_000)

    def _failed(self, message: str) -> None:
        self.failed.emit(message)

    def _cancelled(self) -> None:
        self.cancelled.emit()
        self.status.emit("Large render cancelled; its finished tiles are kept for the next", 10_000)
