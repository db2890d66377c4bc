"""*Render large...*: the document rendered at a world size as tiles on Dask
(:mod:`terrasynth_core.tiled`), as events a worker drains.

Plain Python, no Qt: the controller hands :func:`large_render_events` to a
worker thread; each finished tile is a ``TileFinished`` event, and closing
the generator (the worker's cancel) stops the run within a fraction of a
second, its finished tiles kept beside the output for the next run.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

from terrasynth_core.errors import TerraSynthError
from terrasynth_core.export.engines import check_export, export_file_for_engine, folder_beside
from terrasynth_core.tiled import TileFinished, TiledResult, run_tiled, tiled_project_inputs
from terrasynth_core.tiled.run import check_tiled_output

from .run_request import SynthesisRequest, reported_events

__all__ = ["EngineExportStarted", "LargeRender", "LargeRendered", "large_render_events"]


@dataclass(frozen=True)
class LargeRender:
    """What to render and where.

    Parameters
    ----------
    size : (rows, cols)
        Output cells.
    tile : int
        Tile side, cells.
    workers : int
        Local Dask worker processes.
    out : Path
        The GeoTIFF to write.
    engine : str, optional
        Also write the terrain for this engine or tool (a preset of
        :data:`terrasynth_core.export.PRESETS`) into :meth:`engine_folder`,
        read from the GeoTIFF window by window.
    engine_tiles : int, default 1
        Its ``K x K`` tiles (unreal, unity).
    """

    size: tuple[int, int]
    tile: int
    workers: int
    out: Path
    engine: str | None = None
    engine_tiles: int = 1

    def engine_folder(self) -> Path:
        """``OUTSTEM_PRESET`` beside the GeoTIFF, as ``synth --engine`` writes it."""
        return folder_beside(self.out, self.engine)


@dataclass(frozen=True)
class LargeRendered:
    """What a render made: the core's ``TiledResult``, and the engine's
    files when asked for (an ``EngineExport``, else None)."""

    result: TiledResult
    engine: object | None


def large_render_events(request: SynthesisRequest, render: LargeRender, *,
                        poll_seconds: float = 0.1) -> Iterator[TileFinished | EngineExportStarted | None]:
    """Render ``request`` tiled: a ``TileFinished`` per tile, then, when
    ``render`` asks for them, an ``EngineExportStarted`` and the engine's files.

    The run reports by callback, so it runs on a helper thread; while
    waiting this yields None every ``poll_seconds`` (a cancel checkpoint
    for the consumer).  Closing the generator stops the run.

    Returns
    -------
    LargeRendered
        The generator's return value.

    Raises
    ------
    ParamsError, DEMFormatError
        The document uses controls a tiled run does not take (a height
        range, a re-synthesis), a bad size or tile, or an engine folder
        holding a file the export would replace (before any work); the
        engine's files not written (after the GeoTIFF is).
    """
    # Pins and stamps follow the sketch to the render's size.
    examples, sketch, params, controls = tiled_project_inputs(request.at_size(render.size))
    if render.engine is not None:
        # Checked now: a long render never ends on a name already taken or
        # a grid too large.
        check_tiled_output(render.out)
        check_export(render.engine, render.engine_folder(), shape=render.size, tiles=render.engine_tiles,
                     stem=render.out.stem, hint="remove it, or choose another GeoTIFF name (the folder is named "
                                                "after it)")
    result: TiledResult = yield from reported_events(
        lambda report, cancel: run_tiled(examples, sketch, shape=render.size, tile=render.tile, out=render.out,
                                         params=params, workers=render.workers, progress=report, cancel=cancel,
                                         controls=controls),
        name="render-large", poll_seconds=poll_seconds)
    engine = None
    if render.engine is not None:
        # On a helper thread too, so that Cancel stops it between tiles
        # (and removes what it wrote); the GeoTIFF stays.
        yield EngineExportStarted(render.engine)
        try:
            engine = yield from reported_events(
                lambda report, cancel: export_file_for_engine(render.out, render.engine, render.engine_folder(),
                                                              tiles=render.engine_tiles, stem=render.out.stem,
                                                              cancel=cancel),
                name="render-large-engine", poll_seconds=poll_seconds)
        except TerraSynthError as exc:
            raise type(exc)(f"the GeoTIFF {render.out} is written; the {render.engine} files are not: {exc}") from exc
    return LargeRendered(result, engine)


@dataclass(frozen=True)
class EngineExportStarted:
    """The tiles are done and the GeoTIFF written; the engine's files are being made."""

    engine: str
