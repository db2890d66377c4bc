"""ESRI ASCII grids (``.asc``): a short ``key value`` header, then the rows
of the grid from north to south as whitespace-separated numbers; the CRS,
if any, in ``<same stem>.prj`` (read and written).

Read here rather than through GDAL, whose AAIGrid driver silently shifts
the values when a header line is indented, and pads a short grid or an
unparsable value with zeros; this reader refuses both.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import BinaryIO

import numpy as np
from rasterio.crs import CRS
from rasterio.errors import CRSError

from ..errors import DEMFormatError
from ..heightfield import HeightField
from ._common import read_field
from .gdal import grid_placement

HEADER_KEYS = (
    "ncols",
    "nrows",
    "xllcorner",
    "xllcenter",
    "yllcorner",
    "yllcenter",
    "cellsize",
    "dx",
    "dy",
    "nodata_value",
)

#: Nodata value written unless a valid height happens to equal it.
NODATA_VALUE = -9999.0

#: ``cellsize`` written for a field without a cell size (or a map placement).
DEFAULT_CELL = 1.0


def _split_header(text: str, path: Path) -> tuple[dict[str, float], str]:
    """Header entries (keys lower-case) and the text of the grid values."""
    header: dict[str, float] = {}
    pos = 0
    while pos < len(text):
        end = text.find("\n", pos)
        end = len(text) if end < 0 else end
        tokens = text[pos:end].split()
        if tokens and not tokens[0][0].isalpha():
            break
        if tokens:
            key = tokens[0].lower()
            if key not in HEADER_KEYS or len(tokens) != 2:
                raise DEMFormatError(
                    f"{path}: unexpected header line {text[pos:end].strip()!r}; "
                    f"expected 'key value' with key in {', '.join(HEADER_KEYS)}"
                )
            try:
                header[key] = float(tokens[1])
            except ValueError as exc:
                raise DEMFormatError(f"{path}: header {key} is {tokens[1]!r}; expected a number") from exc
        pos = end + 1
    return header, text[pos:]


def _lower_left(header: dict, axis: str, step: float, path: Path) -> float:
    """The lower-left corner's ``axis`` ("x" or "y") coordinate, from
    ``<axis>llcorner`` or half a cell before ``<axis>llcenter``."""
    if f"{axis}llcorner" in header:
        return header[f"{axis}llcorner"]
    if f"{axis}llcenter" in header:
        return header[f"{axis}llcenter"] - step / 2
    raise DEMFormatError(f"{path}: header has no {axis}llcorner or {axis}llcenter")


def read_esri_ascii(path: Path) -> HeightField:
    """Read an ESRI ASCII grid.

    Parameters
    ----------
    path : Path
        Header keys (any case, any spacing, CRLF or LF): ``ncols``, ``nrows``,
        ``xllcorner`` or ``xllcenter``, ``yllcorner`` or ``yllcenter``,
        ``cellsize`` or ``dx`` and ``dy``, optional ``NODATA_value``.

    Returns
    -------
    HeightField
        Heights with ``NODATA_value`` (and any ``nan``) as NaN; ``georef``
        from the lower-left corner or centre, with the CRS of the ``.prj``
        beside the file when there is one.  ``cell_size`` as for GDAL reads
        (:func:`.gdal.grid_placement`): without a ``.prj``, metres, except
        for coordinates that look geographic (|x| <= 180, |y| <= 90 and a
        step under 0.1), where it is the ground size at the centre latitude.

    Raises
    ------
    DEMFormatError
        Missing or unknown header entries, non-numeric values, or a value
        count other than ``nrows * ncols``.
    """
    header, body = _split_header(path.read_text(encoding="latin-1"), path)
    for required in ("ncols", "nrows"):
        if required not in header:
            raise DEMFormatError(f"{path}: header has no {required}")
    cols, rows = int(header["ncols"]), int(header["nrows"])
    x_step = header.get("dx", header.get("cellsize"))
    y_step = header.get("dy", header.get("cellsize"))
    if x_step is None or y_step is None:
        raise DEMFormatError(f"{path}: header has no cellsize (or dx and dy)")
    if not (x_step > 0 and y_step > 0):
        raise DEMFormatError(f"{path}: cell size ({x_step}, {y_step}); expected positive values")
    x_origin = _lower_left(header, "x", x_step, path)
    y_bottom = _lower_left(header, "y", y_step, path)

    try:
        values = np.array(body.split(), dtype=np.float64)
    except ValueError as exc:
        raise DEMFormatError(f"{path}: grid holds a value that is not a number ({exc})") from exc
    if values.size != rows * cols:
        raise DEMFormatError(
            f"{path}: {values.size} values; header says {rows} rows x {cols} columns = {rows * cols}"
        )
    values = values.reshape(rows, cols)
    metadata = {}
    if "nodata_value" in header:
        values[values == header["nodata_value"]] = np.nan
        metadata["nodata_value"] = header["nodata_value"]

    y_origin = y_bottom + rows * y_step
    georef, cell_size = grid_placement(x_origin, y_origin, x_step, y_step, rows, _prj_crs(path))
    return read_field(path, "esri-ascii", values.astype(np.float32), cell_size=cell_size, georef=georef,
                      metadata=metadata)


def _prj_paths(path: Path) -> tuple[Path, Path]:
    """Where the ``.prj`` of the grid ``path`` may be (either case)."""
    return path.with_suffix(".prj"), path.with_suffix(".PRJ")


def _prj_crs(path: Path) -> CRS | None:
    """The CRS of the ``.prj`` beside ``path`` (ESRI or OGC WKT), if there is one."""
    for prj in _prj_paths(path):
        if prj.is_file():
            text = prj.read_text(encoding="latin-1").strip()
            try:
                return CRS.from_wkt(text)
            except CRSError as exc:
                raise DEMFormatError(f"{prj}: not a CRS GDAL understands ({exc})") from exc
    return None


def prj_text(field: HeightField, path: Path) -> str | None:
    """The ``.prj`` to write beside ``path`` for ``field``: its CRS as ESRI
    WKT (what ArcGIS, QGIS and GDAL read), or None without a CRS.

    Raises
    ------
    DEMFormatError
        ``field`` has no CRS but a ``.prj`` of that stem exists: the grid
        would be read back in a CRS that is not its own.
    """
    from rasterio.enums import WktVersion

    from .gdal import field_crs

    crs = field_crs(field.georef)
    if crs is None:
        for prj in _prj_paths(path):
            if prj.exists():
                raise DEMFormatError(f"cannot write {path}: {prj} beside it names a CRS this terrain does not "
                                     "have (it has none); remove it or choose another name")
        return None
    return crs.to_wkt(version=WktVersion.WKT1_ESRI)


def write_esri_ascii(field: HeightField, fh: BinaryIO) -> None:
    """Write ``field`` as an ESRI ASCII grid.

    Values use 9 significant digits, enough for any float32 to read back
    exactly.  Nodata is ``NODATA_value -9999`` (one metre below the minimum
    instead, should a valid height be exactly -9999).  The lower-left corner
    comes from the georeference, or is (0, 0) without one; the cell size is
    the georeference step, else ``cell_size``, else 1.  Non-square cells are
    written with ``dx``/``dy`` (understood by GDAL) instead of ``cellsize``.

    Parameters
    ----------
    field : HeightField
    fh : binary file
        Open for writing.
    """
    rows, cols = field.shape
    geo = field.georef
    if geo is not None:
        x_step, y_step = geo.x_step, geo.y_step
        x_corner, y_corner = geo.x_origin, geo.y_origin - rows * geo.y_step
    else:
        y_step, x_step = field.cell_size or (DEFAULT_CELL, DEFAULT_CELL)
        x_corner = y_corner = 0.0
    heights = field.heights
    nodata = field.nodata
    nodata_value = NODATA_VALUE
    if np.any(heights == NODATA_VALUE):
        nodata_value = float(math.floor(field.min) - 1)

    lines = [f"ncols {cols}", f"nrows {rows}", f"xllcorner {float(x_corner)!r}", f"yllcorner {float(y_corner)!r}"]
    if x_step == y_step:
        lines.append(f"cellsize {float(x_step)!r}")
    else:
        lines += [f"dx {float(x_step)!r}", f"dy {float(y_step)!r}"]
    lines.append(f"NODATA_value {nodata_value:.9g}")
    fh.write(("\n".join(lines) + "\n").encode("ascii"))
    np.savetxt(fh, np.where(nodata, nodata_value, heights), fmt="%.9g")
