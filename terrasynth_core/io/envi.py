"""ENVI rasters: a headerless binary grid (``.bil``, ``.bsq``, ``.bip``) and
its text header (``.hdr``).

Only single-band files are read; with one band the three interleaves store
the same bytes.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import DEMFormatError
from ..heightfield import GeoReference, HeightField
from ._common import geographic_cell, read_field

#: ENVI ``data type`` codes of real-valued samples.
DATA_TYPES = {
    1: np.uint8,
    2: np.int16,
    3: np.int32,
    4: np.float32,
    5: np.float64,
    12: np.uint16,
    13: np.uint32,
    14: np.int64,
    15: np.uint64,
}

_ENTRY = re.compile(r"^\s*([^=\n]+?)\s*=\s*(\{[^}]*\}|[^\n]*)", re.MULTILINE)


def header_path(path: Path) -> Path:
    """The ``.hdr`` of an ENVI data file: ``name.hdr`` or ``name.bil.hdr``.

    Raises
    ------
    DEMFormatError
        If neither exists.
    """
    candidates = [
        path.with_suffix(".hdr"),
        path.with_suffix(".HDR"),
        path.with_name(path.name + ".hdr"),
        path.with_name(path.name + ".HDR"),
    ]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    raise DEMFormatError(
        f"{path}: ENVI header not found; expected {candidates[0].name} or {candidates[2].name} beside it"
    )


def parse_header(text: str, path: Path) -> dict[str, str]:
    """Entries of an ENVI header, keys lower-case, braces removed.

    Parameters
    ----------
    text : str
        Header content; must start with ``ENVI``.
    path : Path
        Header file, for messages.
    """
    if not text.lstrip().startswith("ENVI"):
        raise DEMFormatError(f"{path}: not an ENVI header (first line must be 'ENVI')")
    entries = {}
    for key, value in _ENTRY.findall(text):
        value = value.strip()
        if value.startswith("{"):
            value = value[1:-1].strip()
        entries[key.strip().lower()] = value
    return entries


def read_envi(path: Path) -> HeightField:
    """Read a single-band ENVI raster and its header.

    Parameters
    ----------
    path : Path
        The binary data file; the header is found by :func:`header_path`.

    Returns
    -------
    HeightField
        Heights with the ``data ignore value`` as NaN.  From ``map info``:
        for UTM, ``georef`` in metres (EPSG 326zz/327zz on WGS-84, 267zz on
        NAD27, 269zz on NAD83) and ``cell_size`` the pixel size; for
        Geographic Lat/Lon, ``georef`` in degrees (EPSG 4326 on WGS-84) and
        ``cell_size`` the ground size at the centre latitude; for other
        projections, the pixel size taken as metres and no EPSG.

    Raises
    ------
    DEMFormatError
        Missing header or header entries, several bands, unsupported data
        type, or a data file whose size does not match the header.
    """
    hdr = header_path(path)
    entries = parse_header(hdr.read_text(encoding="latin-1"), hdr)

    def integer(key: str, default: int | None = None) -> int:
        if key not in entries:
            if default is None:
                raise DEMFormatError(f"{hdr}: missing '{key}' entry")
            return default
        try:
            return int(entries[key])
        except ValueError as exc:
            raise DEMFormatError(f"{hdr}: '{key}' is {entries[key]!r}; expected an integer") from exc

    cols, rows = integer("samples"), integer("lines")
    bands = integer("bands", 1)
    if bands != 1:
        raise DEMFormatError(f"{hdr}: {bands} bands; expected a single-band elevation raster")
    code = integer("data type")
    if code not in DATA_TYPES:
        raise DEMFormatError(
            f"{hdr}: data type {code} is not supported; expected one of {sorted(DATA_TYPES)}"
        )
    order = ">" if integer("byte order", 0) == 1 else "<"
    dtype = np.dtype(DATA_TYPES[code]).newbyteorder(order)
    offset = integer("header offset", 0)

    expected = offset + rows * cols * dtype.itemsize
    size = path.stat().st_size
    if size != expected:
        raise DEMFormatError(
            f"{path}: {size} bytes; header {hdr.name} implies {expected} "
            f"({rows} lines x {cols} samples of {dtype.itemsize} bytes after {offset})"
        )
    raw = np.fromfile(path, dtype=dtype, offset=offset).reshape(rows, cols)
    heights = raw.astype(np.float32)
    metadata = {"data_type": code}
    if "data ignore value" in entries:
        ignore = float(entries["data ignore value"])
        # Floats compare in the file's precision (-3.4e38 is not exact in float32).
        heights[raw == (raw.dtype.type(ignore) if raw.dtype.kind == "f" else ignore)] = np.nan
        metadata["nodata_value"] = ignore

    georef, cell_size = _map_info(entries.get("map info"), hdr, (rows, cols))
    return read_field(path, "envi", heights, cell_size=cell_size, georef=georef, metadata=metadata)


def _datum_name(datum: str) -> str:
    """Short name of a datum as written in ``map info``: wgs84, nad27, nad83 or ''."""
    compact = re.sub(r"[^a-z0-9]", "", datum.lower())
    if compact in ("wgs84", "worldgeodeticsystem1984"):
        return "wgs84"
    if compact in ("nad27", "northamerica1927"):
        return "nad27"
    if compact in ("nad83", "northamerica1983"):
        return "nad83"
    return ""


def _map_info(
    value: str | None, hdr: Path, shape: tuple[int, int]
) -> tuple[GeoReference | None, tuple[float, float] | None]:
    """Georeference and cell size from a ``map info`` entry."""
    if not value:
        return None, None
    items = [item.strip() for item in value.split(",")]
    try:
        ref_x, ref_y, easting, northing, x_step, y_step = (float(v) for v in items[1:7])
    except ValueError as exc:
        raise DEMFormatError(f"{hdr}: cannot parse map info {{{value}}}") from exc
    # The reference pixel is 1-based and (1, 1) is the upper-left corner of
    # the first cell, so shift the reference point back to that corner.
    x_origin = easting - (ref_x - 1) * x_step
    y_origin = northing + (ref_y - 1) * y_step
    projection = items[0].lower()
    # After the six numbers come positional items (zone, hemisphere, datum)
    # and optional "key=value" items such as "units=Meters".
    rest, options = [], {}
    for item in items[7:]:
        key, equals, val = item.partition("=")
        if equals:
            options[key.strip().lower()] = val.strip().lower()
        else:
            rest.append(item)

    if projection.startswith("geographic"):
        datum = _datum_name(rest[0]) if rest else ""
        epsg = 4326 if datum == "wgs84" else None
        lat = y_origin - shape[0] * y_step / 2
        georef = GeoReference(x_origin, y_origin, x_step, y_step, epsg)
        return georef, geographic_cell(lat, y_step, x_step)

    epsg = None
    if projection == "utm" and len(rest) >= 3:
        zone = int(rest[0])
        south = rest[1].lower().startswith("s")
        datum = _datum_name(rest[2])
        if datum == "wgs84":
            epsg = (32700 if south else 32600) + zone
        elif datum == "nad27" and not south:
            epsg = 26700 + zone
        elif datum == "nad83" and not south:
            epsg = 26900 + zone
    metres = 0.3048 if options.get("units", "meters").startswith("f") else 1.0
    georef = GeoReference(x_origin, y_origin, x_step, y_step, epsg)
    return georef, (y_step * metres, x_step * metres)
