"""The height field: heights, their nodata mask, cell size and georeference.

Every reader returns a :class:`HeightField` and every writer takes one.  The
grid is stored north-up: row 0 is the northern edge, column 0 the western
edge, indexing is ``(row, col)``.

Nodata strategy
---------------
Cells without a valid height are ``NaN`` in :attr:`HeightField.heights` and
``True`` in :attr:`HeightField.nodata`; they are never silently zero.  The
algorithms do not accept NaN.  Two ways to get a fully valid grid:

* :meth:`HeightField.crop_valid` crops to the largest axis-aligned rectangle
  holding only valid cells (no invented terrain, but a basin clip or a
  tile with a void inside can lose half its cells).
* :meth:`HeightField.fill_nodata` fills each invalid cell from its nearest
  valid cell and smooths the fill.

Examples take :meth:`HeightField.trim_nodata`: the crop when it keeps
nearly every valid cell (a ragged edge, a reprojection's slivers), else
only the margins, the voids inside left for the engine to fill and keep
out of every patch (:func:`terrasynth_core.exemplars.prepare_example`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage

from .errors import DEMFormatError, ParamsError

#: :meth:`HeightField.trim_nodata` crops to the largest valid rectangle when
#: it keeps this share of the valid cells.
CROP_KEEPS = 0.9

#: Fewest cells along a height field's side.
LEAST_SIDE = 2

#: Most cells of a grid the engine makes: an output, an example at the
#: run's cell size, an export's resampled grid (beyond it the arrays and
#: the solvers take gigabytes).
MOST_GRID_CELLS = 64_000_000

#: Heights the engine takes, metres: within +- this (Earth's relief is under 20 km;
#: larger values are other units or fill values, and overflow the solvers).
HEIGHT_LIMIT = 100_000.0

#: Mean Earth radius in metres (IUGG), used to turn arc-seconds into metres.
EARTH_RADIUS_M = 6_371_008.8


@dataclass(frozen=True)
class GeoReference:
    """Where the grid lies on Earth.

    Parameters
    ----------
    x_origin, y_origin : float
        Map coordinates of the upper-left *corner* of the upper-left cell, in
        the units of the CRS (metres for UTM, degrees for geographic).
    x_step, y_step : float
        Cell size along columns and rows, in CRS units; ``y_step`` is positive
        and rows run north to south.
    epsg : int or None
        EPSG code of the coordinate reference system when known
        (4326 for SRTM tiles, 326zz for WGS 84 / UTM zone zz North).
    crs_wkt : str or None
        The coordinate reference system as WKT, when known.  It is what
        names a CRS without an EPSG code (a local Transverse Mercator, a
        compound CRS with a vertical datum); beside an EPSG code it only
        describes it.

    Notes
    -----
    Two georeferences are equal when their origin and steps are, and their
    CRS: the EPSG code when either has one, else the WKT text (the same CRS
    read back from a file may be worded differently; compare
    ``rasterio.crs.CRS.from_wkt`` objects to tell).
    """

    x_origin: float
    y_origin: float
    x_step: float
    y_step: float
    epsg: int | None = None
    crs_wkt: str | None = field(default=None, repr=False)

    def _crs_key(self):
        return ("epsg", self.epsg) if self.epsg is not None else ("wkt", self.crs_wkt)

    def __eq__(self, other):
        if not isinstance(other, GeoReference):
            return NotImplemented
        return (self.x_origin, self.y_origin, self.x_step, self.y_step, self._crs_key()) == (
            other.x_origin, other.y_origin, other.x_step, other.y_step, other._crs_key())

    def __hash__(self):
        return hash((self.x_origin, self.y_origin, self.x_step, self.y_step, self._crs_key()))

    def at(self, row: int, col: int) -> "GeoReference":
        """The georeference of a window of the grid whose first cell is
        ``(row, col)``: the origin moves with it."""
        return replace(self, x_origin=self.x_origin + col * self.x_step, y_origin=self.y_origin - row * self.y_step)


def geographic_cell_size(lat_deg: float, step_deg: float) -> tuple[float, float]:
    """Ground size ``(dy, dx)`` in metres of a geographic cell.

    Parameters
    ----------
    lat_deg : float
        Latitude of the cell centre in degrees.
    step_deg : float
        Angular cell size in degrees (1/1200 for 3 arc-seconds).

    Returns
    -------
    (dy, dx) : tuple of float
        North-south and east-west size in metres; ``dx`` shrinks with
        ``cos(lat)`` because meridians converge.
    """
    dy = math.radians(step_deg) * EARTH_RADIUS_M
    dx = dy * math.cos(math.radians(lat_deg))
    return (dy, dx)


@dataclass(frozen=True, eq=False)
class HeightField:
    """A north-up grid of heights in metres.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Heights in metres; ``NaN`` marks nodata.  Infinite values are
        rejected.
    cell_size : (dy, dx) or None
        Ground size of a cell in metres, north-south then east-west, when
        the file tells or implies it.
    georef : GeoReference or None
        Map placement when the format carries one.
    source : str or None
        File the field was read from, for messages.
    format : str or None
        Short name of the format it was read from (``"hgt"``, ``"geotiff"``...).
    """

    heights: np.ndarray
    cell_size: tuple[float, float] | None = None
    georef: GeoReference | None = None
    source: str | None = None
    format: str | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        h = np.asarray(self.heights)
        where = f" in {self.source}" if self.source else ""
        if h.ndim != 2 or min(h.shape) < LEAST_SIDE:
            raise DEMFormatError(
                f"height field{where} must be a 2-D grid of at least {LEAST_SIDE}x{LEAST_SIDE} cells, "
                f"got shape {h.shape}"
            )
        if not np.issubdtype(h.dtype, np.number):
            raise DEMFormatError(f"height field{where} has non-numeric type {h.dtype}")
        h = h.astype(np.float32, copy=False)
        if np.isinf(h).any():
            raise DEMFormatError(
                f"height field{where} holds {int(np.isinf(h).sum())} infinite values; "
                "expected finite heights in metres (NaN for nodata)"
            )
        if np.isnan(h).all():
            raise DEMFormatError(f"height field{where} has no valid cell: every cell is nodata")
        if self.cell_size is not None:
            dy, dx = (float(v) for v in self.cell_size)
            if not (dy > 0 and dx > 0 and math.isfinite(dy) and math.isfinite(dx)):
                raise DEMFormatError(f"height field{where} has invalid cell size {self.cell_size}")
            object.__setattr__(self, "cell_size", (dy, dx))
        h.flags.writeable = False
        object.__setattr__(self, "heights", h)

    # -- derived ---------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the grid."""
        return self.heights.shape

    @property
    def nodata(self) -> np.ndarray:
        """Boolean mask, shape (rows, cols): ``True`` where there is no height."""
        return np.isnan(self.heights)

    @property
    def nodata_count(self) -> int:
        return int(np.isnan(self.heights).sum())

    @property
    def min(self) -> float:
        return float(np.nanmin(self.heights))

    @property
    def max(self) -> float:
        return float(np.nanmax(self.heights))

    def with_heights(self, heights: np.ndarray, **changes) -> "HeightField":
        """A copy with new heights (same cell size and georeference unless changed)."""
        return replace(self, heights=heights, **changes)

    # -- nodata strategies ----------------------------------------------
    def crop_valid(self) -> "HeightField":
        """Crop to the largest rectangle of valid cells.

        Returns the field itself when it has no nodata.  The georeference
        origin moves with the crop.
        """
        valid = ~self.nodata
        if valid.all():
            return self
        return self.window(*largest_valid_rectangle(valid))

    def trim_nodata(self) -> "HeightField":
        """Cut nodata away as an example wants it.

        The largest valid rectangle (:meth:`crop_valid`) when it keeps at
        least :data:`CROP_KEEPS` of the valid cells: a ragged quadrangle or
        a reprojected tile's slivers.  Otherwise (a basin clip, a void
        inside a tile) the valid cells' bounding box, with the nodata
        inside still NaN: cropping would throw real terrain away.
        """
        valid = ~self.nodata
        if valid.all():
            return self
        r0, r1, c0, c1 = largest_valid_rectangle(valid)
        if (r1 - r0) * (c1 - c0) >= CROP_KEEPS * int(valid.sum()):
            return self.window(r0, r1, c0, c1)
        box = _bounds(valid)
        return self if box == (0, self.shape[0], 0, self.shape[1]) else self.window(*box)

    def window(self, r0: int, r1: int, c0: int, c1: int) -> "HeightField":
        """Rows ``r0:r1`` and columns ``c0:c1`` (a copy); the georeference
        origin moves with them."""
        geo = None if self.georef is None else self.georef.at(r0, c0)
        return replace(self, heights=self.heights[r0:r1, c0:c1].copy(), georef=geo)

    def fill_nodata(self) -> "HeightField":
        """Fill nodata cells from their nearest valid cell, then smooth the fill.

        Only the filled cells change; valid heights are kept exactly.
        """
        mask = self.nodata
        if not mask.any():
            return self
        # Only the voids' bounding box and a ring of valid cells around it
        # take part: every void cell's nearest valid cell lies there, and the
        # smoothing reads one cell further per pass from void cells only.
        r0, r1, c0, c1 = _bounds(mask)
        box = (slice(max(r0 - 1, 0), r1 + 1), slice(max(c0 - 1, 0), c1 + 1))
        hole, part = mask[box], self.heights[box]
        idx = ndimage.distance_transform_edt(hole, return_distances=False, return_indices=True)
        filled = part[tuple(idx)]
        # A few passes of a 3x3 mean inside the hole remove the Voronoi steps
        # that nearest-neighbour filling leaves, without touching valid cells.
        for _ in range(8):
            smooth = ndimage.uniform_filter(filled, size=3, mode="nearest")
            filled = np.where(hole, smooth, filled)
        heights = self.heights.copy()
        heights[box] = filled
        return replace(self, heights=heights.astype(np.float32, copy=False))


def _bounds(mask: np.ndarray) -> tuple[int, int, int, int]:
    """Half-open ``(r0, r1, c0, c1)`` of the ``True`` cells of a boolean
    grid that has some."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def whole_windows(valid: np.ndarray, size) -> np.ndarray:
    """Where a window of ``valid`` cells is wholly valid.

    Parameters
    ----------
    valid : ndarray of bool, shape (H, W)
    size : int or (h, w)
        Window side(s), cells.

    Returns
    -------
    ndarray of bool, shape (H, W)
        At each cell, whether the window centred on it as ``scipy.ndimage``
        centres one (rows ``i - h // 2`` to ``i + (h - 1) // 2``) lies
        inside the grid and holds only valid cells.
    """
    return ndimage.minimum_filter(valid, size=size, mode="constant", cval=False)


def largest_valid_rectangle(valid: np.ndarray) -> tuple[int, int, int, int]:
    """Largest axis-aligned all-``True`` rectangle of a boolean grid.

    Parameters
    ----------
    valid : ndarray of bool, shape (rows, cols)

    Returns
    -------
    (r0, r1, c0, c1) : tuple of int
        Half-open row and column bounds of the rectangle.

    Notes
    -----
    The classic dynamic programme, O(rows * cols), a row at a time in
    array operations: per column, the run of ``True`` cells ending in the
    row (its height) and how far left and right the columns stay at least
    that tall (the running bounds of the row's own runs).  Of equal areas
    the first row wins, then the rectangle ending furthest left, then the
    tallest (the order of the histogram-stack method this replaced, whose
    scan in Python took 5 s on a reprojected 3601x3601 tile).
    """
    rows, cols = valid.shape
    if valid.all():
        return 0, rows, 0, cols
    at = np.arange(cols)
    heights = np.zeros(cols, dtype=np.int64)
    left = np.zeros(cols, dtype=np.int64)
    right = np.full(cols, cols, dtype=np.int64)
    best = (0, 0, 0, 0, 0)  # area, r0, r1, c0, c1
    for r in range(rows):
        v = valid[r]
        heights = np.where(v, heights + 1, 0)
        # Start and end of the row's run of True cells through each column.
        run_left = np.maximum.accumulate(np.where(v, 0, at + 1))
        run_right = np.minimum.accumulate(np.where(v, cols, at)[::-1])[::-1]
        left = np.where(v, np.maximum(left, run_left), 0)
        right = np.where(v, np.minimum(right, run_right), cols)
        area = heights * (right - left)
        top = int(area.max())
        if top > best[0]:
            ties = np.flatnonzero(area == top)
            c = ties[np.lexsort((-heights[ties], right[ties]))[0]]
            best = (top, r + 1 - int(heights[c]), r + 1, int(left[c]), int(right[c]))
    if best[0] == 0:
        raise DEMFormatError("grid has no valid cell")
    return best[1:]


def height_grid(heights, *, min_side: int = 2) -> np.ndarray:
    """The float32 height grid of an array or a :class:`HeightField`, checked.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
        Heights in metres, NaN = nodata; any integer or float dtype.
    min_side : int, default 2
        Fewest rows and columns the caller's neighbourhood operations need.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        ``heights`` itself when it already is float32, else a converted copy.

    Raises
    ------
    ParamsError
        When the grid is not 2-D, has a side below ``min_side`` or is not numeric.
    """
    h = np.asarray(heights.heights if isinstance(heights, HeightField) else heights)
    if h.ndim != 2 or min(h.shape) < min_side:
        raise ParamsError(
            f"heights must be a 2-D grid of at least {min_side}x{min_side} cells, got shape {h.shape}"
        )
    if not (np.issubdtype(h.dtype, np.floating) or np.issubdtype(h.dtype, np.integer)):
        raise ParamsError(f"heights must be numeric, got dtype {h.dtype}")
    return h.astype(np.float32, copy=False)
