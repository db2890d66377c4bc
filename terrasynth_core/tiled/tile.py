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

from ..controls.stamps import render_stamp
from ..features.sketch import SketchMap
from ..heightfield import HeightField
from ..synthesis.events import drive
from ..synthesis.landform import level_under_stamps
from ..synthesis.params import SynthesisParams
from ..synthesis.session import Session
from .controls import TileControls
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
        The landform pass under the crop's level box (None: no pass).
    context : ndarray of float32, shape of the crop, or None
        The finished neighbours' heights in the crop (metres; the tile's
        own cells are ignored); None for a tile without finished neighbours.
        Those in the tile's band (``tile.region`` less ``tile.box``) may
        change: the tile's seams run there.
    controls : TileControls
        Its part of the run's style regions, water, stamps and pins, and
        what its level field is made of.
    cell_size : float or None
        The run's, metres (where stamps land).
    """

    tile: Tile
    params: SynthesisParams
    sketch: SketchMap | None
    coarse: CoarseWindow | None
    context: np.ndarray | None
    controls: TileControls
    cell_size: float | None = None


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
        The run's example DEMs as sent to the workers: the plain ones, then
        the styles', then the stamps' (see
        :class:`~terrasynth_core.tiled.controls.MapControls`).

    Returns
    -------
    ndarray of float32, shape of ``job.tile.region``
        The heights of the cells the tile makes, metres.
    """
    tile, tc = job.tile, job.controls
    r0, r1, c0, c1 = tile.crop
    crop_shape = (r1 - r0, c1 - c0)
    previous = selection = band = None
    if job.context is not None:
        selection = np.zeros(crop_shape, bool)
        selection[tile.made] = True
        previous = np.array(job.context, dtype=np.float32)
        previous[tile.inner] = 0.0  # not read: those cells are synthesized
        # The band: terrain that is there (graph cuts weigh it as any
        # filled cell) but may be replaced, so a seam can run through it.
        band = selection.copy()
        band[tile.inner] = False
    controls = tc.controls(examples, previous=previous, selection=selection)
    level, split = _level(job, crop_shape, controls.stamps)
    session = Session(examples[:tc.n_plain], job.sketch, shape=crop_shape, params=job.params, controls=controls,
                      level=level, level_split=split, band=band)
    result = drive(session.iter_run(), what=f"tile {tile.row},{tile.col}")
    return np.ascontiguousarray(result.heights[tile.made], dtype=np.float32)


def _level(job: TileJob, crop_shape: tuple[int, int], stamps) -> tuple[np.ndarray, float | None]:
    """The tile's window of the whole map's level field, and the
    examples' landform/detail split to go with it (None: no landform pass,
    nor the drawing's landforms standing in for it).

    With the landform pass or the drawing's landforms: its window
    (:mod:`.inputs`); without: the style groups' bases blurred across their
    borders.  Then bent through the pins within reach and, under the pass
    or the drawing's landforms, made flat under the tile's stamps
    (``stamps``, in crop cells), as a whole-map run's
    (:func:`~terrasynth_core.synthesis.landform.landform_from`).
    """
    tile, tc, patch = job.tile, job.controls, job.params.patch_size
    r0, r1, c0, c1 = tile.crop
    if job.coarse is not None and not tc.steering and not stamps:
        return job.coarse.level(tile.crop), job.coarse.split  # nothing bends it: the window itself
    e0, e1, f0, f1 = box = tc.level_box
    level = tc.plain_level(patch) if job.coarse is None else job.coarse.level(box)
    level = tc.steered(level, patch)[r0 - e0:r1 - e0, c0 - f0:c1 - f0]
    if job.coarse is None:
        return level, None
    rendered = [render_stamp(s, crop_shape, patch, cell_size=job.cell_size, notes=[]) for s in stamps]
    return level_under_stamps(level, rendered, patch), job.coarse.split
