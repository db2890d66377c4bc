"""One tile's synthesis, as a worker runs it: a session on the tile's crop,
with the finished neighbours' border strips locked, on the whole map's
level field.

A tile is a local re-synthesis (:mod:`terrasynth_core.synthesis.local`)
whose selection is the tile and whose kept terrain is the finished strips
around it: its patches are matched to that terrain and merged with it by
the same graph cut and seam solve, and the strips' cells stay bit for bit.
Its level field is its window of the whole map's landform pass
(:mod:`.inputs`) instead of a pass of its own, so landforms continue
across tile borders.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..controls.options import Controls
from ..features.sketch import SketchMap
from ..heightfield import HeightField
from ..synthesis.events import drive
from ..synthesis.params import SynthesisParams
from ..synthesis.pipeline import RunState, run_pipeline
from ..synthesis.session import Session
from .inputs import CoarseWindow
from .plan import Tile

__all__ = ["TileJob", "synthesize_tile", "tile_params"]


@dataclass(frozen=True)
class TileJob:
    """Everything a worker needs for one tile (a few megabytes; never the
    whole output).

    Parameters
    ----------
    tile : Tile
    params : SynthesisParams
        The tile's (:func:`tile_params`).
    sketch : SketchMap or None
        The sketch over the tile's crop.
    coarse : CoarseWindow or None
        The landform pass under the crop (None: flat level).
    context : ndarray of float32, shape of the crop, or None
        The finished neighbours' heights in the crop (metres; the tile's
        own cells are ignored); None for a tile without finished neighbours.
        Those in the tile's band (``tile.region`` less ``tile.box``) may
        change: the tile's seams run there.
    """

    tile: Tile
    params: SynthesisParams
    sketch: SketchMap | None
    coarse: CoarseWindow | None
    context: np.ndarray | None


def tile_params(params: SynthesisParams, tile: Tile) -> SynthesisParams:
    """A tile's parameters: the run's, with the tile's seed; one process
    (a Dask worker is one core); the landform pass and drainage are the
    run's, not the tile's (drainage needs the whole map's streams)."""
    return dataclasses.replace(params, seed=tile.seed, workers=1, landform=False, drainage=False)


def synthesize_tile(job: TileJob, examples: Sequence[HeightField | np.ndarray]) -> np.ndarray:
    """Synthesize one tile.

    Parameters
    ----------
    job : TileJob
    examples : sequence of HeightField
        The run's example DEMs.

    Returns
    -------
    ndarray of float32, shape of ``job.tile.region``
        The heights of the cells the tile makes, metres.
    """
    tile = job.tile
    r0, r1, c0, c1 = tile.crop
    crop_shape = (r1 - r0, c1 - c0)
    controls = Controls()
    if job.context is not None:
        selection = np.zeros(crop_shape, bool)
        selection[tile.made] = True
        previous = np.array(job.context, dtype=np.float32)
        previous[tile.inner] = 0.0  # not read: those cells are synthesized
        controls = Controls(previous=previous, selection=selection)
    session = Session(examples, job.sketch, shape=crop_shape, params=job.params, controls=controls)
    state = RunState.start(session)
    if job.context is not None:
        # The band: terrain that is there (graph cuts weigh it as any
        # filled cell) but may be replaced, so a seam can run through it.
        band = np.zeros(crop_shape, bool)
        band[tile.made] = True
        band[tile.inner] = False
        state.canvas.filled |= band
    if job.coarse is not None:
        # The pipeline's landform stage, with the whole map's landforms: the
        # level is the window of the global pass, the examples' detail is
        # taken above the same split.
        detail, anchor = session.detail_above(job.coarse.sigma)
        state.layout = dataclasses.replace(state.layout, level=job.coarse.level(tile.crop), detail=detail,
                                           anchor=anchor)
    result = drive(run_pipeline(state), what=f"tile {tile.row},{tile.col}")
    return np.ascontiguousarray(result.heights[tile.made], dtype=np.float32)
