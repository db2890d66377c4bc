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

from terrasynth_core.tiled import TileFinished, TiledResult, run_tiled, tiled_project_inputs

from .run_request import SynthesisRequest, reported_events

__all__ = ["LargeRender", "large_render_events"]


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
    """

    size: tuple[int, int]
    tile: int
    workers: int
    out: Path


def large_render_events(request: SynthesisRequest, render: LargeRender, *,
                        poll_seconds: float = 0.1) -> Iterator[TileFinished | None]:
    """Render ``request`` tiled: a ``TileFinished`` per tile.

    The run reports by callback, so it runs on a helper thread; while
    waiting this yields None every ``poll_seconds`` (a cancel checkpoint
    for the consumer).  Closing the generator stops the run.

    Returns
    -------
    TiledResult
        The generator's return value.

    Raises
    ------
    ParamsError
        The document uses controls a tiled run does not take (a height
        range, a re-synthesis), or a bad size
        or tile (before any work).
    """
    # Pins and stamps follow the sketch to the render's size.
    examples, sketch, params, controls = tiled_project_inputs(request.at_size(render.size))
    result: TiledResult = yield from reported_events(
        lambda report, cancel: run_tiled(examples, sketch, shape=render.size, tile=render.tile, out=render.out,
                                         params=params, workers=render.workers, progress=report, cancel=cancel,
                                         controls=controls),
        name="render-large", poll_seconds=poll_seconds)
    return result
