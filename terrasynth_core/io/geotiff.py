"""GeoTIFF elevation rasters, read and written with :mod:`tifffile`.

Only the GeoTIFF tags a north-up DEM needs are handled: ``ModelPixelScale``
and ``ModelTiepoint`` (or an unrotated ``ModelTransformation``), the EPSG code
and raster type from the ``GeoKeyDirectory``, and GDAL's nodata tag.
Multi-band images are refused rather than silently reduced to one band: a
DEM has one band, and an RGB TIFF is more likely a picture than a heightmap.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

import numpy as np
import tifffile

from ..errors import DEMFormatError
from ..heightfield import GeoReference, HeightField
from ._common import geographic_cell, is_geographic_epsg, looks_geographic, read_field

# TIFF tags
MODEL_PIXEL_SCALE = 33550
MODEL_TIEPOINT = 33922
MODEL_TRANSFORMATION = 34264
GEO_KEY_DIRECTORY = 34735
GDAL_NODATA = 42113

# GeoKeys and their values
GT_MODEL_TYPE = 1024
MODEL_PROJECTED, MODEL_GEOGRAPHIC = 1, 2
GT_RASTER_TYPE = 1025
RASTER_PIXEL_IS_AREA, RASTER_PIXEL_IS_POINT = 1, 2
GEOGRAPHIC_TYPE = 2048
GEOG_ANGULAR_UNITS = 2054
ANGULAR_DEGREE = 9102
PROJECTED_CS_TYPE = 3072
PROJ_LINEAR_UNITS = 3076
LINEAR_METRE = 9001
USER_DEFINED = 32767

#: Metres per linear unit of ProjLinearUnitsGeoKey (metre, foot, US survey foot).
LINEAR_UNITS_M = {LINEAR_METRE: 1.0, 9002: 0.3048, 9003: 1200.0 / 3937.0}


class _SkipNodataTagWarning(logging.Filter):
    """Drop tifffile's warning that it cannot cast the GDAL_NODATA tag.

    tifffile tries to convert the tag to the image dtype and logs a warning
    when it fails (bigtujunga.tif: "32767 is not castable to int16"); the
    reader parses the tag itself, so the message is noise.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        return "GDAL_NODATA" not in record.getMessage()


@contextmanager
def _quiet_nodata_tag_warning() -> Iterator[None]:
    logger = logging.getLogger("tifffile")
    quiet = _SkipNodataTagWarning()
    logger.addFilter(quiet)
    try:
        yield
    finally:
        logger.removeFilter(quiet)


def parse_geokeys(directory: tuple[int, ...] | None) -> dict[int, int]:
    """Short-valued keys of a GeoKeyDirectoryTag.

    Parameters
    ----------
    directory : tuple of int or None
        The tag value: a 4-short header then 4 shorts per key
        (id, location, count, value).

    Returns
    -------
    dict
        Key id to value, for keys stored inline (location 0); keys whose
        value lives in another tag (names, doubles) are not needed here.
    """
    if directory is None:
        return {}
    entries = np.asarray(directory[4:], dtype=np.int64).reshape(-1, 4)
    return {int(key): int(value) for key, location, _, value in entries if location == 0}


def read_geotiff(path: Path) -> HeightField:
    """Read a single-band GeoTIFF DEM.

    Parameters
    ----------
    path : Path
        A TIFF whose first image is one band of int8/16/32, uint8/16/32 or
        float32/64 heights in metres.

    Returns
    -------
    HeightField
        Heights with the ``GDAL_NODATA`` value as NaN.  ``georef`` comes from
        the pixel scale and tiepoint (PixelIsPoint tiepoints are moved half a
        cell to the cell corner) with the EPSG code of the projected or
        geographic CRS.  ``cell_size`` is the pixel scale in metres for a
        projected CRS and the ground size at the centre latitude for a
        geographic one; a pixel scale without tiepoint still gives a cell
        size.

    Raises
    ------
    DEMFormatError
        Multi-band or non-2-D images, non-numeric samples, rotated grids.
    """
    with _quiet_nodata_tag_warning(), tifffile.TiffFile(path) as tif:
        page = tif.pages.first
        if page.samplesperpixel != 1:
            raise DEMFormatError(
                f"{path}: image has {page.samplesperpixel} bands per pixel; "
                "expected a single-band elevation raster"
            )
        tags = {tag.code: tag.value for tag in page.tags.values()}
        data = page.asarray()
    if data.ndim != 2:
        raise DEMFormatError(f"{path}: image has shape {data.shape}; expected a 2-D elevation raster")
    if data.dtype.kind not in "iuf":
        raise DEMFormatError(f"{path}: samples of type {data.dtype}; expected integer or float heights")

    heights = data.astype(np.float32)
    nodata_value = _parse_nodata(tags.get(GDAL_NODATA))
    if nodata_value is not None:
        heights[_nodata_mask(data, nodata_value)] = np.nan

    keys = parse_geokeys(tags.get(GEO_KEY_DIRECTORY))
    georef, cell_size = _placement(path, tags, keys, data.shape)
    metadata = {"dtype": str(data.dtype)}
    if nodata_value is not None:
        metadata["nodata_value"] = nodata_value
    return read_field(path, "geotiff", heights, cell_size=cell_size, georef=georef, metadata=metadata)


def _parse_nodata(tag_value) -> float | None:
    if tag_value is None:
        return None
    text = tag_value if isinstance(tag_value, str) else str(tag_value)
    try:
        return float(text.strip().strip("\x00"))
    except ValueError:
        return None


def _nodata_mask(data: np.ndarray, nodata_value: float) -> np.ndarray:
    """Cells equal to the nodata value, compared in the data's own type."""
    if math.isnan(nodata_value):
        return np.isnan(data) if data.dtype.kind == "f" else np.zeros(data.shape, bool)
    if data.dtype.kind == "f":
        return data == data.dtype.type(nodata_value)
    info = np.iinfo(data.dtype)
    if nodata_value != int(nodata_value) or not info.min <= nodata_value <= info.max:
        return np.zeros(data.shape, bool)
    return data == int(nodata_value)


def _placement(
    path: Path, tags: dict, keys: dict[int, int], shape: tuple[int, int]
) -> tuple[GeoReference | None, tuple[float, float] | None]:
    """Georeference and cell size from the GeoTIFF tags."""
    scale = tags.get(MODEL_PIXEL_SCALE)
    tiepoint = tags.get(MODEL_TIEPOINT)
    matrix = tags.get(MODEL_TRANSFORMATION)
    if matrix is not None:
        a, b, _, c, d, e, _, f = matrix[:8]
        if b != 0 or d != 0:
            raise DEMFormatError(f"{path}: rotated or sheared grid; expected a north-up raster")
        x_step, y_step, x_origin, y_origin = a, -e, c, f
    elif scale is not None:
        x_step, y_step = scale[0], scale[1]
        if tiepoint is not None:
            i, j, _, x, y, _ = tiepoint[:6]
            x_origin, y_origin = x - i * x_step, y + j * y_step
        else:
            x_origin = y_origin = None
    else:
        return None, None
    if not (x_step > 0 and y_step > 0):
        raise DEMFormatError(
            f"{path}: pixel scale ({x_step}, {y_step}); expected positive steps of a north-up raster"
        )
    if x_origin is not None and keys.get(GT_RASTER_TYPE) == RASTER_PIXEL_IS_POINT:
        # The tiepoint names the centre of the cell; GeoReference wants its corner.
        x_origin, y_origin = x_origin - x_step / 2, y_origin + y_step / 2

    epsg = keys.get(PROJECTED_CS_TYPE) or keys.get(GEOGRAPHIC_TYPE)
    if epsg == USER_DEFINED:
        epsg = None
    model = keys.get(GT_MODEL_TYPE)
    if model is not None:
        geographic = model == MODEL_GEOGRAPHIC
    elif epsg is not None:
        geographic = is_geographic_epsg(epsg)
    else:
        geographic = x_origin is not None and looks_geographic(x_origin, y_origin, y_step)

    georef = None
    if x_origin is not None:
        georef = GeoReference(x_origin, y_origin, x_step, y_step, epsg)
    if geographic:
        if y_origin is None:
            return None, None
        lat = y_origin - shape[0] * y_step / 2
        return georef, geographic_cell(lat, y_step, x_step)
    unit = LINEAR_UNITS_M.get(keys.get(PROJ_LINEAR_UNITS, LINEAR_METRE), 1.0)
    return georef, (y_step * unit, x_step * unit)


def write_geotiff(field: HeightField, fh: BinaryIO) -> None:
    """Write ``field`` as a float32 GeoTIFF.

    Nodata cells are NaN and the ``GDAL_NODATA`` tag says ``"nan"``.  With a
    georeference the file carries ModelPixelScale, ModelTiepoint (upper-left
    corner, PixelIsArea) and a GeoKeyDirectory with the EPSG code (geographic
    for codes 4000-4999, projected in metres otherwise); without one, only a
    ModelPixelScale from ``cell_size`` (metres) when that is known.

    Parameters
    ----------
    field : HeightField
    fh : binary file
        Open for writing.
    """
    tags = [(GDAL_NODATA, "s", 0, "nan", True)]
    geo = field.georef
    if geo is not None:
        tags.append((MODEL_PIXEL_SCALE, "d", 3, (geo.x_step, geo.y_step, 0.0), True))
        tags.append((MODEL_TIEPOINT, "d", 6, (0.0, 0.0, 0.0, geo.x_origin, geo.y_origin, 0.0), True))
        keys = [(GT_RASTER_TYPE, RASTER_PIXEL_IS_AREA)]
        # GeoKey values are 16-bit; larger codes (not EPSG) cannot be stored.
        if geo.epsg is not None and 0 < geo.epsg < USER_DEFINED:
            if is_geographic_epsg(geo.epsg):
                keys += [
                    (GT_MODEL_TYPE, MODEL_GEOGRAPHIC),
                    (GEOGRAPHIC_TYPE, geo.epsg),
                    (GEOG_ANGULAR_UNITS, ANGULAR_DEGREE),
                ]
            else:
                keys += [
                    (GT_MODEL_TYPE, MODEL_PROJECTED),
                    (PROJECTED_CS_TYPE, geo.epsg),
                    (PROJ_LINEAR_UNITS, LINEAR_METRE),
                ]
        directory = [1, 1, 0, len(keys)]
        for key, value in sorted(keys):
            directory += [key, 0, 1, value]
        tags.append((GEO_KEY_DIRECTORY, "H", len(directory), tuple(directory), True))
    elif field.cell_size is not None:
        dy, dx = field.cell_size
        tags.append((MODEL_PIXEL_SCALE, "d", 3, (dx, dy, 0.0), True))
    # Deflate level 1: five times faster than the default level for files
    # about a quarter larger, still less than half the uncompressed size.
    tifffile.imwrite(
        fh,
        field.heights,
        photometric="minisblack",
        compression="zlib",
        compressionargs={"level": 1},
        metadata=None,
        extratags=tags,
    )
