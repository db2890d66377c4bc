"""What a tile is given: its window of the sketch, and its window of the
level field made by one landform pass over the whole map.

The sketch is painted at any resolution and scaled to the output; a tile
takes only its window of the scaled sketch, computed from the painted
pixels under it, so no process ever holds the sketch at the output's size.

The landform pass (:mod:`terrasynth_core.synthesis.landform`) runs once,
over the whole map, so landforms cross tile borders.  Its coarse terrain is
small (the output down-sampled by the pass's factor); each tile brings its
window of it to the output's grid and low-passes it there
(:class:`CoarseWindow`), as the whole-map pass would, with enough margin
that the window's edge leaves no trace inside the tile.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import ndimage

from ..features.sketch import SketchMap, sketch_features
from ..heightfield import HeightField
from ..synthesis.landform import (DRAWN_NOTE, coarse_session_for, coherence, drawn_landforms, drawn_split,
                                  fitted_to_examples, landform_lowpass, split_sigma)
from ..synthesis.params import SynthesisParams
from ..synthesis.session import Session

__all__ = ["CoarseLevel", "CoarseWindow", "coarse_level", "sketch_window"]

#: Margin of the output-grid window a tile low-passes, in the split's
#: standard deviations: the low-pass falls like a Gaussian of sigma/sqrt(2),
#: so at 8 sigma the window's edge weighs less than 1e-27 inside the tile.
LOWPASS_MARGIN = 8.0

#: Coarse cells of margin around a window for the cubic spline: its
#: prefilter's influence falls by 0.27 a cell, 1e-9 after 16.
SPLINE_MARGIN = 16

Box = tuple[int, int, int, int]


# -- the sketch ------------------------------------------------------------------------------
def sketch_window(sketch: SketchMap | None, shape: tuple[int, int], box: Box) -> SketchMap | None:
    """The window ``box`` of ``sketch`` scaled to ``shape``.

    Parameters
    ----------
    sketch : SketchMap or None
        As painted, any size.
    shape : (rows, cols)
        The output's size.
    box : (r0, r1, c0, c1)
        Output cells, half-open.

    Returns
    -------
    SketchMap or None
        Of the box's shape; None for no sketch.  As
        :meth:`SketchMap.resized`, a cell is a stroke when any part of its
        footprint on the painted sketch is (the kind covering more of it
        wins), here for upscaling too, which may thicken a stroke by a cell.
    """
    if sketch is None:
        return None
    r0, r1, c0, c1 = box
    wr, rs = _footprints(r0, r1, shape[0], sketch.shape[0])
    wc, cs = _footprints(c0, c1, shape[1], sketch.shape[1])

    def coverage(mask: np.ndarray) -> np.ndarray:
        return wr @ mask[rs, cs].astype(np.float32) @ wc.T

    ridge, valley = coverage(sketch.ridge_mask), coverage(sketch.valley_mask)
    eps = 1e-6
    return SketchMap((ridge > eps) & (ridge >= valley), (valley > eps) & (valley > ridge))


def _footprints(lo: int, hi: int, size: int, source: int) -> tuple[np.ndarray, slice]:
    """Overlap of each output cell ``lo..hi`` (of ``size``) with the source
    pixels (of ``source``) under it: a (hi - lo, n) matrix and the slice of
    the n source pixels."""
    scale = source / size
    a = np.arange(lo, hi, dtype=np.float64) * scale
    b = a + scale
    k0 = int(math.floor(a[0]))
    k1 = min(int(math.ceil(b[-1])), source)
    k = np.arange(k0, k1, dtype=np.float64)
    overlap = np.minimum(b[:, None], k[None, :] + 1) - np.maximum(a[:, None], k[None, :])
    return np.clip(overlap, 0.0, None).astype(np.float32), slice(k0, k1)


# -- the level field ---------------------------------------------------------------------------
@dataclass(frozen=True)
class CoarseLevel:
    """The landform pass's terrain over the whole map.

    Parameters
    ----------
    heights : ndarray of float32, shape (R, C)
        The coarse terrain (fitted to the examples' heights as the
        whole-map pass does), metres; or the drawing's landforms where the
        pass cannot serve
        (:func:`~terrasynth_core.synthesis.landform.drawn_landforms`).
    shape : (rows, cols)
        The output's size; the coarse grid spans it.
    sigma : float
        The standard deviation of the level's low-pass
        (:func:`~terrasynth_core.synthesis.landform.split_sigma`), output
        cells.
    factor : int
        The coarse grid's down-sampling.
    coherent : ndarray of float32, shape (R, C), or None
        Where the level and the detail carry the same landform
        (:func:`~terrasynth_core.synthesis.landform.coherence`); None
        without strokes.
    split : float, optional
        The examples' landform/detail split, output cells: ``sigma``
        unless given (the drawing's landforms:
        :func:`~terrasynth_core.synthesis.landform.drawn_split`).
    """

    heights: np.ndarray
    shape: tuple[int, int]
    sigma: float
    factor: int
    coherent: np.ndarray | None = None
    split: float | None = None

    def window(self, box: Box) -> "CoarseWindow":
        """What a tile needs to make the level over ``box`` (output cells):
        the coarse cells under it and its margins."""
        r0, r1, c0, c1 = box
        pad = int(math.ceil(LOWPASS_MARGIN * self.sigma))
        R, C = self.heights.shape
        q0, q1 = _coarse_span(r0 - pad, r1 + pad, self.shape[0], R)
        p0, p1 = _coarse_span(c0 - pad, c1 + pad, self.shape[1], C)
        coherent = None if self.coherent is None else np.array(self.coherent[q0:q1, p0:p1])
        return CoarseWindow(np.array(self.heights[q0:q1, p0:p1]), (q0, p0), (R, C), self.shape, self.sigma, coherent,
                            self.detail_split)

    @property
    def detail_split(self) -> float:
        """The examples' landform/detail split, output cells."""
        return self.sigma if self.split is None else self.split


def _coarse_span(lo: int, hi: int, size: int, coarse: int) -> tuple[int, int]:
    """The coarse cells whose spline reaches output cells ``lo..hi``."""
    scale = coarse / size
    a = (lo + 0.5) * scale - 0.5
    b = (hi - 0.5) * scale - 0.5
    return max(int(math.floor(a)) - SPLINE_MARGIN, 0), min(int(math.ceil(b)) + SPLINE_MARGIN + 1, coarse)


@dataclass(frozen=True)
class CoarseWindow:
    """A window of :class:`CoarseLevel`, sent to the tile that needs it.

    Parameters
    ----------
    heights : ndarray of float32
        The coarse cells of the window.
    origin : (row, col)
        Its first cell on the coarse grid.
    coarse_shape, shape : (rows, cols)
        The whole coarse grid and the output.
    sigma : float
        The level's low-pass, output cells (:class:`CoarseLevel`).
    coherent : ndarray of float32, or None
        The coarse cells' coherence weights (:class:`CoarseLevel`).
    split : float
        The examples' landform/detail split, output cells
        (:attr:`CoarseLevel.detail_split`).
    """

    heights: np.ndarray
    origin: tuple[int, int]
    coarse_shape: tuple[int, int]
    shape: tuple[int, int]
    sigma: float
    coherent: np.ndarray | None
    split: float

    def level(self, box: Box) -> np.ndarray:
        """The level field over ``box``: the coarse terrain interpolated
        (cubic, at output cell centres, as the whole-map pass) and low-passed
        (:func:`~terrasynth_core.synthesis.landform.landform_lowpass`, with
        the coherence weights interpolated alike).

        Returns
        -------
        ndarray of float32, shape (r1 - r0, c1 - c0)
            Metres.
        """
        r0, r1, c0, c1 = box
        pad = int(math.ceil(LOWPASS_MARGIN * self.sigma))
        rows, cols = self.shape
        a0, a1 = max(r0 - pad, 0), min(r1 + pad, rows)
        b0, b1 = max(c0 - pad, 0), min(c1 + pad, cols)
        # Output cell centres on the coarse grid (grid mode: the coarse grid
        # spans the output exactly), in the window's own cells.
        y = (np.arange(a0, a1) + 0.5) * self.coarse_shape[0] / rows - 0.5 - self.origin[0]
        x = (np.arange(b0, b1) + 0.5) * self.coarse_shape[1] / cols - 0.5 - self.origin[1]
        yy, xx = np.meshgrid(y, x, indexing="ij")
        up = ndimage.map_coordinates(self.heights.astype(np.float64), [yy, xx], order=3, mode="nearest")
        weight = None if self.coherent is None else ndimage.map_coordinates(
            self.coherent.astype(np.float64), [yy, xx], order=3, mode="nearest")
        del yy, xx
        level = landform_lowpass(up, self.sigma, weight)
        return level[r0 - a0:r1 - a0, c0 - b0:c1 - b0].astype(np.float32)


def coarse_level(examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None, shape: tuple[int, int],
                 params: SynthesisParams) -> tuple[CoarseLevel | None, list[str]]:
    """Run the landform pass once over the whole map.

    The pass's session is made by
    :func:`~terrasynth_core.synthesis.landform.coarse_session_for` from the
    parts of the whole map's session: the examples' layout of a small session
    (which does not depend on the output's size for plain examples), the
    output's size and the painted sketch (scaled by the pass to its coarse
    grid).  No array of the output's size is made.

    Parameters
    ----------
    examples, sketch
        The run's inputs.
    shape : (rows, cols)
        The output's size.
    params : SynthesisParams
        The run's; ``landform=False`` skips the pass.

    Returns
    -------
    level : CoarseLevel or None
        The pass's terrain, or where it cannot serve the drawing's
        landforms; None when the pass is off, or cannot serve and nothing
        stands in for it (no strokes, several style regions): then every
        tile builds on the flat level, as with ``landform=False``.
    notes : list of str
        The warnings of the probe and the pass.
    """
    if not params.landform:
        return None, []
    # One process: this runs in a Dask worker, whose cores the cluster
    # schedules (a worker of a remote cluster may not start processes).
    params = dataclasses.replace(params, workers=1)
    side = 2 * params.patch_size
    probe = Session(examples, None, shape=(side, side), params=dataclasses.replace(params, landform=False,
                                                                                  drainage=False))
    maps = probe.sketch_maps if sketch is None or not sketch.has_strokes else sketch_features(sketch)
    coarse, factor, note = coarse_session_for(params, probe.layout, tuple(shape), probe.controls, probe.n_plain,
                                              sketch, maps)
    notes = [note] if note else []
    if coarse is None:
        # As the whole-map run (landform.drawn_level): where the examples
        # cannot give landforms, the drawing gives them alone.
        drawn = None if note is None else drawn_landforms(sketch, tuple(shape), probe.layout, params.patch_size)
        if drawn is None:
            return None, notes
        heights, f = drawn
        notes[-1] += DRAWN_NOTE
        return CoarseLevel(heights, tuple(shape), split_sigma(params.patch_size), f,
                           split=drawn_split(params.patch_size)), notes
    result = coarse.run()
    # As the whole-map pass (landform.landform_from): chained patches may
    # carry the coarse terrain out of the examples' heights.
    sigma = split_sigma(params.patch_size)
    heights = fitted_to_examples(result.heights, probe.layout, factor, sigma, result.sketch_features)
    coherent = coherence(result.sketch_features, params.patch_size, factor)
    return CoarseLevel(np.asarray(heights, np.float32), tuple(shape), sigma, factor, coherent), notes
