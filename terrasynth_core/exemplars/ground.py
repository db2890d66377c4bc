"""One square cell size for a run: which size, and every example resampled to it.

Patches are copied cell for cell, so examples must share one ground cell
size for their features to keep their real proportions (and for rotated
patches not to be stretched): each example, style and stamp DEM is
resampled once to square cells of the run's size
(:func:`~terrasynth_core.io.resample.to_square_cells`), the warp's NaN
corners cropped.  The result is memoised per (source heights, source cell
and CRS, cell size), in memory and on disk (:mod:`.cache`), next to the
example analysis.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np

from ..errors import ParamsError
from ..heightfield import CROP_KEEPS, LEAST_SIDE, MOST_GRID_CELLS, HeightField
from ..io.resample import already_square, ground_cell_size, to_square_cells
from . import cache

__all__ = ["UPSAMPLE_WARNING", "on_ground", "run_cell_size"]

#: Up-sampling factor above which an example is named in the warnings.
UPSAMPLE_WARNING = 2.0

_MEMO = cache.Memo(16, cache.load_array, cache.save_array)


def run_cell_size(cell_size: float | None, fields) -> float | None:
    """The run's square cell size in metres.

    Parameters
    ----------
    cell_size : float or None
        Asked for (``SynthesisParams.cell_size``); wins when given.
    fields : iterable of HeightField or ndarray
        Every DEM the run uses (examples, styles, stamps).

    Returns
    -------
    float or None
        ``cell_size``, else the finest :func:`ground_cell_size` among the
        fields, else None (no field knows its cell size).
    """
    if cell_size is not None:
        return float(cell_size)
    sizes = [ground_cell_size(f) for f in fields if isinstance(f, HeightField)]
    sizes = [s for s in sizes if s is not None]
    return min(sizes) if sizes else None


def on_ground(field: HeightField | np.ndarray, cell_size: float | None, *,
              name: str) -> tuple[HeightField | np.ndarray, list[str]]:
    """``field`` at square cells of ``cell_size`` metres, NaN edges cropped.

    Parameters
    ----------
    field : HeightField or ndarray
        A field without cell size (or an array) is taken to be at
        ``cell_size`` already and comes back unchanged, as does one whose
        cells are already square at that size.
    cell_size : float or None
        None (the run's cell size is unknown): ``field`` unchanged.
    name : str
        For messages.

    Returns
    -------
    field : HeightField or ndarray
        Resampled (a new HeightField with ``cell_size == (c, c)``) or
        ``field`` itself.
    notes : list of str
        For the run's warnings: the example was up-sampled by more than
        :data:`UPSAMPLE_WARNING` times; its nodata was cropped away.

    Raises
    ------
    ParamsError
        The resampled example has no valid cell.
    """
    if cell_size is None or not isinstance(field, HeightField) or field.cell_size is None:
        return field, []
    if already_square(field, cell_size):  # projected or plain grid at the size: nothing to warp
        return field, []
    dy, dx = field.cell_size
    _check_grid(field.shape, (dy, dx), cell_size, name)
    notes = []
    factor = max(dy, dx) / cell_size
    if factor > UPSAMPLE_WARNING:
        notes.append(f"{name}: {dy:.4g} x {dx:.4g} m cells up-sampled {factor:.1f}x to {cell_size:g} m: its "
                     "detail will be soft; a finer example or --cell-size N would help")
    heights = _MEMO.get(_key(field, cell_size), lambda: _resampled(field, cell_size, name))
    if field.nodata_count and not np.isnan(heights).any():  # (voids kept inside: prepare_example says so)
        notes.append(f"{name}: cropped to its largest valid rectangle {heights.shape[0]}x{heights.shape[1]} at "
                     f"{cell_size:g} m (nodata)")
    out = HeightField(heights, cell_size=(cell_size, cell_size), source=field.source, format=field.format,
                      metadata={**field.metadata, "resampled_from": (dy, dx)})
    return out, notes


def _check_grid(shape: tuple[int, int], cells: tuple[float, float], cell_size: float, name: str) -> None:
    """Refuse a cell size at which the example's grid would be too large to
    hold or too small to synthesize from, naming the cell sizes that work.

    Parameters
    ----------
    shape : (rows, cols)
        The example's grid.
    cells : (dy, dx)
        Its cell size, metres.
    cell_size : float
        The run's, metres.
    """
    rows, cols = shape[0] * cells[0] / cell_size, shape[1] * cells[1] / cell_size
    grid = f"{name}: at {cell_size:g} m cells its {shape[0]}x{shape[1]} grid of {cells[0]:.4g} x {cells[1]:.4g} m " \
           f"cells would become about {_count(rows)}x{_count(cols)} cells"
    if rows * cols > MOST_GRID_CELLS:
        finest = _rounded(cell_size * math.sqrt(rows * cols / MOST_GRID_CELLS), math.ceil)
        raise ParamsError(f"{grid}, over the {MOST_GRID_CELLS // 1_000_000} million an example may have; "
                          f"a cell size of at least {finest:g} m (--cell-size) keeps it within")
    if min(rows, cols) < LEAST_SIDE:
        coarsest = _rounded(cell_size * min(rows, cols) / LEAST_SIDE, math.floor)
        raise ParamsError(f"{grid}, too few to synthesize from; a cell size of at most {coarsest:g} m "
                          "(--cell-size) keeps more of it")


def _count(cells: float) -> str:
    """A cell count for a message: whole from 10 up, to a tenth below."""
    return f"{cells:.0f}" if cells >= 10 else f"{cells:.1f}"


def _rounded(value: float, direction) -> float:
    """``value`` to three significant figures, rounded by ``direction``
    (``math.ceil`` or ``math.floor``): a suggested cell size that passes."""
    scale = 10.0 ** (math.floor(math.log10(value)) - 2)
    return direction(value / scale) * scale


def _resampled(field: HeightField, cell_size: float, name: str) -> np.ndarray:
    """The heights at square cells, the warp's NaN edges cut away
    (:meth:`~terrasynth_core.heightfield.HeightField.trim_nodata`)."""
    resampled = to_square_cells(field, cell_size)
    heights = resampled.trim_nodata().heights
    if np.isnan(heights).all():
        raise ParamsError(f"{name}: no valid cell left after resampling to {cell_size:g} m cells")
    return heights


def _key(field: HeightField, cell_size: float) -> str:
    """Digest of what the resampled grid depends on: heights, cell size,
    georeference (CRS and where the grid lies), the new size and the
    nodata trimming."""
    h = hashlib.sha1(np.ascontiguousarray(field.heights).tobytes())
    geo = field.georef
    where = None if geo is None else (geo.x_origin, geo.y_origin, geo.x_step, geo.y_step, geo.epsg, geo.crs_wkt)
    # (With how nodata is trimmed: grids stored before voids were kept inside
    # were cropped.)
    h.update(repr((field.shape, field.cell_size, where, float(cell_size), "trim", CROP_KEEPS)).encode())
    return "ground-" + h.hexdigest()
