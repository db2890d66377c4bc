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
from terrasynth_core.export.engines import check_export, export_file_for_engine
from terrasynth_core.tiled import TileFinished, TiledResult, run_tiled, tiled_project_inputs

from .run_request import SynthesisRequest, reported_events

__all__ = ["LargeRender", "LargeRendered", "large_render_events"]


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
        return self.out.with_name(f"{self.out.stem}_{self.engine}")


@dataclass(frozen=True)
class LargeRendered:
    """What a render made: the core's ``TiledResult``, and the engine's
    files when asked for (an ``EngineExport``, else None)."""

    result: TiledResult
    engine: object | None


def large_render_events(request: SynthesisRequest, render: LargeRender, *,
                        poll_seconds: float = 0.1) -> Iterator[TileFinished | None]:
    """Render ``request`` tiled: a ``TileFinished`` per tile, then the
    engine's files when ``render`` asks for them.

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
        # Checked now: a long render never ends on a name already taken.
        check_export(render.engine, render.engine_folder(), tiles=render.engine_tiles, stem=render.out.stem)
    result: TiledResult = yield from reported_events(
        lambda report, cancel: run_tiled(examples, sketch, shape=render.size, tile=render.tile, out=render.out,
                                         params=params, workers=render.workers, progress=report, cancel=cancel,
                                         controls=controls),
        name="render-large", poll_seconds=poll_seconds)
    engine = None
    if render.engine is not None:
        try:
            engine = export_file_for_engine(render.out, render.engine, render.engine_folder(),
                                            tiles=render.engine_tiles, stem=render.out.stem)
        except TerraSynthError as exc:
            raise type(exc)(f"wrote {render.out}, but not the {render.engine} files: {exc}") from exc
    return LargeRendered(result, engine)
