"""One cell size for every example: resampling to square cells in metres.

Examples come with cells of every shape: SRTM tiles in degrees (at 44 N a
3" cell is 93 m north-south but 66 m east-west), UTM grids at 10 or 30 m,
heightmaps with a size from their sidecar.  Synthesis compares patches
pixel for pixel, so :func:`to_square_cells` resamples each example once to
square cells of one size on the ground, as ``gdalwarp -tr`` would:

* geographic grids are warped (GDAL, through rasterio) into a local
  Transverse Mercator centred on the grid, on the grid's own datum, where a
  metre is a metre in both directions;
* projected grids are warped in their own CRS;
* grids with a cell size but no CRS are resampled with separable sparse
  matrices (scipy), the same filters without a projection.

Filters: **average** (area-weighted) when the new cell is at least as large
as the old one on both axes -- each new cell is the mean of the ground it
covers, which is what a coarser DEM measures and does not alias;
**bilinear** otherwise -- continuous, no overshoot next to cliffs or voids
(cubic rings), exact on planes so slopes are kept.  GDAL widens the
bilinear kernel along an axis that shrinks, so a mixed case (SRTM 1" at
mid-latitudes: taller cells get shorter, narrower ones wider) is not
aliased either.

Nodata stays NaN; a warped grid has NaN corners outside the source
footprint, which :meth:`HeightField.crop_valid` removes.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from rasterio.crs import CRS
from rasterio.transform import Affine
from rasterio.warp import Resampling, reproject, transform_bounds
from rasterio.warp import transform as transform_points
from scipy import sparse

from ..errors import ParamsError
from ..heightfield import GeoReference, HeightField
from ._common import looks_geographic
from .gdal import field_crs, georef_transform

__all__ = ["already_square", "ground_cell_size", "local_projection", "output_georeference", "resample_nodes",
           "to_square_cells"]


def ground_cell_size(field: HeightField) -> float | None:
    """The smaller side ``min(dy, dx)`` of the field's ground cell in metres.

    The finest detail the field resolves; ``None`` when the cell size is
    unknown.  The engine picks the output cell size from these.
    """
    return None if field.cell_size is None else min(field.cell_size)


def local_projection(geographic: CRS, lon: float, lat: float) -> CRS:
    """A Transverse Mercator in metres centred on ``(lon, lat)``, scale 1.

    On the datum of ``geographic`` (WGS 84 when its WKT has no plain
    geographic CRS to build on, e.g. a compound CRS).  Within a few hundred
    kilometres of the centre its scale error stays under 0.1 %.
    """
    base = geographic.to_wkt()
    if not base.startswith("GEOGCS["):
        base = CRS.from_epsg(4326).to_wkt()
    return CRS.from_wkt(
        f'PROJCS["Local Transverse Mercator {lat:.6f} {lon:.6f}",{base},'
        'PROJECTION["Transverse_Mercator"],'
        f'PARAMETER["latitude_of_origin",{lat!r}],PARAMETER["central_meridian",{lon!r}],'
        'PARAMETER["scale_factor",1],PARAMETER["false_easting",0],PARAMETER["false_northing",0],'
        'UNIT["metre",1],AXIS["Easting",EAST],AXIS["Northing",NORTH]]'
    )


def output_georeference(fields, shape: tuple[int, int], cell_size: float) -> GeoReference:
    """Where a synthesized grid of ``cell_size`` metres is put on the map.

    A local Transverse Mercator (:func:`local_projection`) centred on the
    centre of the first georeferenced field in ``fields`` (the style's
    source), with the grid centred on it, so GIS tools show the output at
    true size near where its style came from; centred on 0 N 0 E when no
    field is georeferenced.

    Parameters
    ----------
    fields : iterable of HeightField (other items are skipped)
    shape : (rows, cols)
        Of the output.
    cell_size : float
        Metres.

    Returns
    -------
    GeoReference
        No EPSG code; the projection in ``crs_wkt``.
    """
    wgs84 = CRS.from_epsg(4326)
    base, lon, lat = wgs84, 0.0, 0.0
    for field in fields:
        crs = field_crs(getattr(field, "georef", None))
        if crs is None:
            continue
        geo, (rows, cols) = field.georef, field.shape
        x, y = geo.x_origin + cols * geo.x_step / 2, geo.y_origin - rows * geo.y_step / 2
        if crs.is_geographic:
            base, lon, lat = crs, x, y
        else:
            (lon,), (lat,) = transform_points(crs, wgs84, [x], [y])
        break
    rows, cols = shape
    size = float(cell_size)
    return GeoReference(-cols * size / 2, rows * size / 2, size, size, None,
                        local_projection(base, lon, lat).to_wkt())


def to_square_cells(field: HeightField, cell_size: float) -> HeightField:
    """``field`` resampled once to square cells of ``cell_size`` metres.

    Parameters
    ----------
    field : HeightField
    cell_size : float
        Side of the new cells on the ground, in metres.

    Returns
    -------
    HeightField
        ``cell_size == (cell_size, cell_size)``, heights in metres with NaN
        nodata (warped grids have NaN corners: see the module notes).
        ``georef`` follows: a geographic field gets a local Transverse
        Mercator (:func:`local_projection`; no EPSG code, the WKT in
        ``crs_wkt``), a projected one keeps its CRS.  ``metadata`` gains
        ``resampled_from`` (the old ``(dy, dx)``) and ``resampling``.  A
        field that already has square cells of that size (projected or
        without CRS) is returned as is.

        A field **without cell size** (a PNG without sidecar) is returned
        with its heights untouched, ``cell_size`` set to ``(cell_size,
        cell_size)`` and ``metadata["cell_size_assumed"] = True``: nothing
        tells its scale, so its cells are taken to be the output's, and the
        flag lets the caller say so.  Geographic-looking coordinates without
        a CRS are taken as WGS 84 (``metadata["crs_assumed"] = "EPSG:4326"``).

    Raises
    ------
    ParamsError
        ``cell_size`` not a positive finite number.
    """
    try:
        size = float(cell_size)
    except (TypeError, ValueError) as exc:
        raise ParamsError(f"cell_size must be a positive number of metres, got {cell_size!r}") from exc
    if not (size > 0 and math.isfinite(size)):
        raise ParamsError(f"cell_size must be a positive number of metres, got {cell_size!r}")
    if field.cell_size is None:
        return replace(field, cell_size=(size, size), metadata={**field.metadata, "cell_size_assumed": True})

    if already_square(field, size):
        return field
    dy, dx = field.cell_size
    method = Resampling.average if size >= max(dy, dx) * (1 - 1e-9) else Resampling.bilinear
    metadata = {**field.metadata, "resampled_from": (dy, dx), "resampling": method.name}
    crs, assumed = _source_crs(field)
    if assumed:
        metadata["crs_assumed"] = "EPSG:4326"
    if crs is None:
        return _zoom(field, size, method, metadata)
    return _warp(field, crs, size, method, metadata)


def already_square(field: HeightField, cell_size: float) -> bool:
    """Whether ``field`` already has square cells of ``cell_size`` metres on
    a grid that needs no projection (:func:`to_square_cells` returns it as
    is); cheap, nothing is resampled."""
    if field.cell_size is None:
        return False
    dy, dx = field.cell_size
    if not (math.isclose(dy, cell_size, rel_tol=1e-9) and math.isclose(dx, cell_size, rel_tol=1e-9)):
        return False
    crs, _ = _source_crs(field)
    return crs is None or not crs.is_geographic


def _source_crs(field: HeightField) -> tuple[CRS | None, bool]:
    """The field's CRS, and whether it was assumed: geographic-looking
    coordinates without a CRS are taken as WGS 84."""
    geo = field.georef
    crs = field_crs(geo)
    if geo is not None and crs is None and looks_geographic(geo.x_origin, geo.y_origin - field.shape[0] * geo.y_step,
                                                             geo.y_step):
        return CRS.from_epsg(4326), True
    return crs, False


def _warp(field: HeightField, crs: CRS, size: float, method: Resampling, metadata: dict) -> HeightField:
    """Warp with GDAL: geographic grids into a local TM, projected ones in their CRS."""
    geo = field.georef
    rows, cols = field.shape
    src_transform = georef_transform(geo)
    left, top = geo.x_origin, geo.y_origin
    right, bottom = left + cols * geo.x_step, top - rows * geo.y_step
    if crs.is_geographic:
        dst_crs = local_projection(crs, (left + right) / 2, (top + bottom) / 2)
        # The bounding box of the footprint (edges densified: they curve).
        x0, y0, x1, y1 = transform_bounds(crs, dst_crs, left, bottom, right, top, densify_pts=21)
        width, height = max(2, math.ceil((x1 - x0) / size)), max(2, math.ceil((y1 - y0) / size))
        transform = Affine(size, 0.0, x0, 0.0, -size, y1)
        epsg = None
    else:
        dst_crs = crs
        step = size / (field.cell_size[0] / geo.y_step)  # metres to CRS units
        # Whole new cells inside the old extent: no half-empty edge cells.
        width = max(2, math.floor((right - left) / step + 1e-9))
        height = max(2, math.floor((top - bottom) / step + 1e-9))
        transform = Affine(step, 0.0, left, 0.0, -step, top)
        epsg = geo.epsg
    out = np.full((height, width), np.nan, dtype=np.float32)
    reproject(
        source=np.ascontiguousarray(field.heights, dtype=np.float32), destination=out,
        src_transform=src_transform, src_crs=crs, src_nodata=np.nan,
        dst_transform=transform, dst_crs=dst_crs, dst_nodata=np.nan, resampling=method,
    )
    georef = GeoReference(transform.c, transform.f, transform.a, -transform.e, epsg, dst_crs.to_wkt())
    return replace(field, heights=out, cell_size=(size, size), georef=georef, metadata=metadata)


def _axis_weights(n_in: int, step_in: float, step_out: float, method: Resampling) -> sparse.csr_matrix:
    """Sparse ``(n_out, n_in)`` resampling weights along one axis (rows sum to 1).

    ``average``: the overlap of each new cell with each old one (area
    weights).  ``bilinear``: linear interpolation at the new cell centres,
    clamped at the edges.
    """
    n_out = max(2, math.floor(n_in * step_in / step_out + 1e-9))
    if method == Resampling.average:
        edges_out = np.arange(n_out + 1) * step_out
        rows, cols, vals = [], [], []
        for j in range(n_out):
            first = int(edges_out[j] // step_in)
            last = min(n_in, math.ceil(edges_out[j + 1] / step_in - 1e-9))
            for i in range(first, last):
                overlap = min(edges_out[j + 1], (i + 1) * step_in) - max(edges_out[j], i * step_in)
                if overlap > 0:
                    rows.append(j), cols.append(i), vals.append(overlap)
        weights = sparse.csr_matrix((vals, (rows, cols)), shape=(n_out, n_in))
    else:
        u = np.clip((np.arange(n_out) + 0.5) * step_out / step_in - 0.5, 0, n_in - 1)
        i0 = np.minimum(np.floor(u).astype(np.int64), n_in - 2)
        t = u - i0
        j = np.arange(n_out)
        weights = sparse.csr_matrix(
            (np.concatenate([1 - t, t]), (np.concatenate([j, j]), np.concatenate([i0, i0 + 1]))),
            shape=(n_out, n_in),
        )
    totals = np.asarray(weights.sum(axis=1)).ravel()
    return sparse.diags(1 / totals) @ weights


def _zoom(field: HeightField, size: float, method: Resampling, metadata: dict) -> HeightField:
    """Separable resampling of a grid without CRS; a new cell more than half
    void is NaN, others are the weighted mean of their valid cells."""
    dy, dx = field.cell_size
    rows, cols = field.shape
    wy = _axis_weights(rows, dy, size, method)
    wx = _axis_weights(cols, dx, size, method)
    valid = ~field.nodata
    filled = np.where(valid, field.heights, 0).astype(np.float64)
    total = (wx @ (wy @ filled).T).T
    weight = (wx @ (wy @ valid.astype(np.float64)).T).T
    with np.errstate(invalid="ignore", divide="ignore"):
        heights = np.where(weight > 0.5, total / weight, np.nan).astype(np.float32)
    geo = field.georef
    if geo is not None:
        geo = replace(geo, x_step=geo.x_step * size / dx, y_step=geo.y_step * size / dy)
    return replace(field, heights=heights, cell_size=(size, size), georef=geo, metadata=metadata)


# -- node grids (engine heightmaps) -------------------------------------------


def _node_weights(n_in: int, n_out: int) -> sparse.csr_matrix:
    """Sparse ``(n_out, n_in)`` weights from ``n_in`` samples to ``n_out`` nodes
    spanning the same first-to-last-sample extent (rows sum to 1).

    Shrinking: each node is the area-weighted mean of the old cells (each
    covering ``[i - 1/2, i + 1/2]``) under a box one new spacing wide
    centred on it (anti-aliased); near the edges the box narrows
    symmetrically, so a slope is not biased there.  Growing: Keys' cubic
    convolution (a = -1/2, Catmull-Rom), the grid extended linearly past
    its edges.  Both are exact on planes.
    """
    scale = (n_in - 1) / (n_out - 1)
    centres = np.arange(n_out) * scale
    rows, cols, vals = [], [], []
    if n_out < n_in:
        for j, t in enumerate(centres):
            half = min(scale / 2, t + 0.5, n_in - 0.5 - t)
            left, right = t - half, t + half
            first, last = int(math.floor(left + 0.5)), int(math.ceil(right - 0.5))
            for i in range(max(first, 0), min(last, n_in - 1) + 1):
                overlap = min(right, i + 0.5) - max(left, i - 0.5)
                if overlap > 0:
                    rows.append(j), cols.append(i), vals.append(overlap)
        weights = sparse.csr_matrix((vals, (rows, cols)), shape=(n_out, n_in))
    else:
        base = np.floor(centres).astype(np.int64)
        frac = centres - base
        for k in range(-1, 3):
            d = np.abs(frac - k)
            w = np.where(d <= 1, 1.5 * d**3 - 2.5 * d**2 + 1, np.where(d < 2, -0.5 * d**3 + 2.5 * d**2 - 4 * d + 2, 0))
            index = base + k
            # Past an edge, the linear extension v[-1] = 2 v[0] - v[1]
            # (and likewise at the end) keeps planes exact.
            for outside, edge, inner in ((index < 0, 0, 1), (index > n_in - 1, n_in - 1, n_in - 2)):
                index = np.where(outside, edge, index)
                rows.append(np.arange(n_out)[outside]), cols.append(np.full(outside.sum(), inner))
                vals.append(-w[outside])
                w = np.where(outside, 2 * w, w)
            rows.append(np.arange(n_out)), cols.append(index), vals.append(w)
        # Duplicate (row, col) pairs are summed by the constructor.
        weights = sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                    shape=(n_out, n_in))
    totals = np.asarray(weights.sum(axis=1)).ravel()
    return sparse.diags(1 / totals) @ weights


def resample_nodes(field: HeightField, shape: tuple[int, int]) -> HeightField:
    """``field`` resampled to a grid of ``shape`` covering the same ground.

    The grids are taken as nodes (an engine's vertices): the first and last
    samples of each axis stay where they are, so a grid of ``n`` samples
    spaced ``d`` metres becomes ``m`` samples spaced ``d (n - 1) / (m - 1)``
    metres, and the heights stay in metres.  Each axis is filtered for its
    own change: area average when it shrinks (no aliasing), cubic
    convolution when it grows (smooth, sharper than bilinear; it may
    overshoot next to cliffs by a few percent of the step).

    Parameters
    ----------
    field : HeightField
        Heights in metres, shape (rows, cols); NaN nodata.
    shape : (rows, cols)
        The new grid, each at least 2.

    Returns
    -------
    HeightField
        float32 heights of ``shape``; ``cell_size`` scaled as above (kept
        ``None`` when unknown); ``georef`` with the first cell's centre
        in place.  A new cell is nodata where the old cell nearest to it is.
        The field itself when ``shape`` is its own.

    Raises
    ------
    ParamsError
        A side below 2.
    """
    new_rows, new_cols = (int(v) for v in shape)
    if min(new_rows, new_cols) < 2:
        raise ParamsError(f"resampled size must be at least 2 x 2, got {new_rows} x {new_cols}")
    rows, cols = field.shape
    if (new_rows, new_cols) == (rows, cols):
        return field
    nodata = field.nodata
    heights = field.heights
    if nodata.any():
        # Filters need every sample: nodata takes its nearest valid height,
        # and comes back where the nearest old cell was nodata.
        heights = field.fill_nodata().heights
    out = NodeGrid(field.shape, shape).window(lambda r0, r1, c0, c1: heights[r0:r1, c0:c1], 0, new_rows, 0, new_cols)
    if nodata.any():
        near_r = np.rint(np.arange(new_rows) * (rows - 1) / (new_rows - 1)).astype(np.int64)
        near_c = np.rint(np.arange(new_cols) * (cols - 1) / (new_cols - 1)).astype(np.int64)
        out[nodata[np.ix_(near_r, near_c)]] = np.nan
    cell_size, geo = node_grid_placement(field, shape)
    return replace(field, heights=out, cell_size=cell_size, georef=geo,
                   metadata={**field.metadata, "resampled_from_shape": (rows, cols)})


def node_grid_placement(field, shape: tuple[int, int]) -> tuple:
    """Cell size and georeference of ``field`` resampled to ``shape`` by
    :func:`resample_nodes`: the first cell's centre stays put.

    Parameters
    ----------
    field : HeightField or RasterWindows
        Anything with ``shape``, ``cell_size`` and ``georef``.
    shape : (rows, cols)

    Returns
    -------
    cell_size : (dy, dx) metres or None
    georef : GeoReference or None
    """
    (rows, cols), (new_rows, new_cols) = field.shape, shape
    sy, sx = (rows - 1) / (new_rows - 1), (cols - 1) / (new_cols - 1)
    cell_size = None if field.cell_size is None else (field.cell_size[0] * sy, field.cell_size[1] * sx)
    geo = field.georef
    if geo is not None:
        # The first cell's centre stays put; the origin is its corner.
        geo = replace(geo, x_origin=geo.x_origin + geo.x_step * (1 - sx) / 2,
                      y_origin=geo.y_origin - geo.y_step * (1 - sy) / 2, x_step=geo.x_step * sx,
                      y_step=geo.y_step * sy)
    return cell_size, geo


class NodeGrid:
    """:func:`resample_nodes`' filters from a grid of ``source`` shape to
    one of ``shape``, applied window by window.

    A window of the new grid reads only the old cells its filters reach, and
    holds the same values as that window of the whole resampled grid (each
    new sample sums the same weights in the same order), so a grid larger
    than memory is resampled in pieces.

    Parameters
    ----------
    source, shape : (rows, cols)
        Old and new grid shapes, sides at least 2.
    """

    def __init__(self, source: tuple[int, int], shape: tuple[int, int]):
        self.source, self.shape = tuple(source), tuple(shape)
        self._wy = _node_weights(self.source[0], self.shape[0])
        self._wx = _node_weights(self.source[1], self.shape[1])

    def window(self, read, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """Rows ``r0:r1`` and columns ``c0:c1`` of the resampled grid.

        Parameters
        ----------
        read : callable
            ``read(i0, i1, j0, j1)`` gives the old grid's heights there,
            shape (i1 - i0, j1 - j0), without NaN.

        Returns
        -------
        ndarray of float32, shape (r1 - r0, c1 - c0)
        """
        if self.shape == self.source:
            return np.array(read(r0, r1, c0, c1), dtype=np.float32)
        wy, i0, i1 = _rows(self._wy, r0, r1)
        wx, j0, j1 = _rows(self._wx, c0, c1)
        block = np.asarray(read(i0, i1, j0, j1)).astype(np.float64)
        return (wx @ (wy @ block).T).T.astype(np.float32)


def _rows(weights: sparse.csr_matrix, r0: int, r1: int) -> tuple[sparse.csr_matrix, int, int]:
    """Rows ``r0:r1`` of ``weights`` on the old samples they read, and where
    those start and end.  The rows' entries keep their order, so products
    sum them as the whole matrix does."""
    a, b = weights.indptr[r0], weights.indptr[r1]
    i0, i1 = int(weights.indices[a:b].min()), int(weights.indices[a:b].max()) + 1
    part = sparse.csr_matrix((weights.data[a:b], weights.indices[a:b] - i0, weights.indptr[r0:r1 + 1] - a),
                             shape=(r1 - r0, i1 - i0))
    return part, i0, i1
