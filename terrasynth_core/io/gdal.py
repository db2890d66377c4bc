"""Rasters read and written through GDAL (with :mod:`rasterio`, whose wheels
carry GDAL).

Reading covers every raster format the GDAL in the wheel reads: GeoTIFF
with any compression and predictor (LZW, DEFLATE, ZSTD, LERC...), COG and
BigTIFF, ERDAS Imagine ``.img``, GDAL ``.vrt`` mosaics, NetCDF, DTED, ENVI
and more.  Writing is GeoTIFF, plain or Cloud-Optimized.  The package's
``__init__`` decides which extensions come here.
"""

from __future__ import annotations

import re
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import rasterio
from rasterio.crs import CRS
from rasterio.errors import CRSError, NotGeoreferencedWarning, RasterioIOError
from rasterio.io import MemoryFile
from rasterio.shutil import copy as gdal_copy
from rasterio.transform import Affine
from rasterio.windows import Window

from ..errors import DEMFormatError
from ..heightfield import GeoReference, HeightField
from ._common import fill_value_nodata, geographic_cell, looks_geographic, read_field, with_crs_wkt, wrap_errors

#: Metres per height unit, by normalised unit name (see :func:`metres_per_unit`).
_UNITS_M = {
    **dict.fromkeys(["", "m", "metre", "meter", "metres", "meters"], 1.0),
    **dict.fromkeys(["ft", "foot", "feet", "international foot", "foot international", "ft intl"], 0.3048),
    **dict.fromkeys(["us survey foot", "us survey feet", "us survey ft", "ftus", "us ft", "us foot", "foot us",
                     "survey foot"], 1200.0 / 3937.0),
    **dict.fromkeys(["dm", "decimetre", "decimeter", "decimetres", "decimeters"], 0.1),
    **dict.fromkeys(["cm", "centimetre", "centimeter", "centimetres", "centimeters"], 0.01),
    **dict.fromkeys(["mm", "millimetre", "millimeter", "millimetres", "millimeters"], 0.001),
}

#: The unit of a WKT1 vertical CRS: ``VERT_CS[... UNIT["foot",0.3048 ...``.
_VERT_UNIT = re.compile(r'VERT_CS\[.*?UNIT\["([^"]*)",\s*([0-9.eE+-]+)', re.DOTALL)

#: GDAL metadata item marking a GeoTIFF we wrote for a field without georeference:
#: its transform only carries the cell size.
NO_GEOREF_TAG = "TERRASYNTH_NO_GEOREFERENCE"


def metres_per_unit(unit: str) -> float | None:
    """Metres in one height ``unit`` as GDAL reports it, ``None`` if unknown.

    An empty unit is taken as metres (GDAL reports none for most DEMs).
    """
    key = re.sub(r"[\s_\-.()]+", " ", unit.lower()).strip()
    return _UNITS_M.get(key)


def read_gdal(path: Path, *, band: int | None = None, fmt: str = "gdal") -> HeightField:
    """Read one band of any raster GDAL reads as a height field.

    Parameters
    ----------
    path : Path
    band : int, optional
        1-based band to read, as in GDAL.  Needed when the file has several
        bands: a DEM has one, and an RGB image is more likely a picture.
    fmt : str, default ``"gdal"``
        Short format name given to the field (see ``io.format_name``).

    Returns
    -------
    HeightField
        North-up heights in metres: GDAL's mask (nodata value, NaN or
        infinite nodata, per-dataset masks) as NaN, the band's scale and
        offset applied, heights converted to metres when the band's unit
        (else the vertical CRS's) is feet, US survey feet, decimetres,
        centimetres or millimetres.  A unit not known here is kept as is and
        named in ``metadata["height_unit"]`` with
        ``metadata["height_unit_metres"] = None``.  South-up grids are
        flipped.  ``georef`` has the EPSG code when the CRS has one and its
        WKT always; ``cell_size`` is the resolution times the CRS's linear
        unit for a projected CRS, the ground size at the centre latitude for
        a geographic one (or for degrees without a CRS), the resolution
        taken as metres otherwise.

    Raises
    ------
    DEMFormatError
        Several bands without ``band``, a band out of range, complex or
        non-numeric samples, a rotated or sheared grid, or anything GDAL
        cannot read.
    """
    raster = RasterWindows(path, band=band)
    heights, fill = raster.read_with_fill()
    metadata = dict(raster.metadata)
    if fill is not None:
        # The file does not say what nodata is: a conventional fill value is.
        metadata["nodata_value"] = fill
    return read_field(path, fmt, heights, cell_size=raster.cell_size, georef=raster.georef, metadata=metadata)


class RasterWindows:
    """One band of a raster GDAL reads, read whole or window by window.

    Every read converts as :func:`read_gdal` does (mask to NaN, scale and
    offset, height unit to metres, south-up flipped), so a window is the
    same float32 heights as that part of the whole field.  For grids larger
    than memory (a world-size terrain's GeoTIFF): a window reads only the
    file's blocks under it.

    Parameters
    ----------
    path : Path
    band : int, optional
        As in :func:`read_gdal`.

    Attributes
    ----------
    shape : (rows, cols)
        Of the north-up grid.
    cell_size : (dy, dx) metres or None
    georef : GeoReference or None
    metadata : dict
        As :func:`read_gdal` gives it, without a conventional fill value's
        ``nodata_value`` (known only once every cell is read).

    Raises
    ------
    DEMFormatError
        As :func:`read_gdal`.
    """

    def __init__(self, path: Path, *, band: int | None = None):
        self.path = Path(path)
        with _opened(self.path) as ds:
            self._describe(ds, band)

    def _describe(self, ds, band: int | None) -> None:
        path = self.path
        if ds.count == 0 and ds.subdatasets:
            names = ", ".join(sub.rsplit(":", 1)[-1] for sub in ds.subdatasets)
            raise DEMFormatError(
                f"{path}: holds {len(ds.subdatasets)} grids ({names}), not one; extract the elevation "
                f"grid into a GeoTIFF first (gdal_translate {ds.subdatasets[0]} dem.tif)"
            )
        index = _band_index(path, ds.count, band)
        dtype = np.dtype(ds.dtypes[index - 1])
        if dtype.kind not in "iuf":
            raise DEMFormatError(f"{path}: band {index} holds {dtype} samples; expected integer or float heights")
        if ds.driver in _RAW_DRIVERS:
            _check_raw_size(path, ds, dtype)
        self._index = index
        self._scale, self._offset = ds.scales[index - 1], ds.offsets[index - 1]
        self._declared_nodata = ds.nodata is not None
        metadata = {"driver": ds.driver, "dtype": str(dtype), "band": index, "bands": ds.count}
        if ds.nodata is not None:
            metadata["nodata_value"] = float(ds.nodata)
        if self._scaled:
            metadata["scale"], metadata["offset"] = float(self._scale), float(self._offset)
        crs = ds.crs
        crs_wkt = crs.to_wkt() if crs is not None else None
        unit = ds.units[index - 1] or ""
        if not unit and crs_wkt:
            match = _VERT_UNIT.search(crs_wkt)
            if match:
                unit = match.group(1)
        self._factor = metres_per_unit(unit)
        if unit:
            metadata["height_unit"], metadata["height_unit_metres"] = unit, self._factor
        self.shape = (ds.height, ds.width)
        georef, self.cell_size, self._flip = _placement(path, ds.transform, crs, self.shape, ds.tags())
        self.georef = with_crs_wkt(georef)
        self.metadata = metadata

    @property
    def _scaled(self) -> bool:
        return self._scale != 1 or self._offset != 0

    def read(self, r0: int = 0, r1: int | None = None, c0: int = 0, c1: int | None = None) -> np.ndarray:
        """Heights of rows ``r0:r1`` and columns ``c0:c1`` of the north-up grid.

        Returns
        -------
        ndarray of float32, shape (r1 - r0, c1 - c0)
            Metres, NaN nodata.
        """
        return self.read_with_fill(r0, r1, c0, c1)[0]

    def read_with_fill(self, r0: int = 0, r1: int | None = None, c0: int = 0,
                       c1: int | None = None) -> tuple[np.ndarray, float | None]:
        """:meth:`read`, and the conventional fill value found in the window
        (``None`` when the file declares its nodata or none was found)."""
        rows, cols = self.shape
        r1, c1 = rows if r1 is None else r1, cols if c1 is None else c1
        if not (0 <= r0 < r1 <= rows and 0 <= c0 < c1 <= cols):
            raise ValueError(f"window rows {r0}:{r1}, cols {c0}:{c1} outside the {rows} x {cols} grid")
        # A south-up file holds the north-up rows r0:r1 reversed at the far end.
        f0, f1 = (rows - r1, rows - r0) if self._flip else (r0, r1)
        # Opened for each read: closing drops the blocks GDAL cached (up to 5 %
        # of the machine's memory), which a window read once never needs again.
        with wrap_errors(self.path, "read"), _opened(self.path) as ds:
            data = ds.read(self._index, window=Window(c0, f0, c1 - c0, f1 - f0), masked=True)
        # float64 only when scale and offset need it: a large DEM takes half the memory.
        heights = data.astype(np.float64 if self._scaled else np.float32).filled(np.nan)
        fill = None if self._declared_nodata else fill_value_nodata(np.ma.getdata(data), heights)
        if self._scaled:
            heights = heights * self._scale + self._offset
        if self._factor is not None and self._factor != 1.0:
            heights = heights * self._factor
        if self._flip:
            heights = heights[::-1]
        return heights.astype(np.float32, copy=False), fill


@contextmanager
def _opened(path: Path):
    """The dataset at ``path``, open for the block (a raster without
    georeference is fine: its georef is None)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with _open(path) as ds:
            yield ds


#: GDAL drivers of headerless binary grids beside a text header.
_RAW_DRIVERS = ("ENVI", "EHdr")


def header_candidates(path: Path) -> list[Path]:
    """Where the ``.hdr`` of an ENVI or ESRI BIL/GridFloat file may be."""
    return [path.with_suffix(".hdr"), path.with_suffix(".HDR"),
            path.with_name(path.name + ".hdr"), path.with_name(path.name + ".HDR")]


def _open(path: Path):
    """``rasterio.open(path)``, with a hint when a raw grid's header is missing or foreign."""
    try:
        return rasterio.open(path)
    except RasterioIOError as exc:
        if "not recognized" not in str(exc) or path.suffix.lower() not in (".bil", ".bsq", ".bip", ".flt"):
            raise
        headers = [h for h in header_candidates(path) if h.is_file()]
        if not headers:
            expected = header_candidates(path)
            raise DEMFormatError(
                f"{path}: header not found; expected {expected[0].name} or {expected[2].name} beside it"
            ) from exc
        raise DEMFormatError(
            f"{headers[0]}: not an ENVI header nor an ESRI one that GDAL reads (for {path.name})"
        ) from exc


def _check_raw_size(path: Path, ds, dtype: np.dtype) -> None:
    """Refuse a raw grid shorter than its header says (GDAL would pad it silently)."""
    offset = int(ds.tags(ns="ENVI").get("header_offset", 0) or 0) if ds.driver == "ENVI" else 0
    expected = offset + ds.height * ds.width * ds.count * dtype.itemsize
    size = path.stat().st_size
    if size < expected:
        raise DEMFormatError(
            f"{path}: {size} bytes; its header implies {expected} ({ds.height} lines x {ds.width} "
            f"samples x {ds.count} bands of {dtype.itemsize} bytes after {offset})"
        )


def _band_index(path: Path, count: int, band: int | None) -> int:
    """The 1-based band to read, checked against the file's ``count``."""
    if band is None:
        if count != 1:
            raise DEMFormatError(
                f"{path}: {count} bands; a DEM has one band, choose one with band=1..{count}"
            )
        return 1
    if isinstance(band, bool) or not isinstance(band, (int, np.integer)) or not 1 <= band <= count:
        raise DEMFormatError(f"{path}: band {band!r} does not exist; the file has bands 1..{count}")
    return int(band)


def _placement(path: Path, transform: Affine, crs: CRS | None, shape: tuple[int, int], tags: dict):
    """``(georef, cell_size, flip)`` from GDAL's geotransform and CRS."""
    a, b, c, d, e, f = transform[:6]
    if b != 0 or d != 0:
        raise DEMFormatError(
            f"{path}: rotated or sheared grid (geotransform {tuple(transform[:6])}); "
            "expected a north-up raster (warp it first, e.g. gdalwarp)"
        )
    if crs is None and transform.is_identity:
        return None, None, False  # no georeference at all
    if not (a > 0 and e != 0):
        raise DEMFormatError(f"{path}: cell size ({a}, {e}) in the geotransform; expected a north-up raster")
    rows = shape[0]
    flip = e > 0  # south-up: row 0 is the southern edge
    x_step, y_step = a, abs(e)
    y_origin = f + e * rows if flip else f
    if crs is None and tags.get(NO_GEOREF_TAG):
        return None, (y_step, x_step), flip

    return (*grid_placement(c, y_origin, x_step, y_step, rows, crs), flip)


def grid_placement(x_origin: float, y_origin: float, x_step: float, y_step: float, rows: int,
                   crs: CRS | None) -> tuple[GeoReference, tuple[float, float]]:
    """Georeference and ground cell size ``(dy, dx)`` of a north-up grid.

    Parameters
    ----------
    x_origin, y_origin, x_step, y_step
        As in :class:`GeoReference`, in CRS units.
    rows : int
    crs : CRS or None
        Without one, coordinates that look like degrees
        (:func:`._common.looks_geographic`) are taken as geographic, others
        as metres.
    """
    if crs is not None:
        geographic = crs.is_geographic
    else:
        geographic = looks_geographic(x_origin, y_origin - rows * y_step, y_step)
    if geographic:
        cell_size = geographic_cell(y_origin - rows * y_step / 2, y_step, x_step)
    else:
        metres = 1.0
        if crs is not None:
            try:
                metres = crs.linear_units_factor[1]
            except CRSError:
                metres = 1.0  # no linear unit GDAL knows: taken as metres
        cell_size = (y_step * metres, x_step * metres)
    epsg = crs.to_epsg() if crs is not None else None
    crs_wkt = crs.to_wkt() if crs is not None else None
    return GeoReference(x_origin, y_origin, x_step, y_step, epsg, crs_wkt), cell_size


# -- writing ------------------------------------------------------------------


def field_crs(georef: GeoReference | None) -> CRS | None:
    """The CRS of a georeference: its EPSG code, else its WKT, else ``None``."""
    if georef is None:
        return None
    if georef.epsg is not None:
        return CRS.from_epsg(georef.epsg)
    if georef.crs_wkt:
        return CRS.from_wkt(georef.crs_wkt)
    return None


def georef_transform(geo: GeoReference) -> Affine:
    """The affine map from (col, row) cell corners to map coordinates, north up."""
    return Affine(geo.x_step, 0.0, geo.x_origin, 0.0, -geo.y_step, geo.y_origin)


def _profile(field: HeightField) -> tuple[dict, dict]:
    """Creation profile (driver-independent part) and GDAL metadata tags."""
    rows, cols = field.shape
    geo = field.georef
    tags = {}
    if geo is not None:
        transform = georef_transform(geo)
    elif field.cell_size is not None:
        dy, dx = field.cell_size
        transform = Affine(dx, 0.0, 0.0, 0.0, -dy, 0.0)
        tags[NO_GEOREF_TAG] = "1"
    else:
        transform = Affine.identity()
    profile = {"width": cols, "height": rows, "count": 1, "dtype": "float32", "nodata": float("nan"),
               "crs": field_crs(geo), "transform": transform}
    return profile, tags


#: DEFLATE with the floating-point predictor: lossless and about half the size of
#: DEFLATE alone on heights.  Level 1: several times faster than the default for
#: files a little larger.
_CREATION = {"compress": "DEFLATE", "predictor": 3, "zlevel": 1}


def write_geotiff(field: HeightField, path: Path, *, cog: bool = False) -> None:
    """Write ``field`` as a float32 GeoTIFF at ``path`` (a new file).

    Parameters
    ----------
    field : HeightField
    path : Path
        Written in place; the caller makes it atomic.
    cog : bool, default False
        Write a Cloud-Optimized GeoTIFF (GDAL's COG driver: 512 x 512 tiles,
        overviews averaged down to below one tile, metadata first).

    Notes
    -----
    NaN is nodata.  The CRS is the EPSG code, else the WKT; a field with a
    cell size but no georeference gets a transform from (0, 0) with that
    cell size and the ``TERRASYNTH_NO_GEOREFERENCE`` tag, so it reads back
    without georeference.  Plain GeoTIFFs are tiled 256 x 256.
    """
    profile, tags = _profile(field)
    data = field.heights.astype(np.float32, copy=False)
    with rasterio.Env(GDAL_PAM_ENABLED="NO"), warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        if not cog:
            with rasterio.open(path, "w", driver="GTiff", tiled=True, blockxsize=256, blockysize=256,
                               **_CREATION, **profile) as ds:
                ds.write(data, 1)
                ds.update_tags(**tags)
            return
        with MemoryFile() as memory, memory.open(driver="GTiff", **profile) as source:
            source.write(data, 1)
            source.update_tags(**tags)
            gdal_copy(source, str(path), driver="COG", compress="DEFLATE", predictor="FLOATING_POINT",
                      level=1, blocksize=512, overview_resampling="AVERAGE")
